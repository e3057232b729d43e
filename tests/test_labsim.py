"""Tests of labsim, the independent lab-data generator (tests/labsim/).

Each test names its reference: a number of the paper (Li et al., Tables 1-2 and text), a
textbook limit, or an independent numerical method (scipy's solve_ivp, a finite-volume
diffusion solver, a brute-force play-operator sum). Reference values are typed in here, not
read from labsim.
"""
from __future__ import annotations

import csv
import itertools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

import labsim
from labsim import lti
from labsim.bmlaw import flux_density_amplitude
from labsim.constants import Transducer
from labsim.effects import EffectSet
from labsim.hysteresis import loop_area, periodic_branches, play_sequence
from labsim.sizes import effect_size
from labsim.transducer import simulate
from labsim.waveform import Waveform, respond

MU_0 = 4e-7 * math.pi
#: Paper, Table 2 (SI): N, k_f, L, m, c, K, M_b, K_lambda, K_h, n, K_e, K_ex, N_c, A_c.
N, K_F, L = 1300.0, 1.1, 0.080
M, C, K = 0.02, 2945.0, 1.963e7
M_B, K_LAMBDA = 250e3, 1.4694e-14
K_H, N_STEIN, K_E, K_EX = 85805.0, 1.8092, 2753.39, 895.80
N_C, A_C = 150.0, 380e-6


def field_amp(current):
    """Paper eq 1: H_m = N I_m / (k_f L)."""
    return N * current / (K_F * L)


def paper_force(t, frequency, current, phase):
    """F - F_bias of the paper's model, eqs 4-5, 16, 20, 25, 28, written out here."""
    h_m = field_amp(current)
    b_m = float(flux_density_amplitude(frequency, h_m))
    mu_i = (K_H * b_m**N_STEIN + K_E * b_m**2 * frequency
            + K_EX * b_m**1.5 * frequency**0.5) / (math.pi * MU_0 * h_m**2)
    mu_r = math.sqrt((b_m / (MU_0 * h_m)) ** 2 - mu_i**2)
    theta = 2 * math.pi * frequency * t + phase
    mag = h_m * ((mu_r - 1) * np.cos(theta) + mu_i * np.sin(theta))
    return K * L * K_LAMBDA * ((mag + M_B) ** 2 - M_B**2)  # A_r E^H = K L


def integrate(force, t_end, points):
    """m y'' + c y' + K y = F(t) from rest (eq 27), DOP853 at rtol 1e-12."""
    def rhs(t, x):
        return [x[1], (force(t) - C * x[1] - K * x[0]) / M]
    t = np.linspace(0.0, t_end, points)
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-18,
                    t_eval=t, max_step=1e-5)
    return t, sol.y[0]


def fundamental(t, x, frequency):
    """Least-squares amplitude and phase of the fundamental: x ~ A cos(w t + phi) + const."""
    w = 2 * math.pi * frequency
    basis = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
    a, b, _ = np.linalg.lstsq(basis, x, rcond=None)[0]
    return math.hypot(a, b), math.atan2(-b, a)


CLEAN = EffectSet()


# --- the paper's model -----------------------------------------------------------------

def test_bm_law_within_1_5_percent_of_table_1():
    # paper, Table 1 (f [Hz], I_m [A], B_m [T]); the law's fit leaves at most 1.43 %
    table_1 = [(5, 0.5, 0.0300), (5, 0.7, 0.0530), (50, 1.0, 0.0637),
               (70, 1.0, 0.0590), (80, 1.0, 0.0570), (100, 1.0, 0.0531)]
    for f, i_m, b_m in table_1:
        assert float(flux_density_amplitude(f, field_amp(i_m))) == pytest.approx(b_m, rel=0.015)


@pytest.mark.parametrize("frequency, peak_to_peak", [(50.0, 46e-6), (100.0, 36e-6)])
def test_peak_to_peak_displacement_at_1A(frequency, peak_to_peak):
    # paper, text of "Simulation and experiments": 46 um at 50 Hz and 36 um at 100 Hz, 1 A.
    # 5 %: the B_m law is within 1.5 % of Table 1 and the paper quotes two digits.
    ds = labsim.make_dataset(seed=3, frequencies=[frequency], amplitudes=[1.0])
    y = ds.runs[0].displacement
    assert np.ptp(y) == pytest.approx(peak_to_peak, rel=0.05)


def test_sense_voltage_gives_bm_by_eq_22():
    # paper eq 22: B_m = E_m / (w N_c A_c); the filter's gain at f is divided out
    f = 70.0
    ds = labsim.make_dataset(seed=1, frequencies=[f], amplitudes=[1.0], noise_voltage_V=0.0)
    run = ds.runs[0]
    e_m, _ = fundamental(run.time, run.sense_voltage, f)
    gain = 1 / math.sqrt(1 + (f / (0.2 * run.sample_rate)) ** 8)  # Butterworth, order 4
    b_m = e_m / gain / (2 * math.pi * f * N_C * A_C)
    assert b_m == pytest.approx(float(flux_density_amplitude(f, field_amp(1.0))), rel=2e-4)


@pytest.mark.integration  # solve_ivp from switch-on, 1-3 s
def test_clean_model_matches_solve_ivp_from_switch_on():
    # exact harmonic sum + modal switch-on transient vs DOP853 (rtol 1e-12) on eq 27
    f, i_m, phase = 100.0, 1.0, 0.8
    run = simulate(Transducer(), f, i_m, phase, CLEAN)
    t, y_ref = integrate(lambda t: paper_force(t, f, i_m, phase), 0.012, 1201)
    assert np.max(np.abs(run.displacement(t) - y_ref)) < 1e-12  # 1 pm of ~37 um p-p


@pytest.mark.integration
@pytest.mark.parametrize("formulation", ["default", "alt"])
def test_transient_grid_path_matches_solve_ivp(formulation):
    # hysteresis + eddy + saturation + drift use the first-order-hold transient grid (in
    # both formulations, README "Second formulations"); check it against DOP853 driven by a
    # cubic spline of the same force through eq 27
    effects = EffectSet.from_strengths({"eddy_current_diffusion": 1, "thermal_drift": 1,
                                        "rate_independent_hysteresis": 1,
                                        "magnetization_saturation": 1}, formulation)
    run = simulate(Transducer(), 100.0, 1.0, 0.8, effects)
    fine = np.linspace(0.0, 0.03, 60001)
    spline = CubicSpline(fine, run.force.evaluate(fine))
    t, y_ref = integrate(spline, 0.03, 601)
    assert np.max(np.abs(run.displacement(t) - y_ref)) < 1e-10  # 0.1 nm


# --- acquisition -----------------------------------------------------------------------

def test_anti_alias_gain_and_phase_are_butterworth():
    # 4th-order Butterworth polynomial (s^2 + 0.765367 s + 1)(s^2 + 1.847759 s + 1)
    # (textbook table, e.g. Oppenheim & Schafer); tested where it matters: f = 0.5 f_c
    f, cutoff = 50.0, 100.0
    ds = labsim.make_dataset(seed=2, frequencies=[f], amplitudes=[1.0], sample_rate=5000.0,
                             anti_alias_cutoff=cutoff, noise_current_A=0.0, adc_bits=24)
    run = ds.runs[0]
    amp, phi = fundamental(run.time + run.record_start, run.current, f)
    s = 1j * f / cutoff
    h = 1 / ((s**2 + 0.765367 * s + 1) * (s**2 + 1.847759 * s + 1))
    assert amp == pytest.approx(abs(h) * 1.0, rel=1e-5)
    expected = run.drive_phase + np.angle(h)
    assert math.remainder(phi - expected, 2 * math.pi) == pytest.approx(0.0, abs=1e-5)


def test_adc_values_are_multiples_of_the_step():
    # a b-bit bipolar ADC over +-FS has step 2 FS / 2^b (IEEE Std 1241, code widths)
    ds = labsim.make_dataset(seed=4, frequencies=[20.0], amplitudes=[0.6], adc_bits=12)
    run = ds.runs[0]
    for name in ("current", "displacement", "sense_voltage"):
        step = 2 * run.full_scale[name] / 2**12
        codes = getattr(run, name) / step
        assert np.allclose(codes, np.round(codes), atol=1e-6)
        assert np.max(np.abs(codes)) <= 2**11


def test_noise_level_is_the_requested_one():
    # difference of two seeds' records with identical phases is noise only: std sqrt(2) sigma
    kwargs = dict(frequencies=[50.0], amplitudes=[1.0], noise_um=0.05)
    a = labsim.make_dataset(seed=5, **kwargs).runs[0]
    b = labsim.make_dataset(seed=5, **{**kwargs, "noise_um": 0.0}).runs[0]
    residual = (a.displacement - b.displacement) * 1e6
    assert np.std(residual) == pytest.approx(0.05, rel=0.1)  # 4800 samples: +-2 % (1 sigma)


def test_fixed_rate_few_cycles_and_transient_start():
    ds = labsim.make_dataset(seed=6, frequencies=[5.0, 200.0], amplitudes=[1.0],
                             sample_rate=20e3, low_frequency_cycles=3, start_in_transient=True,
                             noise_current_A=0.0, sense_coil=False)
    slow, fast = ds.runs
    assert slow.time.size == 3 * 4000 and fast.time.size == 6 * 100
    assert slow.sample_rate == fast.sample_rate == 20e3
    assert slow.record_start == 0.0 and slow.sense_voltage is None
    # the filtered current starts from rest at the switch-on (within one ADC step)
    assert abs(slow.current[0]) <= 2 * slow.full_scale["current"] / 2**16


def test_switch_on_spike_of_the_sense_voltage_saturates_the_adc():
    # the paper's phasor model switches B on with a step: E = -N_c A_c dB/dt (eq 21) has an
    # impulse, spread by the filter over a few samples; the ADC is ranged on the running
    # signal, so those samples sit on the end codes and are counted
    ds = labsim.make_dataset(seed=6, frequencies=[50.0], amplitudes=[1.0],
                             start_in_transient=True)
    run = ds.runs[0]
    assert 0 < run.saturated["sense_voltage"] < 40  # of 4800 samples, all in the first ms
    top = run.full_scale["sense_voltage"] * (1 - 2.0**-15)
    assert np.all(np.abs(run.sense_voltage[int(1e-3 * run.sample_rate):]) < top)
    assert run.saturated["displacement"] == 0


def test_jitter_is_seeded_and_recorded():
    a = labsim.make_dataset(seed=12, frequencies=[50.0], amplitudes=[1.0], jitter=0.03)
    b = labsim.make_dataset(seed=12, frequencies=[50.0], amplitudes=[1.0], jitter=0.03)
    factors = a.truth["jitter_factors"]
    assert factors == b.truth["jitter_factors"] and len(set(factors.values())) == 6
    assert all(abs(k - 1) <= 0.09 for k in factors.values())  # clipped at 3 sigma
    assert a.truth["transducer"].mass == pytest.approx(0.02 * factors["mass"])


def test_record_start_phase_is_random_and_reproducible():
    a = labsim.make_dataset(seed=7, frequencies=[50.0, 100.0], amplitudes=[1.0])
    b = labsim.make_dataset(seed=7, frequencies=[50.0, 100.0], amplitudes=[1.0])
    c = labsim.make_dataset(seed=8, frequencies=[50.0, 100.0], amplitudes=[1.0])
    assert all(np.array_equal(x.displacement, y.displacement) for x, y in zip(a.runs, b.runs))
    assert not np.array_equal(a.runs[0].displacement, c.runs[0].displacement)
    assert len({round(r.phase_at_start, 6) for r in a.runs + c.runs}) == 4


def test_csv_has_the_measured_data_columns(tmp_path):
    # docs/MEASURED.md: run, frequency_Hz, time_s, current_A, displacement_um, sense_voltage_V
    ds = labsim.make_dataset(seed=9, frequencies=[50.0, 80.0], amplitudes=[0.6],
                             samples_per_cycle=100, cycles=3)
    path = ds.write_csv(tmp_path / "runs.csv")
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    rows = list(csv.DictReader(lines))
    assert list(rows[0]) == ["run", "frequency_Hz", "time_s", "current_A", "displacement_um",
                             "sense_voltage_V"]
    assert len(rows) == 2 * 300 and {r["run"] for r in rows} == {"50Hz_0.6A", "80Hz_0.6A"}
    first = [r for r in rows if r["run"] == "50Hz_0.6A"]
    assert float(first[1]["time_s"]) == pytest.approx(1 / 5000.0)
    assert float(first[0]["displacement_um"]) == pytest.approx(ds.runs[0].displacement[0] * 1e6)
    no_coil = labsim.make_dataset(seed=9, frequencies=[50.0], amplitudes=[0.6], cycles=2,
                                  samples_per_cycle=100, sense_coil=False)
    header = [ln for ln in no_coil.write_csv(tmp_path / "b.csv").read_text().splitlines()
              if not ln.startswith("#")][0]
    assert header == "run,frequency_Hz,time_s,current_A,displacement_um"


@pytest.mark.parametrize("kwargs, names", [
    (dict(effects={"wobble": 1.0}), "wobble"),
    (dict(effects={"transport_delay": -1.0}), "strength"),
    (dict(samples_per_cycle=100, sample_rate=20e3), "sample_rate"),
    (dict(sample_rate=1000.0, anti_alias_cutoff=600.0), "anti_alias_cutoff"),
    (dict(amplitudes=[0.0]), "amplitude"),
    (dict(full_scale={"displacement": 1e-6}), "full_scale"),
])
def test_bad_input_is_refused_by_name(kwargs, names):
    with pytest.raises(labsim.LabsimError, match=names):
        labsim.make_dataset(seed=0, **{"frequencies": [50.0], **kwargs})


# --- the effects -----------------------------------------------------------------------

@pytest.mark.parametrize("name", labsim.EFFECTS)
def test_strength_one_is_clearly_visible(name):
    # the generator's specification: 0.5-3 um RMS change of y at 100 Hz, 1 A (noise 0.05 um)
    size = effect_size({name: 1.0})
    assert 0.5e-6 < size["displacement_rms"] < 3e-6
    magnetic = name in ("rate_independent_hysteresis", "magnetization_saturation",
                        "eddy_current_diffusion")
    # B changes with the magnetic effects only (mechanical / sensor effects leave it alone)
    assert (size["flux_rms"] > 1e-3 * size["flux_rms_clean"]) == magnetic
    if not magnetic:
        assert size["flux_rms"] == 0.0


def test_delay_is_exactly_a_time_shift():
    t = np.linspace(0.0, 0.05, 777)
    aa = lti.butterworth(4, 4000.0)
    clean = simulate(Transducer(), 80.0, 1.0, 0.3, CLEAN)
    late = simulate(Transducer(), 80.0, 1.0, 0.3, EffectSet.from_strengths({"transport_delay": 1}))
    assert np.allclose(late.displacement(t, aa), clean.displacement(t - 100e-6, aa),
                       rtol=0, atol=1e-18)
    assert np.array_equal(late.sense_voltage(t, aa), clean.sense_voltage(t, aa))


def test_eddy_modal_series_equals_bessel_form():
    # Mittag-Leffler series sum 4/(j0n^2 + s tau) vs 2 I1(q)/(q I0(q)) (Stoll 1974)
    diff = lti.cylinder_diffusion(1e-3)
    s = 1j * 2 * math.pi * np.array([1.0, 50.0, 200.0, 2000.0])
    series = diff.direct + np.sum(diff.residues[:, None] / (s[None, :] - diff.poles[:, None]), 0)
    assert np.allclose(series, diff.transfer(s), rtol=2e-5)


def test_eddy_limits():
    diff = lti.cylinder_diffusion(1e-3)
    # low frequency: F = 1 - s tau / 8 + O(s^2) (series of 2 I1(q)/(q I0(q)))
    w = 2 * math.pi * 0.1
    assert diff.transfer(1j * w) == pytest.approx(1 - 1j * w * 1e-3 / 8, abs=1e-8)
    # high frequency (skin depth << radius): F -> 2/q, phase -> -45 degrees
    value = diff.transfer(1j * 1e9)
    assert math.degrees(np.angle(value)) == pytest.approx(-45.0, abs=0.05)
    assert abs(value) == pytest.approx(2 / math.sqrt(1e9 * 1e-3), rel=1e-2)
    # vanishing diffusion time (tau = 0.1 ns): the paper's model; the lag w tau / 8 = 8e-9 rad
    # moves y by ~ 2e-13 m
    t = np.linspace(0.06, 0.09, 300)
    clean = simulate(Transducer(), 100.0, 1.0, 0.0, CLEAN, transient=False)
    tiny = simulate(Transducer(), 100.0, 1.0, 0.0,
                    EffectSet.from_strengths({"eddy_current_diffusion": 1e-7}), transient=False)
    assert np.allclose(tiny.displacement(t), clean.displacement(t), rtol=0, atol=1e-12)


def test_eddy_transient_matches_finite_volume_diffusion():
    # switched-on surface field H_s(t) = cos(w t) into a cylinder: dH/dt = (1/(mu sigma))
    # (1/r) d/dr (r dH/dr); mean of H over the section by finite volumes (120 rings, BDF)
    tau, f = 1e-3, 200.0
    w = 2 * math.pi * f
    rings = 120
    edges = np.linspace(0.0, 1.0, rings + 1)  # radius in units of a
    centres = 0.5 * (edges[1:] + edges[:-1])
    areas = edges[1:] ** 2 - edges[:-1] ** 2

    def rhs(t, h):
        padded = np.append(h, math.cos(w * t))
        gaps = np.append(np.diff(centres), 1.0 - centres[-1])
        flux = edges[1:] * np.diff(padded) / gaps  # r dH/dr at the outer edge of each ring
        inflow = flux - np.append(0.0, flux[:-1])
        return 2.0 * inflow / (areas * tau)

    t = np.linspace(0.0, 0.01, 201)
    sol = solve_ivp(rhs, (0, 0.01), np.zeros(rings), method="BDF", t_eval=t, rtol=1e-9,
                    atol=1e-12)
    mean_fv = areas @ sol.y
    mean = respond(lti.cylinder_diffusion(tau), Waveform.sinusoid(w, 1.0)).evaluate(t)
    # after the first 50 us the two agree to the finite-volume error (second order, 120 rings);
    # at t = 0 labsim's modes beyond the 60th (time constants < tau / j0_60^2 = 28 ns) act
    # instantaneously: a step of 1 - sum 4 / j0n^2 = 0.0067 that the PDE spreads over ~30 ns
    assert np.max(np.abs(mean - mean_fv)[1:]) < 1e-4
    assert mean[0] == pytest.approx(0.0067, abs=1e-4)


def test_hysteresis_closed_form_equals_discrete_plays():
    # brute force: 8000 play operators of thresholds r_k (midpoints, dr = 5 A/m, up to
    # 20 r0) with weights p(r_k) dr
    chi, r0 = 0.25, 2000.0
    t = np.linspace(0.0, 2.0, 801)
    u = 9000 * np.cos(2 * np.pi * t + 0.7) + 2500 * np.sin(5 * np.pi * t)
    r = (np.arange(8000) + 0.5) * 5.0
    weight = np.exp(-r / r0) / r0 * 5.0
    z, brute = np.zeros_like(r), np.empty_like(u)
    for k, uk in enumerate(u):
        z = np.maximum(uk - r, np.minimum(uk + r, z))
        brute[k] = chi * weight @ z
    # differences: the closed form refines turning points between samples (O(h^2))
    assert np.max(np.abs(play_sequence(u, chi, r0) - brute)) < 0.5  # A/m, of ~2500 A/m


def assert_loop_stays_open(effects):
    """Rate independence: the flux added at 0.5 Hz equals that at 5 Hz (0.6 A), per phase of
    the drive, and is an open loop, not a vanishing one, as f -> 0."""
    shapes = []
    for f in (0.5, 5.0):
        phase = np.linspace(0, 2 * np.pi, 64, endpoint=False)
        t = 10 / f + phase / (2 * np.pi * f)
        with_h = simulate(Transducer(), f, 0.6, 0.0, effects, transient=False).flux.evaluate(t)
        without = simulate(Transducer(), f, 0.6, 0.0, CLEAN, transient=False).flux.evaluate(t)
        shapes.append(with_h - without)
    assert np.allclose(shapes[0], shapes[1], rtol=0, atol=1e-12)
    assert np.ptp(shapes[0]) > 1e-3  # T


def test_hysteresis_is_rate_independent_with_rayleigh_loops():
    chi, r0 = 0.25, 2000.0
    # Rayleigh limit: for A << r0 each play r < A encloses 4 r (A - r), so the loop area is
    # chi p(0) (2/3) A^3 = (2/3) chi A^3 / r0 (Rayleigh's law: loss ~ H_m^3)
    for amplitude in (20.0, 40.0):
        assert loop_area(amplitude, chi, r0) == pytest.approx(2 / 3 * chi * amplitude**3 / r0,
                                                              rel=2 * amplitude / r0)
    assert_loop_stays_open(EffectSet.from_strengths({"rate_independent_hysteresis": 1.0}))
    # pointed tips: the slope right after the reversal is zero (no play has moved yet)
    tip = periodic_branches(5000.0, np.array([1e-4, 2e-4]), chi, r0)
    assert abs(tip[1] - tip[0]) < 1e-3


def test_saturation_small_signal_limit():
    # Langevin M_s L(3 m / M_s) at the bias: the small-signal gain of y is
    # S(M_b) S'(M_b) / M_b of the paper's, with S' = 3 L'(x) and L'(x) = 1/x^2 - 1/sinh^2 x
    m_s = 0.8e6
    x = 3 * M_B / m_s
    langevin = 1 / math.tanh(x) - 1 / x
    slope = 3 * (1 / x**2 - 1 / math.sinh(x) ** 2)
    expected = m_s * langevin * slope / M_B
    t = np.linspace(0.5, 0.7, 401)
    amps = []
    for effects in (CLEAN, EffectSet.from_strengths({"magnetization_saturation": 1.0})):
        run = simulate(Transducer(), 5.0, 0.02, 0.0, effects, transient=False)
        amps.append(fundamental(t, run.displacement(t), 5.0)[0])
    assert amps[1] / amps[0] == pytest.approx(expected, rel=2e-3)  # 0.02 A: curvature ~1e-3


def test_resonance_keeps_static_gain_and_rises_towards_the_mode():
    base = lti.mass_spring_damper(M, C, K)
    two = lti.two_mass(M, C, K, 0.05, 25.0, 3.16e5)
    assert abs(two(0.0)) == pytest.approx(1 / K, rel=1e-12)  # static compliance 1/K
    freqs = np.array([5, 20, 50, 70, 80, 100, 150, 200.0])
    ratio = np.abs(two(2j * np.pi * freqs) / base(2j * np.pi * freqs))
    assert np.all(np.diff(ratio) > 0) and ratio[-1] > 1.2
    # vanishing output mass: the paper's eq 27
    tiny = lti.two_mass(M, C, K, 1e-12, 25.0, 3.16e5)
    assert np.allclose(tiny(2j * np.pi * freqs), base(2j * np.pi * freqs), rtol=1e-8)


def test_thermal_drift_is_monotonic_over_a_run():
    # 5 Hz, 1 A, 6 cycles: the cycle means rise and the cycle amplitudes fall monotonically
    effects = EffectSet.from_strengths({"thermal_drift": 1.0})
    run = simulate(Transducer(), 5.0, 1.0, 0.0, effects, transient=False)
    t = 1.0 + np.arange(6 * 400) / 2000.0
    y = run.displacement(t).reshape(6, 400)
    assert np.all(np.diff(y.mean(axis=1)) > 0) and np.all(np.diff(np.ptp(y, axis=1)) < 0)
    assert np.ptp(y.mean(axis=1)) > 0.3e-6  # clearly above 0.05 um noise


@pytest.mark.parametrize("formulation", ["default", "alt"])
@pytest.mark.parametrize("pair", list(itertools.combinations(labsim.EFFECTS, 2)))
def test_every_pair_of_effects(pair, formulation):
    kwargs = dict(seed=11, frequencies=[5.0, 100.0], amplitudes=[1.0], samples_per_cycle=100,
                  cycles=3, start_in_transient=True)
    ds = labsim.make_dataset(dict.fromkeys(pair, 1.0), formulation=formulation, **kwargs)
    clean = labsim.make_dataset(**kwargs)
    for run, ref in zip(ds.runs, clean.runs):
        assert np.all(np.isfinite(run.displacement)) and np.all(np.isfinite(run.sense_voltage))
        assert np.std(run.displacement - ref.displacement) > 0.05e-6
        # from rest at the switch-on: the first samples agree within an ADC step (same noise)
        step = 2 * run.full_scale["displacement"] / 2**16
        assert abs(run.displacement[0] - ref.displacement[0]) <= step * (1 + 1e-9)
