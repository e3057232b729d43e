"""Identification (smeha.identify): recover the paper's loss coefficients from synthetic runs.

Synthetic data are generated here, never with the code under test: for each
(f, I_m), B_m from gmt's calibration (paper Table 1 through
gmt.DEFAULT_CALIBRATION, so the model is self-consistent), mu'' from eq 16 with
the paper's Table 2 coefficients, y(t) of the continuous transducer in its
periodic steady state written out here by hand (eq 25's strain harmonics
through eq 27's transfer function at each harmonic, :func:`continuous_loop`),
the sense voltage from eq 21 of the model's B(t) (dB/dt in closed form), then
noise, then y zeroed at its minimum (measured displacements are relative).
"""
import json
import math

import numpy as np
import pytest

import gmt
from gmt.sensing import induced_voltage
from smeha import cli
from smeha.identify import (Identification, LossFit, RunIdentification, fit_losses, identify,
                            identify_run, physical_flags)
from smeha.measured import Run, read_measurements, write_measurements

MU_0 = 4e-7 * math.pi
#: Paper, Table 2: K_h, n, K_e, K_ex (the values the identification must give back).
TRUE = {"K_h": 85805.0, "n": 1.8092, "K_e": 2753.39, "K_ex": 895.80}
#: 5-200 Hz (the paper identifies at 5, 50, 100 Hz; wider here) at three amplitudes.
FREQUENCIES = (5.0, 20.0, 50.0, 100.0, 200.0)
AMPLITUDES = (0.5, 0.7, 1.0)
#: Noise of the noisy data: displacement sensor, [m]; sense voltage, fraction of E_m.
NOISE_Y, NOISE_E = 0.05e-6, 0.01
#: Relative tolerances of the noisy round trip, about 5 x the standard uncertainty
#: this design gives (K_h 0.17 %, n 0.04 %, K_e 0.12 %, K_ex 1.0 %), so the 3-sigma
#: check against the reported uncertainty is the sharper one. K_ex, the smallest
#: share of the loss (paper, Figure 8), is the least determined.
REL_TOL = {"K_h": 0.01, "n": 0.002, "K_e": 0.01, "K_ex": 0.05}


def continuous_loop(params, point, theta):
    """y about the bias of the continuous transducer in steady state, by hand, [m].

    M = H_m Re(m e^{j theta}), m = (mu' - 1) - j mu'' (eq 5), so the strain of
    eq 25 about the bias is K_lambda (2 M_b M + M^2): harmonics
    L_1 = 2 K_lambda M_b H_m m and L_2 = K_lambda H_m^2 m^2 / 2; the force
    A_r E^H L_k (eq 28) drives eq 27, Y_k = A_r E^H L_k / (K - m (k w)^2 + j c k w).
    """
    kl, mb, hm = params.magnetostriction_coefficient, params.bias_magnetization, \
        point.field_amplitude
    m = complex(point.mu_real - 1.0, -point.mu_imag)
    w = 2 * math.pi * point.frequency
    gain = params.rod_area * params.youngs_modulus
    y = np.zeros_like(theta)
    for k, lam in ((1, 2 * kl * mb * hm * m), (2, kl * hm * hm * m * m / 2)):
        g = 1.0 / (params.stiffness - params.mass * (k * w) ** 2 + 1j * params.damping * k * w)
        y = y + np.real(gain * lam * g * np.exp(1j * k * theta))
    return y


def synthetic_run(params, f, im, *, rng=None, sense=True, cycles=3, per_cycle=200,
                  name=None, jitter=0.0):
    """One run: (Run, true mu'', true B_m)."""
    bm = gmt.DEFAULT_CALIBRATION.flux_density_amplitude(f, im)
    point = gmt.operating_point(params, gmt.Excitation(f, im, bm))  # mu'' from eq 16
    h = 1.0 / (f * per_cycle)
    n = int(cycles * per_cycle) + 1
    t = h * np.arange(n)
    if jitter:  # non-uniform sample times t + dt
        dt = jitter * h * np.sin(7.3 * np.arange(n))
        dt[0] = dt[-1] = 0.0
        t = t + dt
    w = 2 * math.pi * f
    phase = 0.0 if rng is None else rng.uniform(0.0, 2 * math.pi)
    theta = w * t + phase
    i = im * np.cos(theta)
    y = continuous_loop(params, point, theta)
    # B = mu_0 H_m (mu' cos + mu'' sin) (eq 17), so eq 21 in closed form
    dbdt = MU_0 * point.field_amplitude * w * (-point.mu_real * np.sin(theta)
                                               + point.mu_imag * np.cos(theta))
    e = induced_voltage(dbdt, params.sense_turns, params.sense_area)
    if rng is not None:
        em = params.sense_turns * params.sense_area * w * bm  # eq 22
        y = y + NOISE_Y * rng.standard_normal(n)
        e = e + NOISE_E * em * rng.standard_normal(n)
    y = y - y.min()
    run = Run(name or f"{f:g}Hz_{im:g}A", f, 2.0 + t, i, y, e if sense else None)
    return run, point.mu_imag, bm


def synthetic_set(seed=None, sense=True, frequencies=FREQUENCIES, amplitudes=AMPLITUDES):
    params = gmt.TransducerParameters()  # paper, Table 2
    rng = None if seed is None else np.random.default_rng(seed)
    out = [synthetic_run(params, f, im, rng=rng, sense=sense)
           for f in frequencies for im in amplitudes]
    return [o[0] for o in out], [o[1] for o in out], [o[2] for o in out]


def values(fit: LossFit):
    return dict(zip(fit.names, fit.values)), dict(zip(fit.names, fit.stderrs))


@pytest.fixture(scope="module")
def noise_free():
    runs, mu_true, b_true = synthetic_set()
    return identify(runs), mu_true, b_true


@pytest.fixture(scope="module")
def noisy():
    runs, mu_true, b_true = synthetic_set(seed=20240611)
    return identify(runs), mu_true, b_true


# -- per run ----------------------------------------------------------------------------

def test_flux_density_from_sense_voltage_matches_table_1(noise_free):
    result, _, b_true = noise_free
    by = {r.run: r for r in result.runs}
    # paper, Table 1: 5 Hz, 0.5 A -> 0.0300 T; 50 Hz, 1 A -> 0.0637 T; 100 Hz, 1 A -> 0.0531 T
    for key, bm in {"5Hz_0.5A": 0.0300, "50Hz_1A": 0.0637, "100Hz_1A": 0.0531}.items():
        r = by[key]
        assert r.flux_density_source == "sense_voltage"
        assert r.flux_density_amplitude == pytest.approx(bm, rel=1e-9)
    for r, b in zip(result.runs, b_true):
        assert r.flux_density_amplitude == pytest.approx(b, rel=1e-9)


def test_mu_imag_noise_free(noise_free):
    result, mu_true, _ = noise_free
    for r, mu in zip(result.runs, mu_true):
        assert r.mu_imag == pytest.approx(mu, rel=1e-8)
        assert not r.mu_imag_at_bound
        assert r.rms_residual < 1e-12  # [m]
        # eq 20 and eq 18 at the identified mu''
        mod = r.flux_density_amplitude / (MU_0 * r.field_amplitude)
        assert r.mu_real == pytest.approx(math.sqrt(mod ** 2 - r.mu_imag ** 2), rel=1e-12)
        assert r.lag == pytest.approx(math.atan2(r.mu_imag, r.mu_real), rel=1e-12)


def test_mu_imag_noisy_within_stderr(noisy):
    result, mu_true, b_true = noisy
    z_mu = [(r.mu_imag - mu) / r.mu_imag_stderr for r, mu in zip(result.runs, mu_true)]
    z_b = [(r.flux_density_amplitude - b) / r.flux_density_stderr
           for r, b in zip(result.runs, b_true)]
    assert max(map(abs, z_mu)) < 3.5 and max(map(abs, z_b)) < 3.5
    # the standard errors are of the right size: z scatter about 1 (15 runs: loosely)
    assert 0.4 < np.std(z_mu) < 1.8 and 0.4 < np.std(z_b) < 1.8
    for r in result.runs:
        # the residual is the displacement noise: 0.05 um
        assert r.rms_residual == pytest.approx(NOISE_Y, rel=0.15)
        assert r.samples == 401  # 3 periods of 200 samples + 1, first period discarded


def test_flux_density_from_displacement_when_no_sense_voltage():
    params = gmt.TransducerParameters()
    run, mu, bm = synthetic_run(params, 50.0, 1.0, sense=False)
    r = identify_run(run, params)
    assert r.flux_density_source == "displacement"
    # B_m = mu_0 H_m |mu| from the fundamental of y (eq 19): the model's own, exactly
    assert r.flux_density_amplitude == pytest.approx(bm, rel=1e-9)  # paper, Table 1: 0.0637 T
    assert r.mu_imag == pytest.approx(mu, rel=1e-8)
    noisy_run, mu, bm = synthetic_run(params, 50.0, 1.0, sense=False,
                                      rng=np.random.default_rng(3))
    r = identify_run(noisy_run, params)
    assert abs(r.flux_density_amplitude - bm) < 3.5 * r.flux_density_stderr
    assert abs(r.mu_imag - mu) < 3.5 * r.mu_imag_stderr


@pytest.mark.parametrize("per_cycle, jitter", [(16, 0.0), (50, 0.0), (200, 0.2), (4000, 0.0)])
def test_the_answer_does_not_depend_on_the_sampling(per_cycle, jitter):
    # the transducer is continuous, so the same measurement sampled at any rate,
    # uniformly or not, gives the same mu'' and B_m (to rounding without noise; 16 samples a
    # period still resolve the fundamental and the second harmonic that eq 30 has)
    params = gmt.TransducerParameters()
    run, mu, bm = synthetic_run(params, 50.0, 0.7, per_cycle=per_cycle, jitter=jitter)
    r = identify_run(run, params)
    assert r.flux_density_amplitude == pytest.approx(bm, rel=1e-9)
    assert r.mu_imag == pytest.approx(mu, rel=1e-8)


def test_physical_flags_of_a_meaningless_fit():
    # a fit reported as K_ex = -640 +- 1382 with a residual variance of 562 (11
    # degrees of freedom) makes no physical sense and must say so
    flags = physical_flags((85805.0, 1.81, 2753.0, -640.0), (100.0, 0.01, 10.0, 1382.0),
                           562.0, 11)
    assert any("K_ex = -640 < 0" in f for f in flags)
    assert any("not determined" in f and "K_ex" in f for f in flags)
    assert any("residual variance 562" in f for f in flags)
    # the chi^2/dof of 11 dof exceeds 2.9 with probability 1e-3: a variance of 2 is no flag
    assert physical_flags((85805.0, 1.81, 2753.0, 896.0), (100.0, 0.01, 10.0, 9.0), 2.0,
                          11) == ()


# -- loss coefficients --------------------------------------------------------------------

def test_loss_coefficients_noise_free(noise_free):
    result, _, _ = noise_free
    got, err = values(result.loss_fit)
    for name, true in TRUE.items():  # paper, Table 2
        assert got[name] == pytest.approx(true, rel=1e-6), name
    assert result.loss_fit.note == "" and result.loss_fit.flags == ()


def test_loss_coefficients_noisy(noisy):
    result, _, _ = noisy
    fit = result.loss_fit
    got, err = values(fit)
    for name, true in TRUE.items():  # paper, Table 2
        assert abs(got[name] - true) < 3.0 * err[name], (name, got[name], err[name])
        assert got[name] == pytest.approx(true, rel=REL_TOL[name]), name
        assert 0 < err[name] < REL_TOL[name] * true
    corr = np.array(fit.correlation)
    np.testing.assert_allclose(np.diag(corr), 1.0, rtol=1e-12)
    np.testing.assert_allclose(corr, corr.T, atol=1e-12)
    assert np.all(np.abs(corr) <= 1.0 + 1e-12)
    assert 0.1 < fit.residual_variance < 4.0  # chi^2/dof, 11 dof
    params = fit.parameters()
    assert params.steinmetz_exponent == got["n"]


def test_few_runs():
    runs, _, _ = synthetic_set(frequencies=(5.0, 50.0), amplitudes=(0.5, 1.0))
    four = identify(runs)
    assert four.loss_fit.stderrs is None and four.loss_fit.correlation is None
    assert "uncertainty not determined" in four.loss_fit.note
    three = identify(runs[:3])
    assert three.loss_fit is None and "not determined" in three.note
    assert fit_losses(three.runs) is None
    assert three.as_dict()["loss_coefficients"] is None


def test_result_types_are_frozen(noise_free):
    result, _, _ = noise_free
    assert isinstance(result, Identification) and isinstance(result.runs[0], RunIdentification)
    with pytest.raises(AttributeError):
        result.runs[0].mu_imag = 0.0
    d = result.as_dict()
    json.dumps(d, allow_nan=False)
    assert set(d["loss_coefficients"]) == set(TRUE)
    assert set(d["loss_coefficients"]["K_h"]) == {"value", "stderr", "unit"}


# -- command line -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def data_file(tmp_path_factory):
    runs, _, _ = synthetic_set(seed=5)
    runs[1].sense_voltage = None  # one run without a sense voltage: B_m from y
    path = tmp_path_factory.mktemp("identify") / "runs.csv"
    write_measurements(path, runs)
    return path


def test_cli_identify_table(data_file, capsys):
    status = cli.main(["identify", str(data_file)])
    out, err = capsys.readouterr()
    assert status == 0 and err == ""
    assert "5Hz_0.5A" in out and "200Hz_1A" in out
    assert "sense voltage" in out and "displacement" in out
    for name in TRUE:
        assert f"  {name} " in out
    assert "correlation" in out


def test_cli_identify_json(data_file, capsys):
    status = cli.main(["identify", str(data_file), "--json"])
    out, _ = capsys.readouterr()
    assert status == 0
    report = json.loads(out)
    assert len(report["runs"]) == len(FREQUENCIES) * len(AMPLITUDES)
    sources = [r["flux_density_source"] for r in report["runs"]]
    assert sources.count("displacement") == 1
    for key in ("run", "frequency", "current_amplitude", "flux_density_amplitude",
                "mu_imag", "mu_imag_stderr", "mu_real", "lag_deg", "rms_residual_um"):
        assert key in report["runs"][0]
    for name, true in TRUE.items():  # paper, Table 2
        entry = report["loss_coefficients"][name]
        assert abs(entry["value"] - true) < 3.0 * entry["stderr"]
    assert report["correlation"]["names"] == list(TRUE)
    # the file reads back to the same runs the CLI used
    assert len(read_measurements(data_file)) == len(report["runs"])


def test_cli_identify_bad_file_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text("run,frequency_Hz,time_s,current_A\n")
    status = cli.main(["identify", str(path), "--json"])
    out, err = capsys.readouterr()
    assert status == 2 and out == ""
    assert "bad.csv" in err and "displacement" in err and "Traceback" not in err
