"""Synthetic measured runs (smeha.synthetic): the ground truth of the diagnosis tests.

Each hidden effect is checked against its physical signature (docs/DIAGNOSE-method.md, the
candidate causes) with references computed here independently of the
generator: analytic transfer functions (slab eddy currents, two-mass mechanics,
pure delay) and an independent ODE integration (thermal model).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp, trapezoid

import gmt
from gmt.sensing import flux_density_amplitude_from_voltage
from smeha import synthetic
from smeha.measured import Run

#: Noise-free, nominal (un-jittered) effect parameters: signature tests compare
#: the effect with the clean paper model sample by sample.
QUIET = dict(noise_um=0.0, voltage_noise=0.0, current_noise=0.0, jitter=0.0)
#: The default data set.
FREQUENCIES = (5.0, 20.0, 50.0, 100.0, 150.0, 200.0)
SKIP = 256  # the first period holds the mechanics' start transient (gmt.simulate starts at rest)


def _by_name(runs):
    return {r.name: r for r in runs}


def _phasor(run_or_time, signal, frequency, skip=SKIP):
    """Complex amplitude X of the fundamental, x ~ Re(X e^{jwt}) + const (least squares)."""
    t = run_or_time.time if isinstance(run_or_time, Run) else run_or_time
    w = 2 * math.pi * frequency
    t, x = t[skip:], np.asarray(signal)[skip:]
    basis = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
    c, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return complex(c[0], -c[1])


def _harmonics(t, x, frequency, orders=(1, 2, 3), skip=SKIP):
    """Amplitudes of the given harmonics of x (least squares, mean removed)."""
    w = 2 * math.pi * frequency
    t, x = t[skip:], np.asarray(x)[skip:]
    cols = [np.ones_like(t)]
    for k in orders:
        cols += [np.cos(k * w * t), np.sin(k * w * t)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols), x, rcond=None)
    return {k: math.hypot(c[1 + 2 * j], c[2 + 2 * j]) for j, k in enumerate(orders)}


def _rms_change(a, b, skip=SKIP):
    """RMS of a - b after the first period, its mean removed (offsets are free), [m]."""
    d = (a.displacement - b.displacement)[skip:]
    return float(np.sqrt(np.mean((d - d.mean()) ** 2)))


@pytest.fixture(scope="module")
def clean():
    return synthetic.generate_runs(None, seed=0, **QUIET)


@pytest.fixture(scope="module")
def effect_runs():
    return {e: synthetic.generate_runs(e, seed=0, **QUIET) for e in synthetic.EFFECTS}


# ---------------------------------------------------------------- API, determinism, invariants


def test_default_data_set_and_run_invariants():
    runs = synthetic.generate_runs("thermal_drift", seed=4)
    assert len(runs) == 6 * 2
    assert [r.name for r in runs[:3]] == ["f005_I0.5", "f005_I1.0", "f020_I0.5"]
    for r in runs:
        n = 8 * 256
        assert r.time.shape == r.current.shape == r.displacement.shape == (n,)
        assert r.sense_voltage.shape == r.control.shape == (n,)
        assert np.all(np.diff(r.time) > 0)  # Run invariant: time increasing
        assert r.cycles >= 1.0
        assert r.cycles == pytest.approx(8.0 * (n - 1) / n)
        im = r.meta["current_amplitude"]
        assert r.current_amplitude == pytest.approx(im, rel=1e-3)
        assert np.all(np.isfinite(r.displacement)) and np.all(np.isfinite(r.sense_voltage))
        # control u = i / K_a with K_a = 1 A/V (paper, Figure 9), noise-free command
        np.testing.assert_allclose(r.control, im * np.cos(2 * np.pi * r.frequency * r.time),
                                   rtol=0, atol=1e-12)
        assert r.meta["effect"] == "thermal_drift" and r.meta["strength"] == 1.0
        assert "thermal_resistance" in r.meta["truth"]


def test_unknown_effect_and_bad_strength_raise():
    with pytest.raises(ValueError, match="effect"):
        synthetic.generate_runs("backlash")
    with pytest.raises(ValueError, match="strength"):
        synthetic.generate_runs("transport_delay", strength=-1.0)


def test_seeded_determinism():
    a = synthetic.generate_runs("rate_independent_hysteresis", seed=7)
    b = synthetic.generate_runs("rate_independent_hysteresis", seed=7)
    c = synthetic.generate_runs("rate_independent_hysteresis", seed=8)
    for ra, rb, rc in zip(a, b, c):
        for key in ("current", "displacement", "sense_voltage", "control"):
            np.testing.assert_array_equal(getattr(ra, key), getattr(rb, key))
        assert ra.meta == rb.meta
        assert not np.array_equal(ra.displacement, rc.displacement)
    # the effect's parameters are jittered by the seed, within the stated spread
    ta, tc = a[0].meta["truth"], c[0].meta["truth"]
    nominal = synthetic.NOMINAL["rate_independent_hysteresis"]["coercive_field"]
    assert ta["coercive_field"] != tc["coercive_field"]
    for t in (ta, tc):
        assert nominal / 1.2 <= t["coercive_field"] <= nominal * 1.2


def test_noise_is_the_same_whatever_the_effect():
    # so that effect - clean at one seed is the effect alone
    clean = synthetic.generate_runs(None, seed=3)
    delayed = synthetic.generate_runs("transport_delay", seed=3, strength=0.0)
    for a, b in zip(clean, delayed):
        np.testing.assert_array_equal(a.current, b.current)
        np.testing.assert_array_equal(a.sense_voltage, b.sense_voltage)
        assert a.meta["offset"] == b.meta["offset"]


def test_noise_levels_as_requested():
    quiet = synthetic.generate_runs(None, seed=5, **QUIET)
    noisy = synthetic.generate_runs(None, seed=5, noise_um=0.2, voltage_noise=0.02,
                                    current_noise=3e-3)
    offsets = []
    for q, r in zip(quiet, noisy):
        dy = r.displacement - q.displacement
        offsets.append(r.meta["offset"])
        # 2048 samples: the sample standard deviation is within ~1.6 % (1 sigma)
        assert np.std(dy) == pytest.approx(0.2e-6, rel=0.08)
        # same seed: same offset, so the difference is the noise alone, zero mean
        assert r.meta["offset"] == q.meta["offset"]
        assert abs(np.mean(dy)) < 4 * 0.2e-6 / math.sqrt(2048)
        assert np.std(r.sense_voltage - q.sense_voltage) == pytest.approx(0.02, rel=0.08)
        assert np.std(r.current - q.current) == pytest.approx(3e-3, rel=0.08)
        assert abs(r.meta["offset"]) <= synthetic.OFFSET_RANGE
    assert np.std(offsets) > 5e-6  # offsets differ from run to run


# ---------------------------------------------------------------- clean data = the paper's model


def test_clean_runs_are_the_continuous_paper_model(clean):
    # the transducer is continuous: after the start's transient (the mechanics' slower pole,
    # 0.14 ms, is gone within one period) the clean record is eq 30's periodic steady state
    # with the continuous eq 27 (gmt.periodic_response without a step). The generator
    # integrates eq 27 exactly for a force linear between samples 4x finer than the record's,
    # leaving about (w h / 4)^2 / 12 = 3e-6 of the amplitude (2e-6 measured)
    p = gmt.TransducerParameters()
    for r in clean:
        im = r.meta["current_amplitude"]
        h = 1.0 / (r.frequency * 256)
        point = gmt.operating_point(p, gmt.Excitation(r.frequency, im))
        steady = gmt.periodic_response(p, point, r.time)["displacement"]
        expected = steady - gmt.bias_displacement(p) + r.meta["offset"]
        settled = r.time >= 1.0 / r.frequency
        err = np.max(np.abs(r.displacement - expected)[settled])
        assert err <= 1e-5 * np.ptp(expected)
        sim = gmt.simulate(p, point, im * np.cos(2 * np.pi * r.frequency * r.time), h)
        # eq 21 on B of eq 4, against a numerical derivative of gmt's B
        e_num = -p.sense_turns * p.sense_area * np.gradient(sim["flux_density"], h)
        e_m = np.max(np.abs(r.sense_voltage))
        assert np.max(np.abs(r.sense_voltage - e_num)[1:-1]) < 2e-4 * e_m


def test_clean_sense_voltage_reproduces_table_1(clean):
    # paper, Table 1: 50 Hz, I_m = 1 A: E_m = 1.140 V, B_m = 0.0637 T; 100 Hz: 1.900 V,
    # 0.0531 T; 5 Hz, 0.5 A: 0.053 V, 0.0300 T. E_m = w N_c A_c B_m (eq 22) with the
    # calibration returning Table 1's B_m; Table 1 rounds E_m to 2-3 digits (0.5 %).
    runs = _by_name(clean)
    for name, e_m, b_m in (("f050_I1.0", 1.140, 0.0637), ("f100_I1.0", 1.900, 0.0531),
                           ("f005_I0.5", 0.053, 0.0300)):
        r = runs[name]
        amp = abs(_phasor(r, r.sense_voltage, r.frequency))
        assert amp == pytest.approx(e_m, rel=0.015)
        b = flux_density_amplitude_from_voltage(amp, r.frequency, 150, 380e-6)
        assert b == pytest.approx(b_m, rel=1e-3)


@pytest.mark.parametrize("effect", synthetic.EFFECTS)
def test_strength_zero_is_the_clean_paper_model(effect, clean):
    # strength 0 short-circuits nothing by hand except the infinite limits
    # (M_s, k_j = inf); the result is the paper's model bit for bit
    runs = synthetic.generate_runs(effect, seed=0, strength=0.0, **QUIET)
    for a, b in zip(runs, clean):
        np.testing.assert_array_equal(a.displacement, b.displacement)
        np.testing.assert_array_equal(a.sense_voltage, b.sense_voltage)


@pytest.mark.parametrize("effect", synthetic.EFFECTS)
def test_effect_vanishes_continuously(effect, clean):
    # the truth formulations tend to the paper's model as the strength goes to 0
    # (not only by the switch at 0): at strength 1e-6 the change is ~1e-6 of its size
    small = synthetic.generate_runs(effect, seed=0, strength=1e-6, **QUIET)
    full = synthetic.generate_runs(effect, seed=0, strength=1.0, **QUIET)
    big = max(_rms_change(f, c, skip=0) for f, c in zip(full, clean))
    tiny = max(_rms_change(s, c, skip=0) for s, c in zip(small, clean))
    assert tiny < 1e-4 * big


# ---------------------------------------------------------------- each effect is visible


@pytest.mark.parametrize("effect, runs_that_matter", [
    ("rate_independent_hysteresis", ["f005_I1.0", "f200_I1.0"]),
    ("magnetization_saturation", ["f005_I1.0", "f020_I1.0"]),
    ("eddy_current_diffusion", ["f150_I1.0", "f200_I1.0"]),
    ("transport_delay", ["f150_I1.0", "f200_I1.0"]),
    ("mechanical_resonance", ["f200_I1.0"]),
    ("thermal_drift", ["f005_I1.0"]),
])
def test_effect_changes_displacement_measurably(effect, runs_that_matter, clean, effect_runs):
    # strength 1: at least 1 um RMS (20 x the default 0.05 um noise) where it matters
    eff, ref = _by_name(effect_runs[effect]), _by_name(clean)
    for name in runs_that_matter:
        assert _rms_change(eff[name], ref[name]) > 1e-6
    # and the size grows with the strength
    sizes = []
    for s in (0.25, 0.5, 1.0):
        runs = synthetic.generate_runs(effect, seed=0, strength=s, **QUIET)
        sizes.append(max(_rms_change(a, b) for a, b in zip(runs, clean)))
    assert sizes[0] < sizes[1] < sizes[2]


@pytest.mark.parametrize("effect", synthetic.EFFECTS)
def test_only_magnetic_effects_change_the_sense_voltage(effect, clean, effect_runs):
    # B is the magnetic state (eqs 4, 17): a magnetic effect changes it; mechanical and
    # sensor effects act downstream of M (eqs 25-30) and leave B (and so E, eq 21) untouched
    changed = max(np.max(np.abs(a.sense_voltage - b.sense_voltage))
                  for a, b in zip(effect_runs[effect], clean))
    if effect in synthetic.MAGNETIC_EFFECTS:
        assert changed > 0.02  # V, twice the default voltage noise
    else:
        assert changed == 0.0


# ---------------------------------------------------------------- signatures


def test_transport_delay_phase_grows_linearly_with_frequency(clean, effect_runs):
    # a pure delay: y lags by w tau, amplitude unchanged; the fitted slope of the
    # phase against w is tau (0.5 ms nominal)
    tau = effect_runs["transport_delay"][0].meta["truth"]["delay"]
    assert tau == pytest.approx(0.5e-3)
    eff = _by_name(effect_runs["transport_delay"])
    w, lag = [], []
    for c in clean:
        if c.meta["current_amplitude"] != 1.0:
            continue
        ratio = _phasor(eff[c.name], eff[c.name].displacement, c.frequency) / _phasor(
            c, c.displacement, c.frequency)
        assert abs(ratio) == pytest.approx(1.0, abs=2e-3)
        w.append(2 * math.pi * c.frequency)
        lag.append(-np.angle(ratio))
    slope, intercept = np.polyfit(w, lag, 1)
    assert slope == pytest.approx(tau, rel=1e-3)
    assert abs(intercept) < 1e-3


def test_eddy_diffusion_follows_the_slab_solution(clean, effect_runs):
    # Stoll 1974 / Bertotti 1998: the thickness-averaged field of a slab of
    # thickness d is H_s tanh(q)/q, q = (1 + j) d / (2 delta), delta = sqrt(2/(w mu sigma)),
    # so d/(2 delta) = sqrt(w mu sigma d^2 / 8). B's fundamental relative to the
    # clean B must follow it; 12 finite-difference nodes are within ~0.5 % at 200 Hz.
    runs = _by_name(effect_runs["eddy_current_diffusion"])
    truth = effect_runs["eddy_current_diffusion"][0].meta["truth"]
    lags = []
    for c in clean:
        if c.meta["current_amplitude"] != 1.0:
            continue
        r = runs[c.name]
        w = 2 * math.pi * c.frequency
        b_eff = _phasor(r, np.cumsum(r.sense_voltage), c.frequency)
        b_ref = _phasor(c, np.cumsum(c.sense_voltage), c.frequency)
        q = (1 + 1j) * math.sqrt(w * truth["diffusion_time"] / 8.0)
        slab = np.tanh(q) / q
        assert abs(b_eff / b_ref / slab - 1) < 0.01
        lags.append(-np.angle(b_eff / b_ref))
    # the extra lag grows with f and leaves the linear-in-f regime towards 45 deg
    assert np.all(np.diff(lags) > 0)
    assert lags[-1] < math.radians(45)
    per_hz = np.array(lags) / np.array(FREQUENCIES)
    assert per_hz[-1] < 0.6 * per_hz[0]
    # skin depth equals the half thickness at 100 Hz at strength 1 (nominal)
    mu_sigma = truth["diffusion_time"] / truth["thickness"] ** 2
    delta = math.sqrt(2 / (2 * math.pi * 100.0 * mu_sigma))
    assert delta == pytest.approx(truth["thickness"] / 2, rel=1e-9)


def test_mechanical_resonance_follows_the_two_mass_law(clean, effect_runs):
    # Two masses (rod m_1 with K, c; output m_2 on a joint k_j, c_j): in steady
    # state the output mass moves by T(jw) = Y_2/F over the paper's 1/(K - w^2 m + jwc)
    # (eq 29). Written out here from Newton's law for the two masses.
    p = gmt.TransducerParameters()
    truth = effect_runs["mechanical_resonance"][0].meta["truth"]
    m2, kj, cj = truth["output_mass"], truth["joint_stiffness"], truth["joint_damping"]
    m1 = p.mass - m2
    runs = _by_name(effect_runs["mechanical_resonance"])
    gains = []
    for c in clean:
        if c.meta["current_amplitude"] != 1.0:
            continue
        w = 2 * math.pi * c.frequency
        zj = kj + 1j * w * cj
        joint = zj / (zj - w * w * m2)  # Y_2 / Y_1
        rod = 1.0 / (p.stiffness + 1j * w * p.damping - w * w * m1 + zj * (1 - joint))
        expected = rod * joint * (p.stiffness + 1j * w * p.damping - w * w * p.mass)
        r = runs[c.name]
        ratio = _phasor(r, r.displacement, c.frequency) / _phasor(c, c.displacement, c.frequency)
        # the paper's stepper holds the force (ZOH); the truth's bracket interpolates
        # it: ~(w h)^2 differences, 1e-3 at 256 samples a period
        assert abs(ratio / expected - 1) < 2e-3
        gains.append(abs(ratio))
    # the amplitude rises towards the resonance (450 Hz nominal, above the data)
    assert np.all(np.diff(gains) > 0)
    assert gains[-1] > 1.1 and gains[0] < 1.001


def test_hysteresis_is_rate_independent_and_not_elliptic(clean, effect_runs):
    # Preisach (Mayergoyz 1991): the extra loop in the B-H plane has the same area
    # per cycle at 5 Hz as at 200 Hz (a rate-independent loss, persisting as f -> 0),
    # grows with amplitude, and has pointed tips: a strong third harmonic.
    p = gmt.TransducerParameters()
    truth = effect_runs["rate_independent_hysteresis"][0].meta["truth"]
    areas = {}
    for f in (5.0, 200.0):
        for im in (0.5, 1.0):
            ref = synthetic.true_response(None, {}, p, f, im)
            eff = synthetic.true_response("rate_independent_hysteresis", truth, p, f, im)
            one = slice(256 * 7, 256 * 8 + 1)  # last full period
            h = p.field_per_ampere * im * np.cos(2 * np.pi * f * ref["time"])
            db = eff["flux_density"] - ref["flux_density"]
            # closed loop: the period's last sample + 1 is the first of the next one
            hh = np.append(h[one], h[256 * 7])
            bb = np.append(db[one], db[256 * 7])
            areas[f, im] = abs(trapezoid(bb, hh))  # J/m^3 per cycle
            harm = _harmonics(ref["time"], db, f, orders=(1, 3))
            assert harm[3] > 0.05 * harm[1]
    for im in (0.5, 1.0):
        assert areas[200.0, im] == pytest.approx(areas[5.0, im], rel=1e-3)
    assert areas[5.0, 1.0] > 3 * areas[5.0, 0.5]
    assert truth["preisach_magnetization"] > 0


def test_saturation_flattens_more_at_the_larger_amplitude(clean, effect_runs):
    # Langevin anhysteretic with the bias inside: the gain (um per A) falls with
    # amplitude, the top of the stroke (towards saturation) flattens, and the
    # odd harmonics grow faster than linearly with amplitude.
    ref, eff = _by_name(clean), _by_name(effect_runs["magnetization_saturation"])
    drop = {}
    for im in ("0.5", "1.0"):
        c, r = ref[f"f005_I{im}"], eff[f"f005_I{im}"]
        drop[im] = 1 - abs(_phasor(r, r.displacement, 5.0)) / abs(_phasor(c, c.displacement, 5.0))
        y, yc = r.displacement[SKIP:], c.displacement[SKIP:]
        top = (y.max() - np.median(y)) / (yc.max() - np.median(yc))
        bottom = (np.median(y) - y.min()) / (np.median(yc) - yc.min())
        assert top < bottom
    assert drop["0.5"] > 0 and drop["1.0"] > 4 * drop["0.5"]
    third = {im: _harmonics(eff[f"f005_I{im}"].time, eff[f"f005_I{im}"].displacement, 5.0)[3]
             for im in ("0.5", "1.0")}
    assert third["1.0"] > 2 * 2 * third["0.5"]  # faster than linear in I_m (x2)


def test_thermal_drift_is_monotonic_and_largest_in_long_runs(clean, effect_runs):
    truth = effect_runs["thermal_drift"][0].meta["truth"]
    eff, ref = _by_name(effect_runs["thermal_drift"]), _by_name(clean)
    # temperature against an independent integration of the same ODE
    r = eff["f005_I1.0"]
    w = 2 * math.pi * 5.0
    tau, r_th = truth["thermal_time_constant"], truth["thermal_resistance"]
    r0, alpha = truth["coil_resistance"], truth["resistance_coefficient"]

    def rhs(t, x):
        return [(r_th * math.cos(w * t) ** 2 * r0 * (1 + alpha * x[0]) - x[0]) / tau]

    sol = solve_ivp(rhs, (0, r.time[-1]), [0.0], t_eval=r.time, rtol=1e-10, atol=1e-12,
                    max_step=0.01)
    p = gmt.TransducerParameters()
    dt = synthetic.temperature_rise(r.time, 1.0, 5.0, truth)
    np.testing.assert_allclose(dt, sol.y[0], rtol=0, atol=1e-5 * sol.y[0][-1])
    assert r.meta["final_temperature_rise"] == pytest.approx(dt[-1])
    # the drift of the cycle means grows monotonically over the run
    for name in ("f005_I1.0", "f005_I0.5", "f050_I1.0"):
        d = (eff[name].displacement - ref[name].displacement).reshape(8, 256).mean(axis=1)
        assert np.all(np.diff(d) > 0)
    # most visible in the long, low-frequency runs; with coil heating ~ i^2
    span = {n: np.ptp(eff[n].displacement - ref[n].displacement) for n in eff}
    assert span["f005_I1.0"] > 10 * span["f200_I1.0"]
    assert span["f005_I1.0"] > 3 * span["f005_I0.5"]
    # net drift: sensor offset minus the bias strain's fall with K_lambda(T)
    y_bias = gmt.bias_displacement(p)
    expected = (truth["offset_tc"] + truth["strain_coefficient_tc"] * y_bias) * dt[-1]
    final = (eff["f005_I1.0"].displacement - ref["f005_I1.0"].displacement)[-256:].mean()
    assert final == pytest.approx(expected, rel=0.05)
    assert final > 3e-6


# ---------------------------------------------------------------- the building blocks


def test_preisach_wiping_out_and_congruency():
    # Mayergoyz 1991, sec. 1.3: return-point memory (a closed minor loop returns
    # exactly to its start) and odd symmetry from the demagnetised state
    dens = dict(coercive_field=5e3, coercive_log_spread=0.5, interaction_spread=4e3)
    path = np.array([0.0, 10e3, 2e3, 8e3, 2e3, 10e3, -10e3, 10e3])
    out = synthetic.preisach(path, **dens)
    assert out[5] == pytest.approx(out[1], abs=1e-12)  # back to 10 kA/m: minor loop wiped out
    assert out[7] == pytest.approx(out[5], abs=1e-12)
    assert np.all(np.abs(out) <= 1.0)
    up = synthetic.preisach(np.array([20e3, -20e3, 20e3]), **dens)
    assert up[1] == pytest.approx(-up[0], rel=1e-3)  # symmetric major loop
    far = synthetic.preisach(np.array([1e6]), **dens)
    assert far[0] == pytest.approx(1.0, abs=1e-6)  # positive saturation


def test_langevin_function():
    x = np.array([-5.0, -0.5, 0.2, 1.0, 30.0])
    np.testing.assert_allclose(synthetic.langevin(x), 1 / np.tanh(x) - 1 / x, rtol=1e-12)
    # small x, where coth x - 1/x cancels: its Taylor series x/3 - x^3/45 + 2x^5/945
    # (next term x^7/4725, < 1e-13 relative here)
    x = np.array([-2e-3, 1e-8, 1e-4, 2e-3])
    np.testing.assert_allclose(synthetic.langevin(x), x / 3 - x ** 3 / 45 + 2 * x ** 5 / 945,
                               rtol=1e-13)
    # the slope against a central difference
    x = np.array([-1.0, 0.04, 0.06, 2.0])
    fd = (synthetic.langevin(x + 1e-6) - synthetic.langevin(x - 1e-6)) / 2e-6
    np.testing.assert_allclose(synthetic.langevin_slope(x), fd, rtol=1e-8)
    for y in (0.01, 0.3, 0.9):
        assert synthetic.langevin(synthetic.inverse_langevin(y)) == pytest.approx(y, rel=1e-12)


def test_true_response_refuses_an_unknown_effect():
    # a misspelt effect must not quietly give the paper's model alone
    with pytest.raises(ValueError, match="'eddy' is not one of"):
        synthetic.true_response("eddy", {}, gmt.TransducerParameters(), 50.0, 1.0, cycles=1,
                                samples_per_cycle=16)
