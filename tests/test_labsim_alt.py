"""Tests of labsim's second formulations of the six effects (tests/labsim/alternatives.py).

As in test_labsim.py, each test names its reference: a textbook limit or identity, a
filter table, or an independent numerical method (scipy's LSODA/DOP853 in time, brentq on
a frequency equation, a closed-form continuum solution). Reference values are typed in or
computed here, not read from labsim.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq
from test_labsim import C, K, K_LAMBDA, L, M, M_B, assert_loop_stays_open, fundamental

import labsim
from labsim import jiles_atherton as ja
from labsim import lti, rod
from labsim.alternatives import (Arctangent, Brillouin, FroehlichKennelly, MagnetWarming,
                                 MeanFieldLangevin)
from labsim.constants import Transducer
from labsim.effects import EffectSet
from labsim.sizes import effect_size
from labsim.transducer import simulate
from labsim.waveform import Waveform, respond

CLEAN = EffectSet()
#: strength-1 Jiles-Atherton parameters (alternatives.JilesAtherton), typed in
JA_MODEL = ja.Model(12e3, 12e3, 3e3, 0.2, 4e3)


def alt(name, strength=1.0):
    return EffectSet.from_strengths({name: strength}, "alt")


def langevin_anhysteretic(h, m_s=12e3, a=12e3):
    """M_s (coth(H/a) - a/H), written out here (series below |H/a| = 1e-4)."""
    x = np.asarray(h, dtype=float) / a
    safe = np.where(np.abs(x) < 1e-4, 1.0, x)
    return m_s * np.where(np.abs(x) < 1e-4, x / 3, 1 / np.tanh(safe) - 1 / safe)


def steady_times(run, frequency, cycles=6, points=400):
    period = 1.0 / frequency
    start = math.ceil(run.settle_time / period) * period
    return start + np.arange(cycles * points) * period / points


# --- API -------------------------------------------------------------------------------

def test_formulations_are_chosen_per_effect_and_recorded(tmp_path):
    kwargs = dict(seed=3, frequencies=[50.0], amplitudes=[1.0], samples_per_cycle=100, cycles=2)
    effects = {"transport_delay": 1.0, "thermal_drift": 0.5}
    both = labsim.make_dataset(effects, formulation="alt", **kwargs)
    assert both.truth["formulations"] == {"transport_delay": "bessel_sensor",
                                          "thermal_drift": "magnet_bias"}
    assert both.truth["effects"]["thermal_drift"]["parameters"]["magnet_initial"] == 20.0
    mixed = labsim.make_dataset(effects, formulations={"transport_delay": "alt"}, **kwargs)
    assert mixed.truth["formulations"] == {"transport_delay": "bessel_sensor",
                                           "thermal_drift": "strain_and_expansion"}
    named = labsim.make_dataset(effects, formulation="alt",
                                formulations={"thermal_drift": "default"}, **kwargs)
    assert np.array_equal(named.runs[0].displacement, mixed.runs[0].displacement)
    # the CSV's provenance line names non-default formulations only
    text = mixed.write_csv(tmp_path / "a.csv").read_text().splitlines()[1]
    assert "formulations = {'transport_delay': 'bessel_sensor'}" in text
    default = labsim.make_dataset(effects, **kwargs).write_csv(tmp_path / "b.csv")
    assert "formulations" not in default.read_text()
    assert set(labsim.FORMULATIONS) == set(labsim.EFFECTS)


@pytest.mark.parametrize("kwargs, names", [
    (dict(formulation="other"), "formulation"),
    (dict(formulations={"transport_delay": "sinc"}), "formulations.*transport_delay"),
    (dict(formulations={"wobble": "alt"}), "wobble"),
])
def test_bad_formulations_are_refused_by_name(kwargs, names):
    with pytest.raises(labsim.LabsimError, match=names):
        labsim.make_dataset({"transport_delay": 1.0}, seed=0, frequencies=[50.0], **kwargs)


@pytest.mark.parametrize("name", labsim.EFFECTS)
def test_alt_strength_one_is_clearly_visible_in_its_class(name):
    # the generator's specification, as for the first formulations: 0.5-3 um RMS change of
    # y at 100 Hz, 1 A; magnetic effects change B, the others leave the magnetics alone
    size = effect_size({name: 1.0}, formulation="alt")
    assert 0.5e-6 < size["displacement_rms"] < 3e-6
    magnetic = name in ("rate_independent_hysteresis", "magnetization_saturation",
                        "eddy_current_diffusion")
    assert (size["flux_rms"] > 1e-3 * size["flux_rms_clean"]) == magnetic
    if name in ("transport_delay", "mechanical_resonance"):
        assert size["flux_rms"] == 0.0
    # the warming magnet moves only the bias flux, slowly: tested below through the sense coil


# --- rate-independent hysteresis: Jiles-Atherton ---------------------------------------

def test_jiles_atherton_matches_time_integration():
    # Jiles and Atherton (1986) as an ODE in time, dM_irr/dt = dM_irr/dH dH/dt with the
    # frozen rule, by LSODA from the demagnetised state: H ramps 0 -> H_0 in 1 s, then
    # u = A sin(2 pi t); labsim's closed loop (in H, by quadrature) on the third cycle
    m_s, a, k, c, h0 = 12e3, 12e3, 3e3, 0.2, 4e3
    amp = 9000.0

    def field(t):
        return h0 * min(t, 1.0) + (amp * math.sin(2 * math.pi * (t - 1)) if t > 1 else 0.0)

    def slope(t):
        return h0 if t < 1 else amp * 2 * math.pi * math.cos(2 * math.pi * (t - 1))

    def rhs(t, y):
        h, dh = field(t), slope(t)
        delta = 1.0 if dh > 0 else -1.0
        gap = float(langevin_anhysteretic(h, m_s, a)) - y[0]
        return [gap / (delta * k) * dh if delta * gap > 0 else 0.0]

    t = np.linspace(3.0, 4.0, 801)
    sol = solve_ivp(rhs, (0.0, 4.0), [0.0], method="LSODA", rtol=1e-11, atol=1e-8,
                    max_step=4e-4, t_eval=t)
    h = np.array([field(x) for x in t])
    m_ref = c * langevin_anhysteretic(h, m_s, a) + (1 - c) * sol.y[0]
    loop = ja.periodic_loop(JA_MODEL, amp)
    before = float(JA_MODEL.total(h0, JA_MODEL.bias_state()))
    m = ja.periodic_branches(JA_MODEL, loop, 2 * np.pi * (t - 1) - np.pi / 2) + before
    # the loop has closed to < 1e-10 after two cycles (contraction ~5e-5 per cycle)
    # LSODA at rtol 1e-11 with steps below 1/2500 of a cycle: agreement to ~1e-10
    assert np.max(np.abs(m - m_ref)) < 1e-8 * np.ptp(m_ref)


def test_jiles_atherton_energy_balance():
    # Jiles and Atherton (1986): where M_irr moves, M_an - M_irr = delta k dM_irr/dH, so
    # oint (M_an - M_irr) dH = k oint |dM_irr| + the frozen stretches after each reversal
    # (where dM_irr = 0 and the integrand is known); with oint M_an dH = 0 the loop area of
    # M = c M_an + (1 - c) M_irr is (1 - c) [2 k (M_crest - M_trough) + frozen parts]
    k, c, h0, amp = 3e3, 0.2, 4e3, 9000.0
    loop = ja.periodic_loop(JA_MODEL, amp)

    def frozen(h_turn, m_held, direction):
        h_x = brentq(lambda h: float(langevin_anhysteretic(h)) - m_held, h0 - amp, h0 + amp)
        value = quad(lambda h: float(langevin_anhysteretic(h)) - m_held, h_turn, h_x)[0]
        assert direction * (h_x - h_turn) > 0
        return value

    expected = (1 - c) * (2 * k * (loop.crest - loop.trough)
                          + frozen(h0 + amp, loop.crest, -1) + frozen(h0 - amp, loop.trough, 1))
    phase = np.linspace(0.0, 2 * np.pi, 200001)
    m = ja.periodic_branches(JA_MODEL, loop, phase)
    h = amp * np.cos(phase)
    area = np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(m))  # oint H dM, trapezoid
    assert area == pytest.approx(expected, rel=1e-6)


def test_jiles_atherton_limits():
    amp = 9000.0
    phase = np.linspace(0.0, 2 * np.pi, 721)
    # c = 1: all reversible, M = M_an(H_0 + u) - M_an(H_0), no loop (Jiles-Atherton 1986)
    reversible = ja.Model(12e3, 12e3, 3e3, 1.0, 4e3)
    m = ja.periodic_branches(reversible, ja.periodic_loop(reversible, amp), phase)
    expected = langevin_anhysteretic(4e3 + amp * np.cos(phase)) - langevin_anhysteretic(4e3)
    assert np.allclose(m, expected, rtol=0, atol=1e-9)
    # H_0 = 0: the loop is odd, M(u + pi) = -M(u), no even harmonics; H_0 = 4 kA/m sits on
    # the Langevin curve's bend: asymmetric loops, a second harmonic ~2 % of the fundamental
    symmetric = ja.Model(12e3, 12e3, 3e3, 0.2, 0.0)
    m0 = ja.periodic_branches(symmetric, ja.periodic_loop(symmetric, amp), phase)
    assert np.allclose(m0[:361], -m0[360:], rtol=0, atol=1e-8)
    m4 = ja.periodic_branches(JA_MODEL, ja.periodic_loop(JA_MODEL, amp), phase[:-1])
    spectrum = np.abs(np.fft.rfft(m4))
    assert spectrum[2] > 0.01 * spectrum[1]
    # at a reversal M_irr is frozen: the slope is the reversible c dM_an/dH only (not 0 as
    # for a Preisach model, nor the anhysteretic slope)
    top = 4e3 + amp
    slope_an = (langevin_anhysteretic(top + 1.0) - langevin_anhysteretic(top - 1.0)) / 2.0
    tip = ja.periodic_branches(JA_MODEL, ja.periodic_loop(JA_MODEL, amp),
                               np.array([1e-3, 2e-3]))
    du = amp * (math.cos(1e-3) - math.cos(2e-3))
    assert (tip[0] - tip[1]) / du == pytest.approx(0.2 * slope_an, rel=1e-3)


def test_jiles_atherton_is_rate_independent_and_settles_from_switch_on():
    assert_loop_stays_open(alt("rate_independent_hysteresis"))  # as f -> 0
    # from the switch-on the state joins the closed loop (the map is a contraction)
    u = 9000.0 * np.cos(2 * np.pi * np.arange(1, 4 * 2048 + 1) / 2048 + 0.3)
    seq = ja.sequence(JA_MODEL, u)
    loop = ja.periodic_loop(JA_MODEL, 9000.0)
    per = ja.periodic_branches(JA_MODEL, loop, 2 * np.pi * np.arange(1, 4 * 2048 + 1) / 2048
                               + 0.3)
    assert np.max(np.abs(seq[:2048] - per[:2048])) > 10.0  # A/m: a transient ...
    assert np.max(np.abs(seq[-2048:] - per[-2048:])) < 1e-6  # ... that has died out


# --- magnetisation saturation: Froehlich-Kennelly --------------------------------------

def test_froehlich_kennelly_law_and_limits():
    # the tangent at the bias is kept: g(0) = M_b, g'(0) = 1; far above, M -> M_s (the law's
    # asymptote); below, the curve passes through 0 at the law's origin, x = 0
    law = FroehlichKennelly.at(1.0)
    m_s = law.saturation_magnetization
    assert m_s == pytest.approx(0.5e6)
    assert float(law.saturate(M_B, M_B)) == pytest.approx(M_B, rel=1e-15)
    slope = (law.saturate(M_B + 1.0, M_B) - law.saturate(M_B - 1.0, M_B)) / 2.0
    assert float(slope) == pytest.approx(1.0, rel=1e-9)
    assert float(law.saturate(1e12, M_B)) == pytest.approx(m_s, rel=1e-5)
    # x_b = M_b / (M_s - M_b) = 1 and f'(x_b) = 1/4: M = 0 at M_b - M_s f'(x_b) x_b
    assert float(law.saturate(M_B - m_s / 4, M_B)) == pytest.approx(0.0, abs=1e-9)
    # vanishing strength: the identity (the paper's model)
    weak = FroehlichKennelly.at(1e-9)
    assert float(weak.saturate(M_B + 4e4, M_B)) == pytest.approx(M_B + 4e4, rel=1e-9)


def test_froehlich_kennelly_second_harmonic_of_b():
    # small signal m = M1 cos: g(m) = m + g'' m^2 / 2 + ..., with g'' = f''(x_b) / (M_s f'^2)
    # = -2 (1 + x_b) / M_s = -8e-6 m/A for the FK law f = x / (1 + x) at x_b = 1; so B gains
    # a second harmonic mu_0 g'' M1^2 / 4 (fourth order: (M1 / M_s)^2 ~ 1e-4 relative)
    f, current = 5.0, 0.1
    t = 1.0 + np.arange(2000) / (2000 * f)
    clean = simulate(Transducer(), f, current, 0.0, CLEAN, transient=False)
    sat = simulate(Transducer(), f, current, 0.0, alt("magnetization_saturation"),
                   transient=False)
    mag = clean.flux.evaluate(t) / (4e-7 * math.pi) - clean.permeability.field_amplitude * \
        np.cos(2 * math.pi * f * t)
    m1 = 2 * abs(np.mean(mag * np.exp(-2j * math.pi * f * t)))
    b2 = 2 * abs(np.mean(sat.flux.evaluate(t) * np.exp(-4j * math.pi * f * t)))
    assert b2 == pytest.approx(4e-7 * math.pi * 8e-6 * m1**2 / 4, rel=2e-3)
    # the small-signal gain of y is kept (unlike the Langevin law's S(M_b) S'(M_b) / M_b)
    gains = [fundamental(t, run.displacement(t), f)[0] for run in (clean, sat)]
    assert gains[1] / gains[0] == pytest.approx(1.0, abs=2e-3)



# --- magnetisation saturation: Brillouin, arctangent, mean-field Langevin -------------

def test_brillouin_limits_are_tanh_and_langevin():
    # B_{1/2}(x) = tanh x; B_J -> L as J -> inf (Kittel, ch. 11); unit slope at 0 here
    m = np.linspace(-2e6, 2e6, 41)
    half = Brillouin(0.8e6, 0.5).saturate(m, M_B)
    assert np.allclose(half, 0.8e6 * np.tanh(m / 0.8e6), rtol=1e-12, atol=1e-6)
    big = Brillouin(0.8e6, 1e5).saturate(m[m != 0], M_B)
    x = 3 * m[m != 0] / 0.8e6
    assert np.allclose(big, 0.8e6 * (1 / np.tanh(x) - 1 / x), rtol=1e-4)
    # the series branch near 0 meets the closed form
    law = Brillouin(0.8e6, 2.0)
    assert float(law.saturate(0.79e3, M_B)) == pytest.approx(
        float(law.saturate(0.81e3, M_B) + law.saturate(0.77e3, M_B)) / 2, rel=1e-6)


def test_arctangent_keeps_the_tangent_at_the_bias():
    law = Arctangent.at(1.0)
    assert float(law.saturate(M_B, M_B)) == pytest.approx(M_B, rel=1e-12)
    slope = (law.saturate(M_B + 1.0, M_B) - law.saturate(M_B - 1.0, M_B)) / 2.0
    assert float(slope) == pytest.approx(1.0, rel=1e-8)
    assert float(law.saturate(1e14, M_B)) == pytest.approx(law.saturation_magnetization,
                                                            rel=1e-5)
    weak = Arctangent.at(1e-9)
    assert float(weak.saturate(M_B + 4e4, M_B)) == pytest.approx(M_B + 4e4, rel=1e-8)


def test_mean_field_langevin_solves_its_equation():
    # m = L(3 ((1 - a) x + a m)): checked by brentq on the scalar equation; a = 0 is L(3x)
    x = np.array([-3.0, -0.4, 0.05, 0.7, 2.5])
    law = MeanFieldLangevin(1.0, 0.6)
    got = law.saturate(x, M_B)
    for xi, mi in zip(x, got):
        want = brentq(lambda m: 1 / np.tanh(3 * (0.4 * xi + 0.6 * m))
                      - 1 / (3 * (0.4 * xi + 0.6 * m)) - m, -0.999999, 0.999999, xtol=1e-14)
        assert mi == pytest.approx(want, abs=1e-12)
    free = MeanFieldLangevin(1.0, 0.0).saturate(x, M_B)
    assert np.allclose(free, 1 / np.tanh(3 * x) - 1 / (3 * x), rtol=1e-12)
    # slope 1 at 0: small-signal identity
    assert float(law.saturate(1e-6, M_B)) == pytest.approx(1e-6, rel=1e-6)


# --- eddy currents: conducting housing ---------------------------------------------------

def test_shorted_turn_is_a_lag_network():
    # F = (1 + s (1 - kappa) tau) / (1 + s tau): a lag network with beta = 1 / (1 - kappa);
    # largest lag at w_m = 1 / (tau sqrt(1 - kappa)), sin(phi_m) = (beta - 1) / (beta + 1)
    # = kappa / (2 - kappa) (Ogata, Modern Control Engineering, 5th ed., sec. 6.7)
    tau, kappa = 0.3e-3, 0.5
    turn = lti.shorted_turn(tau, kappa)
    assert turn.transfer(0.0) == pytest.approx(1.0)
    assert turn.transfer(1j * 1e12) == pytest.approx(1 - kappa, abs=1e-8)
    w = np.linspace(0.2, 5, 2001) / (tau * math.sqrt(1 - kappa))
    phase = np.angle(turn.transfer(1j * w))
    assert w[np.argmin(phase)] * tau * math.sqrt(1 - kappa) == pytest.approx(1.0, abs=3e-3)
    assert math.sin(-phase.min()) == pytest.approx(kappa / (2 - kappa), rel=1e-6)
    # switched-on cos(w t) through it, from the circuit ODE tau x' = -x + kappa u:
    # x = kappa [cos w t + w tau sin w t - exp(-t / tau)] / (1 + (w tau)^2)
    w0 = 2 * math.pi * 700.0
    t = np.linspace(0.0, 3e-3, 301)
    x = kappa * (np.cos(w0 * t) + w0 * tau * np.sin(w0 * t) - np.exp(-t / tau)) / (
        1 + (w0 * tau) ** 2)
    out = respond(turn, Waveform.sinusoid(w0, 1.0)).evaluate(t)
    assert np.allclose(out, (1 - kappa) * np.cos(w0 * t) + x, rtol=0, atol=1e-12)


def test_housing_scales_the_paper_flux_by_its_transfer():
    # the paper's magnetics are linear in H: with the housing the flux phasor is F(j w) times
    # the paper's (without hysteresis or saturation), F from the lag network above
    f = 100.0
    w = 2 * math.pi * f
    t = 1.0 + np.arange(800) / (800 * f)
    clean = simulate(Transducer(), f, 1.0, 0.4, CLEAN, transient=False)
    eddy = simulate(Transducer(), f, 1.0, 0.4, alt("eddy_current_diffusion"), transient=False)
    ratio = (np.mean(eddy.flux.evaluate(t) * np.exp(-1j * w * t))
             / np.mean(clean.flux.evaluate(t) * np.exp(-1j * w * t)))
    s = 1j * w * 0.3e-3
    assert ratio == pytest.approx((1 + 0.5 * s) / (1 + s), abs=1e-10)


# --- transport delay: Bessel sensor --------------------------------------------------------

def test_bessel_sensor_is_the_textbook_filter():
    # delay-normalised Bessel polynomials (Williams and Taylor, Electronic Filter Design
    # Handbook, table of Bessel polynomials): n = 2: s^2 + 3 s + 3; n = 4:
    # s^4 + 10 s^3 + 45 s^2 + 105 s + 105; -3 dB at w tau = 1.3617 and 2.1139 (same tables)
    tau = 100e-6
    for order, poly, corner in ((2, [1, 3, 3], 1.3617), (4, [1, 10, 45, 105, 105], 2.1139)):
        filt = lti.bessel(order, tau)
        s = 1j * np.array([0.3, 1.0, 3.0]) / tau
        assert np.allclose(filt(s), poly[-1] / np.polyval(poly, s * tau), rtol=1e-12)
        assert abs(filt(1j * corner / tau)) == pytest.approx(1 / math.sqrt(2), abs=1e-4)
        w = 2 * math.pi * np.array([1.0, 1.001])  # group delay at DC: -d phase / d w = tau
        assert -np.diff(np.unwrap(np.angle(filt(1j * w)))) / np.diff(w) == pytest.approx(
            tau, rel=1e-6)


def test_bessel_sensor_delays_y_and_leaves_b_alone():
    # the recorded y is the paper's y through 3 / ((s tau)^2 + 3 s tau + 3), tau = 100 us:
    # at 100 Hz a lag of 0.0628 rad and a gain 0.99934; B exactly unchanged
    f, tau = 100.0, 100e-6
    w = 2 * math.pi * f
    aa = lti.butterworth(4, 20e3)
    t = 1.0 + np.arange(1600) / (1600 * f)
    clean = simulate(Transducer(), f, 1.0, 0.2, CLEAN, transient=False)
    sensed = simulate(Transducer(), f, 1.0, 0.2, alt("transport_delay"), transient=False)
    a0, p0 = fundamental(t, clean.displacement(t, aa), f)
    a1, p1 = fundamental(t, sensed.displacement(t, aa), f)
    x = w * tau
    h = 3 / ((1j * x) ** 2 + 3j * x + 3)
    assert a1 / a0 == pytest.approx(abs(h), rel=1e-9)
    assert math.remainder(p1 - p0 - np.angle(h), 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert np.angle(h) == pytest.approx(-x, rel=1e-4)  # near-constant delay: -w tau
    assert np.array_equal(sensed.sense_voltage(t, aa), clean.sense_voltage(t, aa))


# --- mechanical resonance: continuum rod -------------------------------------------------

def bar_tip_compliance(s, load, rate):
    """Closed form: 1 / (E A gamma coth(gamma L) + M_L s^2 + c_t s), gamma^2 =
    (rho s^2 + d s) / E, rho = 3 m / (A L), d = 2 rate rho, c_t = c - 2 rate m
    (Rao, Vibration of Continuous Systems, 2007, ch. 9; Graff 1975, ch. 2)."""
    area = math.pi * 0.010**2 / 4
    young = K * L / area
    rho = 3 * M / (area * L)
    gamma = np.sqrt((rho * s**2 + 2 * rate * rho * s) / young)
    return 1 / (young * area * gamma / np.tanh(gamma * L) + load * s**2
                + (C - 2 * rate * M) * s)


def test_continuum_rod_matches_the_closed_form():
    response = rod.tip_response(Transducer(), 2.5, 2000.0)
    s = 2j * np.pi * np.array([5.0, 50.0, 100.0, 200.0])
    assert np.allclose(response.transfer(s), bar_tip_compliance(s, 2.5, 2000.0), rtol=1e-7)
    s_k = 2j * np.pi * 1000.0
    assert response.transfer(s_k) == pytest.approx(bar_tip_compliance(s_k, 2.5, 2000.0),
                                                   rel=1e-6)
    assert abs(response.transfer(0.0)) == pytest.approx(1 / K, rel=1e-12)  # static 1/K
    # without the load: eq 27 (Rayleigh's one-third rule), up to O((w L / c_bar)^4) and the
    # distributed damping's second-order term, 6e-6 at 200 Hz
    bare = rod.tip_response(Transducer(), 0.0, 2000.0)
    assert np.allclose(bare.transfer(s), 1 / (M * s**2 + C * s + K), rtol=1e-5)
    # the gain rises monotonically towards the load mode (~430 Hz)
    freqs = np.array([5, 20, 50, 70, 80, 100, 150, 200.0])
    ratio = np.abs(response.transfer(2j * np.pi * freqs) * (M * (2j * np.pi * freqs) ** 2
                                                            + C * 2j * np.pi * freqs + K))
    assert np.all(np.diff(ratio) > 0) and ratio[-1] > 1.15


def test_continuum_rod_modes_follow_the_frequency_equation():
    # undamped bar fixed at x = 0 with a tip mass M_L: beta tan(beta) = m_bar / M_L,
    # omega = beta c_bar / L (Rao 2007, ch. 9; Timoshenko, Vibration Problems in Engineering)
    load = 2.5
    mass, _, stiffness = rod.bar_matrices(Transducer(), load, 0.0, 16)
    omega = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real))
    area = math.pi * 0.010**2 / 4
    c_bar = math.sqrt(K * L / area / (3 * M / (area * L)))
    ratio = 3 * M / load
    roots = [brentq(lambda b: b * math.tan(b) - ratio, lo, hi)
             for lo, hi in ((1e-6, math.pi / 2 - 1e-9), (math.pi + 1e-9, 1.5 * math.pi - 1e-9))]
    expected = np.array(roots) * c_bar / L
    assert omega[0] == pytest.approx(expected[0], rel=1e-4)  # the load mode, 433 Hz
    assert omega[1] == pytest.approx(expected[1], rel=3e-3)  # the bar's own, ~9 kHz


# --- thermal drift: warming bias magnet --------------------------------------------------

def test_magnet_network_matches_ode_integration():
    # two-node network C_c T_c' = P - (T_c - T_m)/R_cm, C_m T_m' = (T_c - T_m)/R_cm - T_m/R_ma
    # (strength 1: P = 15 W at 1 A, R_cm = 2, R_ma = 4 K/W, C_c = 30, C_m = 5 J/K, from
    # 80 K and 40 K), by DOP853
    def rhs(t, x, power):
        t_c, t_m = x
        return [(power - (t_c - t_m) / 2.0) / 30.0, ((t_c - t_m) / 2.0 - t_m / 4.0) / 5.0]

    times = np.linspace(0.0, 300.0, 61)
    for current in (0.6, 1.0):
        sol = solve_ivp(rhs, (0, 300), [80.0, 40.0], args=(15.0 * current**2,),
                        method="DOP853", rtol=1e-12, atol=1e-12, t_eval=times)
        final, rates, coefficients = MagnetWarming.at(1.0).magnet_temperature(current)
        model = final + np.exp(-np.outer(times, rates)) @ coefficients
        assert np.allclose(model, sol.y[1], rtol=0, atol=1e-6)  # DOP853's global error ~1e-7 K
    assert final == pytest.approx(60.0)  # P R_ma at 1 A


def test_warming_magnet_lowers_gain_and_bias_strain():
    # M_b (1 + eps), eps = alpha_B dT_m: without saturation the fundamental of the force,
    # 2 K_l M_b (1 + eps) M1 (eq 25), scales with 1 + eps; the mean displacement follows the
    # bias strain L K_l M_b^2 (1 + eps)^2; eps from the network's own ODE solution above
    warming = MagnetWarming.at(1.0)
    final, rates, coefficients = warming.magnet_temperature(1.0)

    def eps(t):
        return -0.0012 * (final + np.exp(-np.outer(np.atleast_1d(t), rates)) @ coefficients)

    def amplitude(t, y):  # of the fundamental at mid-cycle; the fit allows a linear change of
        w, tm = 2 * math.pi * f, t - t.mean()  # it, harmonics 2-3 and a quadratic drift
        basis = np.column_stack([np.cos(w * t), np.sin(w * t), tm * np.cos(w * t),
                                 tm * np.sin(w * t), np.ones_like(t), tm, tm**2]
                                + [g(n * w * t) for n in (2, 3) for g in (np.cos, np.sin)])
        coef = np.linalg.lstsq(basis, y, rcond=None)[0]
        return math.hypot(coef[0], coef[1])

    f = 5.0
    clean = simulate(Transducer(), f, 1.0, 0.0, CLEAN, transient=False)
    warm = simulate(Transducer(), f, 1.0, 0.0, alt("thermal_drift"), transient=False)
    t = steady_times(warm, f)
    y0, y1 = clean.displacement(t), warm.displacement(t)
    cycles = (t.reshape(6, 400), y0.reshape(6, 400), y1.reshape(6, 400))
    gain = [amplitude(tc, b) / amplitude(tc, a) for tc, a, b in zip(*cycles)]
    expected = [1 + eps(tc.mean())[0] for tc in cycles[0]]
    assert np.allclose(gain, expected, rtol=0, atol=5e-6)  # of -4.9 %; one-cycle fits
    shift = (y1 - y0).reshape(6, 400).mean(axis=1)
    bias = L * K_LAMBDA * M_B**2 * np.array([np.mean((1 + eps(tc)) ** 2) for tc in cycles[0]])
    assert np.allclose(np.diff(shift), np.diff(bias), rtol=0, atol=2e-9)
    assert np.all(np.diff(shift) < 0) and shift[0] - shift[-1] > 0.2e-6  # falls, > noise
    # the bias flux drifts too, but slowly: the sense voltage changes by < 0.1 mV (noise
    # 0.5 mV); the AC flux is the paper's
    aa = lti.butterworth(4, 800.0)
    assert np.max(np.abs(warm.sense_voltage(t, aa) - clean.sense_voltage(t, aa))) < 1e-4


@pytest.mark.parametrize("law", ["brillouin", "arctangent", "mean_field_langevin"])
def test_further_saturation_laws_are_clearly_visible_and_magnetic(law):
    # the generator's specification: 0.5-3 um RMS change of y at 100 Hz, 1 A, B changed
    size = effect_size({"magnetization_saturation": 1.0},
                       formulations={"magnetization_saturation": law})
    assert 0.5e-6 < size["displacement_rms"] < 3e-6
    assert size["flux_rms"] > 1e-3 * size["flux_rms_clean"]
