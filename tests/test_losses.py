"""The core-loss study on real rows (MagNet v1's copy in data/magnet/) and its CSV format."""
import json
import math

import numpy as np
import pytest
from scipy.integrate import quad

from smeha.cli import main
from smeha.coreloss import measurements, study
from smeha.coreloss.models import SteinmetzLaw, fit_steinmetz


@pytest.fixture(scope="module")
def n87():
    return measurements.read_magnet("N87")


def test_igse_matches_closed_form_for_triangles(n87):
    # reference: Venkatachalam et al. 2002, iGSE for a triangle rising for D of the
    # period, written out: P = k_i (2B)^beta f^alpha (D^(1-alpha) + (1-D)^(1-alpha)),
    # with k_i from the integral of |cos|^alpha by quadrature (no Gamma function);
    # tolerance: quadrature and floating point only
    law = fit_steinmetz(n87)
    k, a, b = law.k, law.alpha, law.beta
    cos_integral = quad(lambda t: abs(math.cos(t)) ** a, 0.0, 2.0 * math.pi, limit=200)[0]
    k_i = k / ((2.0 * math.pi) ** (a - 1.0) * cos_integral * 2.0 ** (b - a))
    tri = n87.family("triangle")
    f, bm, d = n87.frequency[tri], n87.flux_density[tri], n87.duty[tri, 0]
    closed = k_i * (2.0 * bm) ** b * f ** a * (d ** (1.0 - a) + (1.0 - d) ** (1.0 - a))
    np.testing.assert_allclose(law.predict(n87)[tri], closed, rtol=1e-9)


def test_igse_of_sampled_sine_is_steinmetz(tmp_path):
    # iGSE reproduces Steinmetz's k f^alpha B^beta on a sinusoid (its defining property);
    # 400 samples: the chord error of |dB/dt|^alpha is below 1e-4
    law = SteinmetzLaw(2.75, 1.47, 2.62)
    b = 0.1 * np.sin(2.0 * np.pi * (np.arange(400) + 0.25) / 400)
    path = tmp_path / "sine.csv"
    path.write_text("frequency_Hz,loss_W_m3,flux_samples_T\n"
                    f"100000,1.0,{' '.join(f'{v:.12g}' for v in b)}\n")
    data = measurements.read_core_losses(path)
    expected = 2.75 * 1e5 ** 1.47 * (0.5 * (b.max() - b.min())) ** 2.62
    assert law.predict(data)[0] == pytest.approx(expected, rel=1e-4)


def test_trapezoid_slopes_follow_magnet_voltages(n87):
    # MagNet's trapezoid: dB/dt proportional to the winding voltage, (1 - d_P + d_N) on
    # the rise, -(d_P - d_N) on the flat parts, -(1 + d_P - d_N) on the fall
    trap = np.flatnonzero(n87.family("trapezoid"))[::500]
    for k in trap:
        d_p, d_n = n87.duty[k, 0], n87.duty[k, 2]
        rate = n87.swings[k] / n87.durations[k]
        volts = np.array([1 - d_p + d_n, -(d_p - d_n), -(1 + d_p - d_n), -(d_p - d_n)])
        np.testing.assert_allclose(rate * volts[2], rate[2] * volts, rtol=1e-9, atol=1e-6)
        assert max(abs(n87.swings[k, 0]), abs(n87.swings[k, 2])) == pytest.approx(
            2.0 * n87.flux_density[k])


def test_calibration_rule(n87):
    cal = study.calibration_mask(n87)
    sine = n87.family("sine")
    assert np.all(cal[sine])
    assert (cal & ~sine).sum() <= study.CALIBRATION_SHARE * (~sine).sum()
    assert set(np.unique(n87.duty[cal & n87.family("triangle"), 0])) == {0.5}


def test_bad_rows_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("frequency_Hz,flux_density_T,duty_1,duty_2,duty_3,duty_4,loss_W_m3\n"
                    "1e5,0.1,-1,-1,-1,-1,100\n1e5,0.1,0.5,0.1,0.5,0.1,100\n")
    with pytest.raises(measurements.DataError, match="data row 2"):
        measurements.read_core_losses(path)
    path.write_text("frequency_Hz,loss_W_m3,flux_samples_T\n1e5,1,0 1 0 1 0 -1\n")
    with pytest.raises(measurements.DataError, match="one maximum"):
        measurements.read_core_losses(path)
    path.write_text("frequency_Hz,flux_density_T\n1e5,0.1\n")
    with pytest.raises(measurements.DataError, match="loss_W_m3 is missing"):
        measurements.read_core_losses(path)


def test_losses_json_shape(capsys):
    # 3F4, the smallest table: the JSON the bar reads, and the extension ahead of iGSE
    assert main(["losses", "3F4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    entry = out["materials"]["3F4"]
    assert set(entry) == {"sine", "triangle", "trapezoid", "igse"}
    assert set(entry["igse"]) == {"triangle", "trapezoid"}
    for s in (entry["triangle"], entry["trapezoid"], entry["igse"]["triangle"]):
        assert set(s) == {"rows", "median_abs_error", "p95_abs_error"}
    assert entry["triangle"]["rows"] == 4236  # |outlier factor| < 5 %, as MagNet's copy keeps
    assert entry["triangle"]["p95_abs_error"] < entry["igse"]["triangle"]["p95_abs_error"]


def test_losses_refuses_unknown_material(capsys):
    assert main(["losses", "N99"]) == 2
    err = capsys.readouterr().err
    assert "N99" in err and len(err.strip().splitlines()) == 1
    assert main(["losses", "3F4", "--json", "--holdout"]) == 2


@pytest.fixture(scope="module")
def n87_result(n87):
    return study.run(n87)


def test_igse_figures_agree_with_an_independent_computation(n87_result):
    # reference: iGSE computed outside this code on the same rows (Steinmetz fitted on the
    # sinusoids, |outlier factor| < 5 %), quoted in the project's tracker with one decimal:
    # N87 triangles 17.8 / 57.5 % (median / 95th percentile of |error|)
    s = n87_result.scores("igse")["triangle"]
    assert 100 * s["median_abs_error"] == pytest.approx(17.8, abs=0.05)
    assert 100 * s["p95_abs_error"] == pytest.approx(57.5, abs=0.05)


def test_plot_refused_without_duty_waveforms(tmp_path, capsys):
    path = tmp_path / "sines.csv"
    path.write_text("frequency_Hz,flux_density_T,duty_1,duty_2,duty_3,duty_4,loss_W_m3\n"
                    "1e5,0.1,-1,-1,-1,-1,100\n2e5,0.1,-1,-1,-1,-1,250\n")
    assert main(["losses", str(path), "--plot", str(tmp_path / "m.png")]) == 2
    assert "--plot" in capsys.readouterr().err


def test_calibration_rule_thins_to_its_share(n87):
    # a table where the named duty settings are most of the non-sinusoidal rows: the rule
    # keeps every k-th of them, at most CALIBRATION_SHARE of those rows
    keep = n87.family("sine") | (n87.family("triangle") & (n87.duty[:, 0] >= 0.4)
                                 & (n87.duty[:, 0] <= 0.6))
    data = n87.subset(keep)
    cal = study.calibration_mask(data)
    other = ~data.family("sine")
    assert 0 < (cal & other).sum() <= study.CALIBRATION_SHARE * other.sum()
    assert set(np.unique(data.duty[cal & other, 0])) == {0.5}


def test_a_plot_of_another_format_is_refused_before_the_work(capsys, tmp_path):
    # matplotlib decides the format by the suffix; a .txt plot was a ValueError traceback
    # after the whole study had run
    from smeha import cli

    assert cli.main(["losses", "3F4", "--plot", str(tmp_path / "maps.txt")]) == 2
    err = capsys.readouterr().err
    assert "--plot" in err and "'.txt'" in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())


def test_extended_law_follows_the_rise_of_loss_with_flux_density(n87_result):
    # reference: N87's measured triangles at 40-90 kHz (MagNet rows). With one exponent per
    # stop density the law's median signed error was -14 % at 30-60 mT and +16 % above 200 mT
    # (a 30-point slope, the same at every frequency); the break of the exponent
    # (steinmetz_break, steinmetz_exponent_high) lets it follow. Bound 8 points: the fitted
    # law leaves 2-3, and the cells' medians move by a point or two between fits
    r, d = n87_result, n87_result.data
    err = r.predicted_extended / d.loss - 1.0
    low_f = d.family("triangle") & (d.frequency < 90e3)
    small = np.median(err[low_f & (d.flux_density >= 0.03) & (d.flux_density < 0.06)])
    large = np.median(err[low_f & (d.flux_density >= 0.2)])
    assert abs(large - small) < 0.08
    assert 0.02 < r.extended.steinmetz_break < 0.1  # within MagNet's flux densities
