"""The compensated drive converges in the compensator's sample period T_c.

References: eq 41 (the compensated stroke between the valve switching instants, u's
minimum to its maximum) and the demand the compensator is asked for, y_d = 10 um/V u
(Figure 9, DriveParameters.displacement_per_volt): u = a + a cos(w t) demands a stroke
of 20 a um, which a compensator that tracks its demand delivers. The figures below
hold for the default root rule ("demand", gmt.parameters.BRANCH_RULE) at every T_c
from 5 us to the default 100 us; Figure 9's literal rule ("control") only at
T_c <= 10 us (gmt.inverse, "Sampling"). benchmarks/compensator_convergence.py prints
the whole curve, with the co-simulated flows.
"""
import pytest

import gmt
from smeha.studies import flow, paper
from gmt.parameters import BRANCH_RULE, COMPENSATOR_PERIOD


@pytest.mark.parametrize("frequency", [50.0, 100.0])
def test_default_compensator_is_converged_in_its_sample_period(frequency):
    # the default T_c (100 us) within 1 % of T_c = 5 us, twenty times finer (the required
    # bound); measured +0.02 % at 50 Hz and +0.18 % at 100 Hz
    default = flow.free_dy(frequency, "compensated")
    fine = flow.free_dy(frequency, "compensated", compensator_period=5e-6)
    assert BRANCH_RULE == "demand" and COMPENSATOR_PERIOD == 1e-4
    assert default == pytest.approx(fine, rel=1e-2)


@pytest.mark.parametrize("frequency", [50.0, 100.0])
def test_compensated_stroke_is_the_demanded_stroke(frequency):
    # 20 a um demanded (a = 2.2 V at 50 Hz: 44 um; 1.5 V at 100 Hz: 30 um), within the
    # static stroke (44.5 um and 36.2 um): delivered within 0.5 % (measured 0.0 % and
    # +0.08 %), at the default T_c and at 10 us
    demanded = 20e-6 * flow.control_amplitude(frequency)
    for period in (COMPENSATOR_PERIOD, 1e-5):
        dy = flow.free_dy(frequency, "compensated", compensator_period=period)
        assert dy == pytest.approx(demanded, rel=5e-3), period


def test_figure_9_rule_converges_only_at_fine_sample_periods():
    # Figure 9's rule switches roots at the first sample after u's peak, 0.15 ms after
    # the demanded magnetisation's peak at 50 Hz: the rod's dip that follows falls before
    # or after the valves' switch by where the samples fall. At 100 us the stroke is
    # ~19 % above the converged one (44.0 against 37.0 um), at 10 us within 1 %.
    def dy(period):
        return flow.free_dy(50.0, "compensated", "control", compensator_period=period)
    converged = dy(5e-6)
    assert dy(1e-4) / converged - 1.0 > 0.1
    assert dy(1e-5) == pytest.approx(converged, rel=1e-2)


@pytest.mark.parametrize("frequency", [50.0, 100.0])
def test_paper_and_flow_agree_on_the_compensated_free_stroke(frequency):
    # smeha paper samples at every step of 1/(2000 f) (T_c 0, the continuous limit);
    # smeha flow's free transducer at the default 100 us: within 1 % (measured 0.02 %
    # and 0.18 %)
    t3 = paper.paperdata.table3()
    a = dict(zip(t3["frequency"], t3["control_amplitude"]))[frequency]
    run = paper.compensated_run(gmt.TransducerParameters(), frequency, float(a))
    y = run.displacement
    dy_paper = y[run.control.argmax()] - y[run.control.argmin()]
    assert run.branch_rule == BRANCH_RULE
    assert flow.free_dy(frequency, "compensated") == pytest.approx(dy_paper, rel=1e-2)
