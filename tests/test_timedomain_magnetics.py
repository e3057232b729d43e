"""Time-domain magnetics (gmt.timedomain): the paper's loss separation as a field separation.

References: the paper's eqs 7, 9, 11 (loss per cycle under a sinusoidal B) and
Table 1; Bertotti, *Hysteresis in Magnetism* (1998), ch. 12 (field separation);
Abramowitz & Stegun 6.2 (the Beta integral behind the excess-loss constant);
Mayergoyz, *Mathematical Models of Hysteresis* (2003), ch. 1 (wiping out, congruent
minor loops).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, special

import gmt
from gmt.timedomain import hysteresis, separation
from gmt.timedomain.magnetics import TimeDomainMagnetics, TimeDomainStepper
from gmt.timedomain.parameters import TimeDomainParameters

K_H, N_EXP, K_E, K_EX = 85805.0, 1.8092, 2753.39, 895.80  # paper, Table 2


# ------------------------------------------------------------------ the excess-loss constant


def test_excess_constant_against_its_closed_form():
    # <|cos|^1.5> = Gamma(5/4) / (sqrt(pi) Gamma(7/4)) (A&S 6.2.1-6.2.2, the Beta integral),
    # evaluated with scipy's gamma, not the code's lgamma; and by scipy's quadrature of
    # |cos|^1.5 over a period. C = (2 pi)^1.5 <|cos|^1.5> = 8.763 (to 4 digits).
    closed = (2 * math.pi) ** 1.5 * special.gamma(1.25) / (math.sqrt(math.pi)
                                                          * special.gamma(1.75))
    mean, _ = integrate.quad(lambda x: abs(math.cos(x)) ** 1.5, 0.0, 2 * math.pi, limit=200)
    assert separation.EXCESS_CONSTANT == pytest.approx(closed, rel=1e-13)
    assert (2 * math.pi) ** 1.5 * mean / (2 * math.pi) == pytest.approx(closed, rel=1e-9)
    assert round(closed, 3) == 8.763


def test_field_coefficients_from_table_2():
    # k_e = K_e / (2 pi^2), k_ex = K_ex / C (module docstring's derivation, by hand here)
    assert separation.eddy_field_coefficient(K_E) == pytest.approx(2753.39 / 19.7392088,
                                                                   rel=1e-8)
    assert separation.excess_field_coefficient(K_EX) == pytest.approx(895.80 / 8.7635,
                                                                      rel=1e-4)


# ------------------------------------------------------------------ energy balance

def _trapezoid_wave(b_m, f, rise, n_ramp):
    """B(t) and dB/dt of a trapezoid: -B_m -> B_m in ``rise`` seconds, flat, back; 2 periods.

    Samples are placed on every corner, so dB/dt is exact sample by sample.
    """
    period = 1.0 / f
    flat = period / 2 - rise
    if flat < 0:
        raise ValueError(rise)
    pieces_t, pieces_b, pieces_r = [], [], []
    t0 = 0.0
    for _ in range(2):
        for start, stop, dur in ((-b_m, b_m, rise), (b_m, b_m, flat), (b_m, -b_m, rise),
                                 (-b_m, -b_m, flat)):
            if dur <= 0:
                continue
            m = n_ramp if start != stop else 4
            s = np.linspace(0.0, 1.0, m + 1)[:-1]
            pieces_t.append(t0 + s * dur)
            pieces_b.append(start + s * (stop - start))
            pieces_r.append(np.full(m, (stop - start) / dur))
            t0 += dur
    t = np.concatenate(pieces_t + [[t0]])
    b = np.concatenate(pieces_b + [[-b_m]])
    return t, b, np.concatenate(pieces_r + [[0.0]])


def _sine_wave(b_m, f, n):
    t = np.linspace(0.0, 2.0 / f, 2 * n + 1)
    w = 2 * math.pi * f
    return t, b_m * np.sin(w * t), b_m * w * np.cos(w * t)


def _loop_terms(b, rate, mag):
    """Loop integrals of each part of H over the second period, trapezoid rule in B [J/m^3]."""
    h_irr = np.array([mag.hysteresis.move(float(x)) for x in b])
    h_rev = mag.nu * b
    h_eddy, h_ex = separation.dynamic_field(rate, mag.k_e, mag.k_ex)
    half = (b.size - 1) // 2  # both generators put the second period in the second half
    sel = slice(half, None)

    def loop(h):
        return float(np.sum(0.5 * (h[sel][1:] + h[sel][:-1]) * np.diff(b[sel])))

    return {"reversible": loop(h_rev), "hysteresis": loop(h_irr), "eddy": loop(h_eddy),
            "excess": loop(h_ex), "total": loop(h_rev + h_irr + h_eddy + h_ex)}


def _closed_form_ramp_losses(b_m, rise, k_e, k_ex):
    # two ramps a cycle of 2 B_m in ``rise`` each: dB/dt = 2 B_m / rise
    rate = 2 * b_m / rise
    return 2 * rise * k_e * rate ** 2, 2 * rise * k_ex * rate ** 1.5


@pytest.mark.parametrize("shape, f, b_m", [
    ("sine", 50.0, 0.0637), ("sine", 100.0, 0.0531),  # Table 1, 1 A
    ("square", 100.0, 0.0531), ("trapezoid", 100.0, 0.0531), ("trapezoid", 50.0, 0.0637)])
def test_energy_balance_loop_integral_equals_the_three_losses(shape, f, b_m):
    # Bertotti's separation: the work of H over a cycle, the loop integral of H dB, is the
    # hysteresis loss K_h B_m^n (eq 7 per cycle) plus the eddy and excess losses computed
    # from the waveform (k_e int (dB/dt)^2 dt, k_ex int |dB/dt|^1.5 dt: closed forms here).
    # The loop integral is the trapezoid rule over 20 000 samples a ramp; its error is
    # ~1e-6, so 0.1 % (the required bound) is a margin of ~1000.
    mag = TimeDomainMagnetics()
    if shape == "sine":
        t, b, rate = _sine_wave(b_m, f, 40000)
        eddy = separation.eddy_field_coefficient(K_E) * (b_m * 2 * math.pi * f) ** 2 / (2 * f)
        excess = (separation.excess_field_coefficient(K_EX) * (b_m * 2 * math.pi * f) ** 1.5
                  / f * special.gamma(1.25) / (math.sqrt(math.pi) * special.gamma(1.75)))
    else:
        rise = (0.01 if shape == "square" else 0.2) / f  # a square wave's edge: 1 % of T
        t, b, rate = _trapezoid_wave(b_m, f, rise, 20000)
        eddy, excess = _closed_form_ramp_losses(b_m, rise, mag.k_e, mag.k_ex)
    got = _loop_terms(b, rate, mag)
    expected = K_H * b_m ** N_EXP + eddy + excess
    assert got["total"] == pytest.approx(expected, rel=1e-3), (got, expected)
    assert abs(got["reversible"]) < 1e-9 * expected  # the reversible curve stores, loses nothing


@pytest.mark.parametrize("f, b_m", [(50.0, 0.0637), (70.0, 0.0590), (80.0, 0.0570),
                                    (100.0, 0.0531), (5.0, 0.0300)])  # Table 1
def test_each_term_under_sinusoidal_b_equals_eqs_7_9_11(f, b_m):
    # Paper eq 7: P_h / (f V) = K_h B_m^n; eq 9: P_eddy / (f V) = K_e B_m^2 f; eq 11:
    # P_ex / (f V) = K_ex B_m^1.5 f^0.5, each the loss per cycle and volume under a sinusoidal
    # B. The time-domain terms' loop integrals must give each within 0.5 % (the required
    # bound; the quadrature's own error is ~1e-6).
    mag = TimeDomainMagnetics()
    t, b, rate = _sine_wave(b_m, f, 40000)
    got = _loop_terms(b, rate, mag)
    assert got["hysteresis"] == pytest.approx(K_H * b_m ** N_EXP, rel=5e-3)  # eq 7
    assert got["eddy"] == pytest.approx(K_E * b_m ** 2 * f, rel=5e-3)  # eq 9
    assert got["excess"] == pytest.approx(K_EX * b_m ** 1.5 * f ** 0.5, rel=5e-3)  # eq 11


# ------------------------------------------------------------------ the hysteresis operator


def test_congruent_minor_loops_carry_the_steinmetz_loss():
    # A Prandtl-Ishlinskii (Preisach-class) operator has congruent minor loops: a minor
    # cycle of half-swing a about any centre loses K_h a^n (eq 7 per cycle) for
    # r_0 <= a <= r_max; the major loop's memory is wiped back in (Mayergoyz ch. 1).
    mag = TimeDomainMagnetics()
    op = mag.hysteresis
    op.move(0.06)
    op.move(-0.06)
    h_top = op.move(0.04)  # up the major branch to the minor loop's top
    a = 0.01
    s = np.linspace(0.0, 1.0, 20001)
    path = np.concatenate((0.04 - 2 * a * s, 0.02 + 2 * a * s[1:]))
    h = np.array([op.move(float(x)) for x in path])
    area = float(np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(path)))
    assert area == pytest.approx(K_H * a ** N_EXP, rel=1e-4)
    assert h[-1] == pytest.approx(h_top, abs=1e-9)  # the minor loop closes
    # passing 0.04 again wipes the minor loop out: back on the major branch from -0.06
    major_at = mag.hysteresis.branch.value(0.05 + 0.06) - mag.hysteresis.branch.value(0.12) / 2
    assert op.move(0.05) == pytest.approx(major_at, rel=1e-12)


@pytest.mark.parametrize("n, knee, m", [(N_EXP, math.inf, 2.0), (2.0, math.inf, 2.0),
                                         (2.98, 0.028, 2.0), (2.5, 0.05, 3.5)],
                         ids=["paper", "n2-log", "broken-m2-log", "broken-m3.5"])
def test_branch_function_is_the_integral_of_its_stops(n, knee, m):
    # G(x) = int rho(r) min(x, 2r) dr and G'(x) = int_{r > x/2} rho(r) dr with
    # rho = K_h n (n-1) r^(n-3) / 4 on [r_0, r_max] (turned to c r_b^(n-m) r^(m-3) above the
    # break r_b) and the single stop below r_0: scipy's quadrature of that definition;
    # n = 2 or m = 2 makes a piece r^-1, whose integral is a logarithm
    g = hysteresis.BranchFunction(K_H, n, 2e-3, 0.2, knee, m)
    c = K_H * n * (n - 1) / 4

    def rho(r):
        return c * r ** (n - 3) if r <= knee else c * knee ** (n - m) * r ** (m - 3)

    for x in (1e-4, 3e-3, 0.02, 0.056, 0.1, 0.3, 0.5):
        points = [p for p in (x / 2, knee) if 2e-3 < p < 0.2] or None
        cont, _ = integrate.quad(lambda r: rho(r) * min(x, 2 * r), 2e-3, 0.2, points=points,
                                 limit=200)
        above, _ = integrate.quad(rho, min(max(x / 2, 2e-3), 0.2), 0.2,
                                  points=[knee] if x / 2 < knee < 0.2 else None, limit=200)
        assert g.value(x) == pytest.approx(cont + g.w * min(x, 2 * g.r1), rel=1e-9), x
        assert g.slope(x) == pytest.approx(above + (g.w if x < 2 * g.r1 else 0.0),
                                           rel=1e-9), x
        assert g.value_and_slope(x)[0] == pytest.approx(g.value(x), rel=1e-13)
        assert g.value_and_slope(x)[1] == pytest.approx(g.slope(x), rel=1e-13)


def test_magnetization_rises_with_b_on_every_branch():
    mag = TimeDomainMagnetics()
    assert mag.smallest_magnetization_slope > 0
    # a reversal slope steeper than 1/mu_0 is refused, naming the parameter
    with pytest.raises(gmt.ParameterError, match="steinmetz_lower"):
        TimeDomainMagnetics(td=TimeDomainParameters(steinmetz_lower=1e-5))


@pytest.mark.parametrize("kwargs, name", [({"reversible_permeability": 0.5},
                                           "reversible_permeability"),
                                          ({"steinmetz_upper": 3.0}, "steinmetz_upper"),
                                          ({"steinmetz_lower": 0.3}, "steinmetz_lower")])
def test_parameters_are_validated(kwargs, name):
    with pytest.raises(gmt.ParameterError, match=name):
        TimeDomainParameters(**kwargs)


def test_exponent_outside_the_operators_range_is_refused():
    with pytest.raises(gmt.ParameterError, match="steinmetz_exponent"):
        TimeDomainMagnetics(gmt.TransducerParameters(steinmetz_exponent=1.0))


# ------------------------------------------------------------------ the implicit step


@pytest.mark.parametrize("step", [1e-6, 1e-4, 1e-2, 1.0])
def test_step_equation_root_and_its_explicit_inverse(step):
    # backward Euler in B: field(solve(H)) == H to the solver's tolerance, at any step
    mag = TimeDomainMagnetics()
    for target in (14772.7, -5000.0, 300.0, 20000.0):
        b = mag.solve(target, step)
        # the solver stops at 1e-12 T: the residual is that times the step equation's slope
        slack = 1e-11 * (mag.k_e / step + 1e6)
        assert mag.field(b, step) == pytest.approx(target, abs=slack)
        assert mag.solve(mag.field(b, step), step) == pytest.approx(b, abs=1e-11)
        mag.step(target, step)


def test_dc_step_settles_without_overshoot_to_the_static_curve():
    # a 1 A current step held for 0.1 s: B rises monotonically (every term of the step
    # equation rises with B, so backward Euler cannot overshoot) towards the static
    # H_hys(B) = H. The excess term makes the last approach algebraic, not exponential:
    # with dB/dt ~ ((H - H_hys)/k_ex)^2 and S = dH_hys/dB >= 1/(mu_0 mu_rev) = nu,
    # H - H_hys <= k_ex^2 / (nu t) asymptotically; twice that is the bound (1.6 A/m, 1e-4 H).
    for h in (1e-5, 1e-4, 2e-3):
        mag = TimeDomainMagnetics()
        field = gmt.TransducerParameters().field_per_ampere * 1.0
        bs = [mag.step(field, h) for _ in range(int(round(0.1 / h)))]
        assert np.all(np.diff(bs) >= 0)
        assert 0.0 < field - mag.static_field() < 2 * mag.k_ex ** 2 / (mag.nu * 0.1)


def test_stepper_outputs_stay_finite_for_step_square_and_dc_currents():
    st = TimeDomainStepper()
    h = 1e-4
    for k in range(3000):
        i = 1.0 if (k // 50) % 2 else -1.0  # 100 Hz square
        if k > 2000:
            i = 2.5  # a step to 2.5 A, then held (DC)
        out = st.step(i, h)
        assert all(math.isfinite(v) for v in out.magnetics) and math.isfinite(out.displacement)
    # DC: the rod creeps to the static displacement of the force (eq 27 at s = 0); B still
    # creeps with the excess term's algebraic approach (previous test), ~1e-7 m/s against
    # ~1e-2 m/s while stroking
    assert abs(st.velocity) < 1e-5
    assert st.displacement == pytest.approx(out.magnetics.force / st.params.stiffness, rel=1e-4)


def test_state_round_trip():
    st = TimeDomainStepper()
    for k in range(137):
        st.step(math.cos(0.07 * k) + 0.3 * math.sin(0.31 * k), 1e-4)
    saved = st.get_state()
    a = [st.step(0.2 * math.sin(0.1 * k), 1e-4).displacement for k in range(50)]
    st.set_state(saved)
    b = [st.step(0.2 * math.sin(0.1 * k), 1e-4).displacement for k in range(50)]
    assert a == b


def test_reversible_curve_reproduces_table_1_at_5_hz():
    # Paper, Table 1, 5 Hz: B_m = 0.0300 T at 0.5 A and 0.0530 T at 0.7 A (eq 22 from the
    # sensing coil, printed to 3 digits). The default mu_rev is the least-squares fit of
    # these two points with one parameter; the model's amplitude dependence (the Steinmetz
    # operator's) is a little weaker than the data's, so each point is met within 5 %, not
    # exactly (measured: +3.8 % and -3.0 %).
    from gmt.timedomain.steady import sinusoidal_response

    for current, measured in ((0.5, 0.0300), (0.7, 0.0530)):
        got = sinusoidal_response(frequency=5.0, current_amplitude=current, samples=1000)
        assert got.flux_density_amplitude == pytest.approx(measured, rel=0.05)


@pytest.mark.parametrize("f, current", [(50.0, 1.0), (100.0, 1.0), (5.0, 0.7)])
def test_loss_per_cycle_is_eq_13_of_b_fundamental(f, current):
    # under a sinusoidal H only B's fundamental does work over a cycle (orthogonality), so
    # the model's loss per cycle must equal eq 13 per cycle and volume, pi mu_0 mu'' H_m^2,
    # with mu'' of that fundamental: two different sums over the same run (the loop integral
    # sum H_k dB_k against a Fourier coefficient). Summed by parts with H_k held at the
    # step's middle, the loop sum is exactly pi mu_0 mu'' H_m^2 sin(pi/N)/(pi/N) for a
    # periodic B sampled N times a period (no mu' term); the run is periodic to ~1e-7
    from gmt.timedomain.steady import sinusoidal_response

    samples = 2000
    r = sinusoidal_response(frequency=f, current_amplitude=current, samples=samples)
    mu_0 = 4e-7 * math.pi
    x = math.pi / samples
    assert r.loss_per_cycle == pytest.approx(
        math.pi * mu_0 * r.mu_imag * r.field_amplitude ** 2 * math.sin(x) / x, rel=1e-5)
    # and it is the sum of its three parts (the separation), each computed from the run's B
    # by its continuous formula (k_e int (dB/dt)^2 dt, k_ex int |dB/dt|^1.5 dt, the loop of
    # H_hys at the steps' ends): the step's exponentially fitted eddy term and the
    # right-point H_hys differ from those integrals at first order in the step, measured
    # 0.26 % (50 Hz) to 0.55 % (5 Hz, where a step is a larger part of the eddy time
    # constant's cycle share) at 2000 steps a period; 1 % allowed
    assert r.loss_per_cycle == pytest.approx(r.hysteresis_loss + r.eddy_loss + r.excess_loss,
                                             rel=1e-2)
