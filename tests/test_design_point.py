"""The design point of eq 30: gmt.design_point and gmt.Transducer.

The cases, each a way the model is driven off its design point: the 50 Hz model driven at 100 Hz (44.3 um peak to peak
instead of 36.0), u = 0 (DC: 13 um of rise with no current), a step of current
(contraction on a positive step); and the paper's own drives (Table 1's 50 Hz and 100 Hz
points, the compensated u = 2.2 + 2.2 cos(100 pi t) V of Figure 9), which must never be
flagged. Where the model follows the drive, the reference is the periodic steady state in
closed form (gmt.loop_metrics, harmonic balance of eqs 25-30), not the time stepper.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import gmt
from gmt.design_point import AMPLITUDE_TOLERANCE, FREQUENCY_TOLERANCE, REASONS, DriveMonitor

H = 1e-5  # the paper's drive sampled at 100 kHz, as the FMU's DefaultExperiment


def run(u, duration, h=H, excitation=None, drive=None):
    """Step a transducer with control u(t); return (transducer, t, y, flag, current)."""
    tr = gmt.Transducer(excitation=excitation, drive=drive)
    n = int(round(duration / h))
    t = np.arange(n) * h
    outs = [tr.step(float(u(tk)), h) for tk in t]
    y = np.array([o.displacement for o in outs])
    flag = np.array([o.outside_design_point for o in outs])
    current = np.array([o.current for o in outs])
    return tr, t, y, flag, current


def cosine(f, a=1.0, offset=0.0):
    return lambda t: offset + a * math.cos(2 * math.pi * f * t)


def steady_ptp(params, f, i_m):
    """Peak-to-peak y of the periodic steady state at (f, I_m), closed form [m]."""
    point = gmt.operating_point(params, gmt.Excitation(f, i_m))
    return gmt.loop_metrics(params, point)["peak_to_peak"]


# -- the paper's drives are inside -------------------------------------------------------------
@pytest.mark.parametrize("drive,u", [
    (None, cosine(50.0)),  # Table 1's 50 Hz, 1 A point, uncompensated
    (gmt.DriveParameters(compensated=True), cosine(50.0, 2.2, 2.2)),  # Figure 9, sampled
    (gmt.DriveParameters(compensated=True, branch_rule="demand"), cosine(50.0, 2.2, 2.2)),
    (gmt.DriveParameters(compensated=True, compensator_period=0.0), cosine(50.0, 2.2, 2.2)),
])
def test_the_papers_drive_is_inside_its_design_point(drive, u):
    tr, _, _, flag, _ = run(u, 0.2, drive=drive)  # ten periods
    assert not flag.any()
    assert tr.monitor.departures == 0
    f, a = tr.monitor.measured
    assert f == pytest.approx(50.0, rel=1e-9) and a == pytest.approx(1.0, rel=1e-3)


def test_table_1_100_hz_point_with_random_steps_is_inside():
    # 100 Hz, 1 A with the frequency set to 100 Hz, steps of 2 to 40 us at random
    rng = np.random.default_rng(5)
    tr = gmt.Transducer(excitation=gmt.Excitation(100.0, 1.0, 0.0531))
    t, flagged = 0.0, False
    for h in rng.uniform(2e-6, 4e-5, 8000):
        flagged |= tr.step(math.cos(2 * math.pi * 100.0 * t), h).outside_design_point
        t += h
    assert not flagged and t > 0.15


# -- driven off the design point -------------------------------------------------------------------------
def test_100_hz_drive_with_frequency_50_is_flagged(params):
    # 44.3 um peak to peak instead of the 36.0 um of the model at 100 Hz
    tr, t, y, flag, _ = run(cosine(100.0), 0.06)
    assert 44.0e-6 < np.ptp(y[t > 0.03]) < 44.6e-6  # the wrong number a user saw
    assert steady_ptp(params, 100.0, 1.0) == pytest.approx(36.0e-6, abs=0.05e-6)
    # judged at the end of the drive's first full period: upward zero crossings at
    # 7.5 ms and 17.5 ms; flagged from then on
    first = t[np.argmax(flag)]
    assert 0.0175 <= first <= 0.0176 and flag[t >= first].all()
    assert REASONS[tr.monitor.reason] == "frequency"
    assert tr.monitor.measured[0] == pytest.approx(100.0, rel=1e-6)
    assert "100 Hz" in tr.monitor.describe() and "50 Hz" in tr.monitor.describe()


def test_100_hz_drive_is_followed_with_follow_drive(params):
    tr, t, y, flag, _ = run(cosine(100.0), 0.06, excitation=gmt.Excitation(follow_drive=True))
    assert not flag.any()
    assert (tr.point.frequency, tr.point.current_amplitude) == pytest.approx((100.0, 1.0),
                                                                             rel=1e-6)
    # after the switch (17.5 ms) the transient decays with the slow pole (7e3 1/s):
    # the last 3 periods are the model's at 100 Hz (the closed form, to 0.2 %)
    assert np.ptp(y[t > 0.03]) == pytest.approx(steady_ptp(params, 100.0, 1.0), rel=2e-3)


def test_dc_drive_is_flagged(params):
    # u = 0 gives 13 um of rise with no current (eq 31's quadrature +-I_m)
    tr, t, y, flag, current = run(lambda t: 0.0, 0.04)
    assert not current.any()
    rise = y[-1] - gmt.bias_displacement(params)
    assert 12e-6 < rise < 14e-6
    # flagged from the first sample (0 A is not the peak I_m at which the model's
    # drive I_m cos(w t) starts), as standing still from the second, not after the first
    # half period of the operating point (10 ms at 50 Hz)
    assert flag.all()
    assert REASONS[tr.monitor.reason] == "standing still"
    assert tr.monitor.departures == 1


def test_a_current_at_rest_is_flagged_at_the_first_sample_and_said_why():
    tr = gmt.Transducer()
    out = tr.step(0.0, H)
    assert out.outside_design_point and tr.monitor.provisional
    assert REASONS[tr.monitor.reason] == "start" and "first sample, 0 A" in tr.monitor.describe()
    # the outputs once reported (B = 0.027 T, M = 21 kA/m, F = 1.7 kN at zero field) are
    # those of eq 31's quadrature term alone, +I_m: H_q = N I_m/(k_f L) = 14.77 kA/m (eq 1)
    assert out.magnetics.field == 0.0
    assert out.magnetics.quadrature_field == pytest.approx(1300 * 1.0 / (1.1 * 0.08))
    assert (out.magnetics.flux_density, out.magnetics.magnetization,
            out.magnetics.force) == pytest.approx((0.027, 21.4e3, 1.70e3), rel=0.01)


@pytest.mark.parametrize("f,peak,h", [(50.0, 1.0, H), (50.0, -1.0, H), (100.0, 1.0, 4e-5),
                                      (50.0, 1.0 - 0.5 * AMPLITUDE_TOLERANCE, H)])
def test_the_papers_drive_is_not_flagged_at_the_first_sample(f, peak, h):
    # i = I_m cos(w t) starts at its peak, where the quadrature sqrt(I_m^2 - i^2) is zero
    # whatever its branch; so does the trough, and a peak within the amplitude tolerance
    tr = gmt.Transducer(excitation=gmt.Excitation(f, 1.0))
    assert not tr.step(peak, h).outside_design_point
    assert not tr.monitor.provisional and tr.monitor.departures == 0
    # and a first sample just outside the tolerance is (the rule can fail)
    tr = gmt.Transducer(excitation=gmt.Excitation(f, 1.0))
    assert tr.step(peak * (1.0 - 1.5 * AMPLITUDE_TOLERANCE), h).outside_design_point


def test_the_compensated_drive_is_not_judged_at_its_first_sample():
    # Figure 9's compensated u = 2.2 + 2.2 cos(100 pi t) V starts at a current of 0.70 A, not
    # at I_m: the compensator's current is no sinusoid, so the first-sample rule is off there
    tr = gmt.Transducer(drive=gmt.DriveParameters(compensated=True))
    out = tr.step(4.4, H)
    assert abs(out.current) < 0.9 and not out.outside_design_point


@pytest.mark.parametrize("f", [50.0, 100.0])
def test_a_sinusoid_starting_at_zero_is_not_taken_for_a_current_at_rest(f):
    # the drive sin(2 pi f t) starts where u = 0 does: flagged at that first sample, whose
    # outputs are u = 0's (eq 31 takes the + branch, a falling current; sin rises there,
    # its quadrature is -I_m), and cleared at the second, as it moves by I_m w h per step,
    # four times the rest rule's bound I_m sin(pi f h)/2 (design_point's docstring)
    tr, t, _, flag, _ = run(lambda t: math.sin(2 * math.pi * f * t), 0.1,
                            excitation=gmt.Excitation(f, 1.0))
    assert flag[0] and not flag[1:].any() and tr.monitor.departures == 1
    # the first output is off the drive's loop: I_m sin(w t) = I_m cos(w t - pi/2) has the
    # quadrature I_m sin(w t - pi/2) = -I_m at t = 0 (eq 4: H_q = -H_m), the model +H_m;
    # from the second sample on the branch is the drive's
    tr = gmt.Transducer(excitation=gmt.Excitation(f, 1.0))
    h_m = 1300 * 1.0 / (1.1 * 0.08)  # eq 1 with Table 2's N, k_f, L
    first, second = (tr.step(math.sin(2 * math.pi * f * k * H), H) for k in (0, 1))
    assert first.magnetics.quadrature_field == pytest.approx(h_m)
    assert second.magnetics.quadrature_field == pytest.approx(
        -h_m * math.cos(2 * math.pi * f * H), rel=1e-6)


def test_a_current_at_rest_is_judged_without_the_compensator_only():
    # the compensator holds its current over its sample period (100 us = 10 FMU steps):
    # equal samples there are no rest; its still demand is caught by the half-period rule
    _, t, _, flag, _ = run(lambda t: 0.0, 0.04, drive=gmt.DriveParameters(compensated=True))
    assert not flag[t < 0.0099].any() and flag[t >= 0.0101].all()


def test_a_step_of_current_is_flagged_at_the_step(params):
    # a step of current is read by eq 31 as a point on the 50 Hz sinusoid (its
    # quadrature from the direction of the step): flagged at the step, and while held
    tr, t, y, flag, _ = run(lambda t: 1.0 if t >= 5e-3 else 0.0, 0.04)
    k = int(round(5e-3 / H))
    # the current at rest at zero before the step is flagged from the first sample
    assert flag.all()
    assert tr.monitor.departures == 1  # outside once, and it stays
    # with the compensator (whose current jumps where Figure 9 switches branch, so jumps
    # are not judged), the held demand is caught as standing still
    tr, t, _, flag, _ = run(lambda t: 4.4 if t >= 5e-3 else 0.0, 0.04,
                            drive=gmt.DriveParameters(compensated=True))
    assert flag[-1] and REASONS[tr.monitor.reason] == "standing still"


def test_half_the_amplitude_is_flagged_or_followed(params):
    tr, t, y, flag, _ = run(cosine(50.0, 0.5), 0.1)
    assert flag[-1] and REASONS[tr.monitor.reason] == "amplitude"
    tr, t, y, flag, _ = run(cosine(50.0, 0.5), 0.1, excitation=gmt.Excitation(follow_drive=True))
    # the first sample, 0.5 A, is not the peak of the 1 A drive the model starts at (the
    # first-sample rule); from the second on the model follows the drive
    assert flag[0] and not flag[1:].any()
    assert tr.point.current_amplitude == pytest.approx(0.5, rel=1e-6)
    assert np.ptp(y[t > 0.06]) == pytest.approx(steady_ptp(params, 50.0, 0.5), rel=2e-3)


def test_an_offset_is_flagged_and_not_followed():
    exc = gmt.Excitation(follow_drive=True)
    tr, _, _, flag, _ = run(cosine(50.0, 1.0, 0.1), 0.1, excitation=exc)
    assert flag[-1] and REASONS[tr.monitor.reason] == "offset"
    assert tr.point.frequency == 50.0 and tr.point.current_amplitude == 1.0


@pytest.mark.parametrize("ratio,outside", [(1.0 + 0.8 * FREQUENCY_TOLERANCE, False),
                                           (1.0 + 1.2 * FREQUENCY_TOLERANCE, True),
                                           (1.0 - 1.2 * FREQUENCY_TOLERANCE, True)])
def test_frequency_tolerance(ratio, outside):
    _, _, _, flag, _ = run(cosine(50.0 * ratio), 0.1)
    assert bool(flag[-1]) is outside and bool(flag.any()) is outside


@pytest.mark.parametrize("ratio,outside", [(1.0 - 0.5 * AMPLITUDE_TOLERANCE, False),
                                           (1.0 - 1.5 * AMPLITUDE_TOLERANCE, True),
                                           (1.0 + 1.5 * AMPLITUDE_TOLERANCE, True)])
def test_amplitude_tolerance(ratio, outside):
    _, _, _, flag, _ = run(cosine(50.0, ratio), 0.1)
    assert bool(flag[-1]) is outside


def test_the_tolerances_keep_the_stroke_within_2_5_percent(params):
    # the module's rationale, measured: at the paper's 50 Hz, 1 A point a drive off by the
    # frequency or the amplitude tolerance changes the peak-to-peak stroke by less than
    # 2.5 % against the model at the drive's own point
    def ptp_mismatch(f_drive, a_drive):
        _, t, y, _, _ = run(cosine(f_drive, a_drive), 0.12)
        return np.ptp(y[t > 0.06]) / steady_ptp(params, f_drive, a_drive) - 1.0
    for f_drive, a_drive in ((50.0 * (1 + FREQUENCY_TOLERANCE), 1.0),
                             (50.0 * (1 - FREQUENCY_TOLERANCE), 1.0),
                             (50.0, 1.0 + AMPLITUDE_TOLERANCE),
                             (50.0, 1.0 - AMPLITUDE_TOLERANCE)):
        assert abs(ptp_mismatch(f_drive, a_drive)) < 0.025, (f_drive, a_drive)


def test_the_flag_clears_when_the_drive_returns():
    tr, t, _, flag, _ = run(lambda t: math.cos(2 * math.pi * (100.0 if t < 0.05 else 50.0) * t),
                            0.14)
    assert flag[(t > 0.02) & (t < 0.05)].all()
    assert not flag[t > 0.11].any()  # a full 50 Hz period after the change
    assert tr.monitor.departures == 1


def test_coarse_steps_are_not_taken_for_standing_still():
    # a step of T/6 (3.3 ms at 50 Hz) samples the paper's drive six times a period: no
    # half-period window can be judged, and the periods still are
    _, _, _, flag, _ = run(cosine(50.0), 0.2, h=1.0 / 300.0)
    assert not flag.any()


def test_state_round_trip_replays_bit_identically():
    # save mid-way through a followed 100 Hz drive (after the switch), run on, restore,
    # replay: the monitor and the followed operating point are part of the state
    exc = gmt.Excitation(follow_drive=True)
    tr = gmt.Transducer(excitation=exc)
    u = cosine(100.0)
    for k in range(2500):
        tr.step(u(k * H), H)
    state = tr.get_state()
    first = [tuple(tr.step(u(k * H), H)[2:4]) for k in range(2500, 3500)]
    fresh = gmt.Transducer(excitation=exc)  # at 50 Hz until the state moves it
    fresh.set_state(state)
    assert fresh.point.frequency == pytest.approx(100.0, rel=1e-6)
    again = [tuple(fresh.step(u(k * H), H)[2:4]) for k in range(2500, 3500)]
    assert again == first
    tr.reset()
    assert (tr.point.frequency, tr.monitor.departures) == (50.0, 0)


def test_follow_drive_needs_the_papers_model():
    with pytest.raises(gmt.ParameterError, match="follow_drive"):
        gmt.Transducer(excitation=gmt.Excitation(follow_drive=True),
                       variant=gmt.ModelVariant.from_name("transport_delay", {"delay_s": 1e-4}))
    with pytest.raises(gmt.ParameterError, match="follow_drive"):
        gmt.Excitation(follow_drive=1)


def test_monitor_state_size_and_round_trip():
    m = DriveMonitor(50.0, 1.0)
    for k in range(1234):
        m.observe(math.cos(2 * math.pi * 70.0 * k * H), H)
    state = m.get_state()
    assert len(state) == DriveMonitor.STATE_SIZE
    other = DriveMonitor(50.0, 1.0)
    other.set_state(state)
    assert other.get_state() == state
