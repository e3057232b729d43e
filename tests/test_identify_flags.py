"""`smeha identify` flags every unphysical value it reports.

The ranges are the paper's: the loss per cycle pi f mu_0 mu'' H_m^2 of eqs 13-14 is
never negative; mu' of eq 20 is real and, for the magnetisation (mu' - 1) H of eq 25
to follow the field, at least 1 (vacuum's); the lag of eq 18 lies in [0, 90] deg;
B_m and H_m (eqs 1, 19) are amplitudes; n lies inside [1, 3] (3: the Rayleigh law
of eq 6) and eq 16's predicted loss is never negative.
"""
from __future__ import annotations

import dataclasses
import json
import math

import pytest

import gmt
from gmt.constants import MU_0
from smeha import cli
from smeha.identify import format_identification, identify
from smeha.identify.flags import loss_law_flags, run_flags
from smeha.identify.losses import _loss_terms
from smeha.measured import write_measurements
from smeha.synthetic import generate_runs

#: Paper, Table 2: K_h, n, K_e, K_ex.
TABLE_2 = (85805.0, 1.8092, 2753.39, 895.80)
#: A short design: 4 frequencies x 2 amplitudes, 4 cycles (the project's own generator).
DESIGN = {"frequencies": (5, 50, 100, 200), "amplitudes": (0.5, 1.0), "cycles": 4, "seed": 1}


@pytest.fixture(scope="module")
def clean():
    return identify(generate_runs(None, **DESIGN))


@pytest.fixture(scope="module")
def shielded():
    # eddy-current diffusion across the rod (smeha.synthetic's slab truth, strength 1)
    # shields the rod at 200 Hz: the sense coil sees a B_m too low for H_m
    return identify(generate_runs("eddy_current_diffusion", strength=1.0, **DESIGN))


def test_clean_runs_raise_no_flag(clean):
    assert clean.flags == () and clean.physical
    assert all(r.flags == () for r in clean.runs)
    d = clean.as_dict()
    assert d["physical"] is True and d["flags"] == []
    assert all(r["flags"] == [] and r["physical"] for r in d["runs"])
    text = format_identification(clean)
    assert "(!)" not in text and "no physical sense" not in text


def test_eddy_shielding_gives_mu_real_below_one_and_is_flagged(shielded):
    # a shielded rod's case: mu' = 0.70 at 200 Hz. mu' from eq 20 of the reported B_m, H_m, mu''
    by = {r.run: r for r in shielded.runs}
    for name in ("f200_I0.5", "f200_I1.0"):
        r = by[name]
        mod = r.flux_density_amplitude / (MU_0 * r.field_amplitude)  # eq 19
        assert r.mu_real == pytest.approx(math.sqrt(mod ** 2 - r.mu_imag ** 2), rel=1e-12)
        assert r.mu_real < 1.0
        (flag,) = r.flags
        assert flag.startswith(f"mu' = {r.mu_real:.4g} < 1 (eq 20)")
    assert by["f200_I0.5"].mu_real == pytest.approx(0.70, abs=0.01)
    # below 200 Hz the shielding leaves mu' above 1: no flag
    assert all(r.flags == () for r in shielded.runs if r.frequency < 200)
    d = shielded.as_dict()
    assert d["physical"] is False
    flagged = {r["run"]: r["flags"] for r in d["runs"] if r["flags"]}
    assert set(flagged) == {"f200_I0.5", "f200_I1.0"}
    assert any(f.startswith("f200_I0.5: mu' = 0.698") for f in d["flags"])
    text = format_identification(shielded)
    assert "(!) values that make no physical sense:" in text
    assert "  - f200_I1.0: mu' = 0.7411 < 1 (eq 20)" in text
    rows = [line for line in text.splitlines() if line.startswith("f200_")]
    assert len(rows) == 2 and all(line.endswith("(!)") for line in rows)


def _provoke(run, **changes):
    return run_flags(dataclasses.replace(run, **changes))


def test_each_unphysical_run_value_raises_its_flag(clean):
    r = clean.runs[2]  # 50 Hz, 0.5 A: mu' = 1.98, mu'' = 0.63
    assert run_flags(r) == ()
    # mu'' < 0: a negative loss per cycle (eqs 13-14); its lag atan(mu''/mu') < 0 too
    flags = _provoke(r, mu_imag=-0.1, lag=math.atan2(-0.1, r.mu_real))
    assert len(flags) == 2
    assert flags[0].startswith("mu'' = -0.1 < 0") and "eqs 13-14" in flags[0]
    assert flags[1].startswith("lag = -2.89") and "outside [0, 90] deg" in flags[1]
    # mu' not real: mu'' above |mu| = B_m / (mu_0 H_m) (eqs 19, 20)
    (flag,) = _provoke(r, mu_imag=10.0, mu_real=math.nan, lag=math.pi / 2)
    assert flag.startswith("mu' is not real: mu'' = 10 exceeds |mu|")
    # mu' < 1: a shielded rod's case
    (flag,) = _provoke(r, mu_real=0.7, lag=math.atan2(r.mu_imag, 0.7))
    assert flag.startswith("mu' = 0.7 < 1 (eq 20)")
    # a lag past a quarter period
    (flag,) = _provoke(r, lag=math.radians(95.0))
    assert flag.startswith("lag = 95 deg is outside [0, 90] deg")
    # amplitudes that are not positive
    flags = _provoke(r, flux_density_amplitude=0.0, mu_real=0.0, lag=math.pi / 2)
    assert flags[0].startswith("B_m = 0 T is not positive")
    assert any(f.startswith("mu' = 0 < 1") for f in flags)
    (flag,) = _provoke(r, field_amplitude=-1.0)
    assert flag.startswith("H_m = -1 A/m is not positive")


def test_each_unphysical_loss_law_raises_its_flag(clean):
    runs = clean.runs
    volume = gmt.TransducerParameters().rod_volume

    def flags(values):
        return loss_law_flags(values, runs, volume, _loss_terms)

    assert flags(TABLE_2) == ()
    kh, n, ke, kex = TABLE_2
    # n on the bound of [1, 3], or beyond it
    (flag,) = flags((kh, 3.0, ke, kex))
    assert flag.startswith("n = 3 is on the bound of its physical range [1, 3]")
    (flag,) = flags((kh, 0.8, ke, kex))
    assert flag.startswith("n = 0.8 is outside its physical range [1, 3]")
    # a loss law whose total is negative at some runs: K_e far below zero makes eq 16
    # negative at high B_m f, while K_h keeps the low-frequency runs positive
    (flag,) = flags((kh, n, -20 * ke, kex))
    assert flag.startswith("eq 16 with these coefficients gives a negative loss per cycle at")
    assert "'f200_I1.0'" in flag


def test_cli_identify_json_and_text_carry_the_flags(tmp_path, capsys):
    path = tmp_path / "runs.csv"
    write_measurements(path, generate_runs("eddy_current_diffusion", strength=1.0, **DESIGN))
    assert cli.main(["identify", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["physical"] is False
    assert [r["run"] for r in d["runs"] if r["flags"]] == ["f200_I0.5", "f200_I1.0"]
    assert cli.main(["identify", str(path)]) == 0
    assert "(!) values that make no physical sense:" in capsys.readouterr().out
