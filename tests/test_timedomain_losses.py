"""The time-domain magnetics stepped along measured flux waveforms, against the closed forms.

The extended dynamic law (gmt.timedomain.dynamic) has closed-form losses per
cycle for straight-segment waveforms; here the stepped model
(TimeDomainMagnetics.field / move, flux driven) integrates H dB over a cycle
of real MagNet rows and must land on them. The solver's failure path is
driven too.
"""
import math

import numpy as np
import pytest

import gmt
from gmt.timedomain import magnetics as td_magnetics
from gmt.timedomain.dynamic import relaxation_lag, segment_losses, sine_losses
from gmt.timedomain.hysteresis import BranchFunction, BranchSum, cycle_loss_per_coefficient
from gmt.timedomain.magnetics import TimeDomainMagnetics
from gmt.timedomain.parameters import TimeDomainParameters
from smeha.coreloss.measurements import read_magnet
from smeha.coreloss.models import ExtendedLaw

#: A law of the size fitted to N87 (smeha losses N87). K_e = 0: the stepped eddy term is
#: exponentially fitted for current-driven steps (TimeDomainMagnetics.eddy_stiffness), so
#: it is k_e dB/dt only for steps short against k_e / (dH_hys/dB).
LAW = ExtendedLaw(hysteresis_coefficient=279.0, steinmetz_exponent=2.52,
                  eddy_coefficient=0.0, excess_coefficient=1e-2, rate_coefficient=6.2e-8,
                  rate_exponent=2.5, swing_exponent=2.56, relaxation_coefficient=51.4,
                  relaxation_time=2.2e-6)
#: The same with a second, steeper hysteresis density (its size fitted to N49).
TWO_SLOPE = ExtendedLaw(**{**LAW.as_dict(), "second_hysteresis_coefficient": 900.0,
                           "second_steinmetz_exponent": 3.4})
#: A Rayleigh-like exponent 3 below a break at 28 mT and 2 above, both densities broken
#: (the size fitted to N87 by smeha losses).
BROKEN = ExtendedLaw(**{**TWO_SLOPE.as_dict(), "hysteresis_coefficient": 1500.0,
                        "steinmetz_exponent": 2.98, "steinmetz_break": 0.028,
                        "steinmetz_exponent_high": 2.0})


def _magnetics(law):
    paper, extra = law.time_domain_parameters()
    params = gmt.TransducerParameters(**paper)
    td = TimeDomainParameters(steinmetz_upper=0.5, **extra)
    return TimeDomainMagnetics(params, td)


def _stepped_cycle_loss(mag, durations, swings, start, steps_per_segment=400):
    """Loop integral of H dB over the second of two cycles, [J/m^3] (flux driven).

    The lossless reversible term and H_irr by the trapezoidal rule (their
    backward-Euler sums carry a spurious (dB)^2 per step); the dynamic fields
    as the model computes them, exact for a constant rate.
    """
    mag.field(start, 1.0)
    mag.move(start)
    energy = 0.0
    for cycle in range(2):
        b = start
        for t, db in zip(durations, swings):
            if t <= 0.0:
                continue
            h = t / steps_per_segment
            for k in range(steps_per_segment):
                new = start + (b - start) + db * (k + 1) / steps_per_segment
                old, h_old = mag.flux_density, mag.hysteresis.h
                field = mag.field(new, h)
                mag.move(new)
                h_new = mag.hysteresis.h
                dynamic = field - mag.nu * new - h_new
                if cycle == 1:
                    energy += (dynamic + 0.5 * (h_old + h_new)) * (new - old)
            b += db
    return energy


@pytest.mark.parametrize("family, law", [("triangle", LAW), ("trapezoid", LAW),
                                         ("triangle", TWO_SLOPE), ("trapezoid", TWO_SLOPE),
                                         ("trapezoid", BROKEN)],
                         ids=["triangle", "trapezoid", "triangle-two-slope",
                              "trapezoid-two-slope", "trapezoid-broken-exponent"])
def test_stepped_magnetics_match_closed_form_on_real_rows(family, law):
    # reference: the closed forms (eddy, excess, rate field, Maxwell element's periodic
    # state) and the operator's K_h B^n; tolerance 0.5 %: backward Euler takes H_irr
    # at each step's end, an error of order 1/steps on the hysteresis part
    data = read_magnet("N87")
    rows = np.flatnonzero(data.family(family) & (data.frequency == 200e3))[::400][:3]
    mag = _magnetics(law)
    for k in rows:
        mag.reset()
        dur, sw = data.durations[k], data.swings[k]
        stepped = _stepped_cycle_loss(mag, dur, sw, -0.5 * sw[0])
        closed = law.predict(data.subset(np.arange(len(data)) == k))[0] / data.frequency[k]
        assert stepped == pytest.approx(closed, rel=5e-3)


def test_second_density_adds_its_loss_per_cycle():
    # reference: W(a) = integral rho 4 r (a - r) dr is linear in rho, so two densities
    # lose K_h a^n + K_h2 a^n2 per cycle for r_0 <= a <= r_max (hysteresis module
    # docstring); n2 = 3.6 > 3, a density growing with r
    one = BranchFunction(279.0, 2.52, 2e-3, 0.5)
    two = BranchFunction(900.0, 3.6, 2e-3, 0.5)
    both = BranchSum(one, two)
    for a in (0.01, 0.1, 0.3):
        assert both.cycle_loss(a) == pytest.approx(279.0 * a ** 2.52 + 900.0 * a ** 3.6,
                                                   rel=1e-12)
        assert both.value_and_slope(a) == pytest.approx((both.value(a), both.slope(a)))
    with pytest.raises(gmt.ParameterError, match="steinmetz_exponent"):
        BranchFunction(900.0, 4.5, 2e-3, 0.5)


@pytest.mark.parametrize("m", [1.05, 1.6, 2.0, 3.5])
def test_broken_density_loss_per_cycle(m):
    # reference: W(a) = integral rho(r) 4 r (a - r) dr by adaptive quadrature (scipy's
    # quad, sharing nothing with the closed forms) over the density c r^(n-3) below r_b and
    # c r_b^(n-m) r^(m-3) above, c = K_h n (n-1)/4; the operator's stops below r_0 are
    # its one-stop replacement with the same W for a >= r_0 (module docstring), so the
    # quadrature runs from 0. rel 1e-9: quad's tolerance
    from scipy.integrate import quad

    k_h, n, knee = 1500.0, 2.98, 0.028
    c = k_h * n * (n - 1.0) / 4.0

    def rho(r):
        return c * r ** (n - 3.0) if r <= knee else c * knee ** (n - m) * r ** (m - 3.0)

    branch = BranchFunction(k_h, n, 2e-3, 0.5, knee, m)
    for a in (0.01, 0.028, 0.05, 0.3):
        exact = quad(lambda r: rho(r) * 4.0 * r * (a - r), 0.0, a,
                     points=[knee] if knee < a else None, epsabs=0.0, epsrel=1e-12)[0]
        assert branch.cycle_loss(a) == pytest.approx(exact, rel=1e-9)
        assert k_h * cycle_loss_per_coefficient(a, n, knee, m) == pytest.approx(exact, rel=1e-9)
        # G' is G's derivative across the break (central difference, step 1e-7 T)
        x = 2.0 * a
        numeric = (branch.value(x + 1e-7) - branch.value(x - 1e-7)) / 2e-7
        assert branch.slope(x) == pytest.approx(numeric, rel=1e-6)
        assert branch.value_and_slope(x) == pytest.approx((branch.value(x), branch.slope(x)))
    # no break within r_max: the single density, unchanged
    plain, high = BranchFunction(k_h, n, 2e-3, 0.5), BranchFunction(k_h, n, 2e-3, 0.5, 0.6, m)
    assert plain.value_and_slope(0.3) == high.value_and_slope(0.3)


def test_break_parameters_checked():
    with pytest.raises(gmt.ParameterError, match="steinmetz_break"):
        TimeDomainParameters(steinmetz_break=1e-3)
    with pytest.raises(gmt.ParameterError, match="steinmetz_exponent_high"):
        TimeDomainParameters(steinmetz_exponent_high=4.5)
    with pytest.raises(gmt.ParameterError, match="steinmetz_break"):
        BranchFunction(1.0, 2.5, 2e-3, 0.5, 1e-3)


def test_relaxation_loss_never_negative():
    # passivity: the Maxwell element's loss per cycle is the dashpot's k x^2 / tau >= 0
    rng = np.random.default_rng(3)
    dur = rng.uniform(1e-8, 1e-5, (200, 5))
    sw = rng.normal(0.0, 0.1, (200, 5))
    sw[:, -1] = -sw[:, :-1].sum(1)
    for tau in (1e-8, 1e-6, 1e-4):
        parts = segment_losses(dur, sw, np.abs(sw).max(1), 1.0, 1.0, 1.0, 2.5, 2.5, 1.0, tau)
        assert all(np.all(p >= -1e-15 * np.abs(p).max()) for p in parts)


def test_relaxation_sine_is_debye():
    # reference: a Debye relaxation's loss per cycle pi k B^2 w tau / (1 + (w tau)^2),
    # peaking at w tau = 1 with pi k B^2 / 2 (Bertotti 1998, ch. 3)
    tau = 1e-6
    f = 1.0 / (2.0 * math.pi * tau)
    *_, relax = sine_losses([f], [0.1], 0.0, 0.0, 0.0, 2.0, 2.0, 3.0, tau)
    assert relax[0] == pytest.approx(math.pi * 3.0 * 0.01 / 2.0, rel=1e-12)


def test_relaxation_lag_exact_for_constant_rate():
    # reference: x(t) = r tau (1 - exp(-t/tau)) from rest, written out
    assert relaxation_lag(0.0, 2.0, 3e-6, 1e-6) == pytest.approx(2e-6 * (1 - math.exp(-3)))


def test_extension_off_by_default():
    assert not TimeDomainParameters().has_extension
    assert TimeDomainParameters().second_hysteresis_coefficient == 0.0


def test_extension_parameters_checked():
    with pytest.raises(gmt.ParameterError, match="relaxation_time"):
        TimeDomainParameters(relaxation_time=0.0)
    with pytest.raises(gmt.ParameterError, match="rate_exponent"):
        TimeDomainParameters(rate_exponent=5.0)
    with pytest.raises(gmt.ParameterError, match="second_steinmetz_exponent"):
        TimeDomainParameters(second_steinmetz_exponent=1.0)
    with pytest.raises(gmt.ParameterError, match="second_hysteresis_coefficient"):
        TimeDomainParameters(second_hysteresis_coefficient=-1.0)


def test_flux_density_for_refuses_nan():
    # before one solver served both, a NaN magnetisation ran 60 iterations and came back NaN
    mag = TimeDomainMagnetics()
    with pytest.raises(gmt.ParameterError, match="magnetization"):
        mag.flux_density_for(float("nan"))


@pytest.mark.parametrize("call", ["solve", "flux_density_for"])
def test_solver_raises_when_it_does_not_converge(monkeypatch, call):
    # one safeguarded Newton for both: cut to one iteration it cannot meet the
    # tolerance, and says so through gmt's run-error family (flux_density_for returned
    # an unconverged B without a word before)
    monkeypatch.setattr(td_magnetics, "_MAX_ITERATIONS", 1)
    mag = TimeDomainMagnetics()
    with pytest.raises(gmt.ConvergenceError, match="no convergence"):
        if call == "solve":
            mag.solve(3000.0, 1e-3)
        else:
            mag.flux_density_for(2e4)
    assert issubclass(gmt.ConvergenceError, gmt.RunError)


def _loop_area(branch, a, steps=2000):
    """integral H_irr dB around the operator's cycle between -a and a, [J/m^3]: the second of
    two cycles, B stepped uniformly, H_irr by the trapezoidal rule."""
    from gmt.timedomain.hysteresis import SteinmetzHysteresis

    op = SteinmetzHysteresis(branch)
    op.move(-a)
    up = np.linspace(-a, a, steps + 1)
    area = 0.0
    for cycle in range(2):
        for path in (up, up[::-1]):
            h = np.array([op.move(b) for b in path])  # the first point is the present one
            if cycle == 1:
                area += float(np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(path)))
    return area


def test_the_loss_study_and_the_operator_share_one_cycle_loss_law():
    # reference: W(a) = integral rho(r) 4 r (a - r) dr by adaptive quadrature (scipy's quad,
    # sharing nothing with the closed forms) over the density c r^(n-3) below r_b and
    # c r_b^(n-m) r^(m-3) above, c = K_h n (n-1)/4 (module docstring): from 0 to a for the
    # loss study (r_0 -> 0, r_max -> inf); for the operator from r_0 to min(a, r_max) plus
    # its one stop at r_1 = r_0 (n-1)/n of weight w = c r_0^(n-2) n/(n-1)^2, whose loop is
    # the parallelogram 4 w r_1 (a - r_1). rel 1e-9: quad's tolerance. The grid holds
    # half-swings below r_1 and r_0, the break r_b and either side of it, and r_max and above
    from scipy.integrate import quad

    k_h, n, m, r0, knee, rmax = 1500.0, 2.98, 2.0, 2e-3, 0.028, 0.5
    c = k_h * n * (n - 1.0) / 4.0
    r1, w = r0 * (n - 1.0) / n, c * r0 ** (n - 2.0) * n / (n - 1.0) ** 2

    def rho(r):
        return c * r ** (n - 3.0) if r <= knee else c * knee ** (n - m) * r ** (m - 3.0)

    def w_quad(a, lo, hi):
        top = min(a, hi)
        if top <= lo:
            return 0.0
        return quad(lambda r: rho(r) * 4.0 * r * (a - r), lo, top,
                    points=[knee] if lo < knee < top else None, epsabs=0.0, epsrel=1e-12)[0]

    branch = BranchFunction(k_h, n, r0, rmax, knee, m)
    grid = np.array([0.5 * r1, 0.9 * r0, r0, 0.01, knee, 0.03, 0.3, rmax, 0.8])
    study = k_h * cycle_loss_per_coefficient(grid, n, knee, m)
    assert isinstance(cycle_loss_per_coefficient(0.01, n, knee, m), float)
    for a, w_study in zip(grid, study):
        operator = w_quad(a, r0, rmax) + 4.0 * w * r1 * max(a - r1, 0.0)
        assert branch.cycle_loss(a) == pytest.approx(operator, rel=1e-9), a
        assert w_study == pytest.approx(w_quad(a, 0.0, math.inf), rel=1e-9), a
        if r0 <= a <= rmax:  # where the two uses are one law
            assert branch.cycle_loss(a) == pytest.approx(w_study, rel=1e-12), a
    # below r_0 and above r_max the operator's own loop (its G, not the closed form) is the
    # operator's loss; rel 1e-5: the trapezoidal rule over 2000 steps of a smooth branch
    for a in (0.5 * r0, 0.9 * r0, 0.3, 0.8):
        assert _loop_area(branch, a) == pytest.approx(branch.cycle_loss(a), rel=1e-5), a
