"""``smeha build --cross-check DIR``: the FMI Cross-Check's files, validated by others' code.

The layout and files follow the FMI Cross-Check rules (modelica/fmi-cross-check); fmpy
implements their checks: ``fmpy.cross_check.validate_vendor_repo.validate_test_fmu`` (the
FMU's version and type against its folder, ``_ref.opt``'s fields, the CSVs' names and time
column) and ``fmpy.util.validate_result`` (the share of a result's samples outside a band
around the reference: 0 passes). The reference is gmt's own simulation
(:mod:`smeha.fmu.crosscheck`); fmpy and, where installed, fmusim simulate the FMU from the
files alone and must fall inside the band, and equal the reference to the printing's
rounding (1e-12 relative, as in tests/test_fmu_tools.py). The Compliance Checker, where
installed, must find no problem in the FMI 2.0 FMU (it cannot check FMI 3.0).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

try:
    from fmu_fixtures import child_env, fmu_dist  # noqa: F401
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import child_env, fmu_dist  # noqa: F401

from smeha import cli
from smeha.fmu import crosscheck

pytestmark = pytest.mark.integration

#: A clean environment naming the Python the FMU runs in (tests/fmu_fixtures.py HOST_ENV)
CLEAN_ENV = {"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "SMEHA_FMU_PYTHON": sys.executable}

#: A child runs the FMU in fmpy from the cross-check files alone and validates the result.
_FMPY = """
import json, sys
import numpy as np
from fmpy import simulate_fmu
from fmpy.util import read_csv, read_ref_opt_file, validate_result
folder, name, result = sys.argv[1:4]
opt = read_ref_opt_file(f"{folder}/{name}_ref.opt")
ref = read_csv(f"{folder}/{name}_ref.csv")
res = simulate_fmu(f"{folder}/{name}.fmu", start_time=opt["StartTime"],
                   stop_time=opt["StopTime"], output_interval=opt["StepSize"],
                   input=read_csv(f"{folder}/{name}_in.csv"), output=list(ref.dtype.names[1:]))
json.dump({"outliers": float(validate_result(res, ref, stop_time=opt["StopTime"])),
           "rows": [list(map(float, r)) for r in res]}, open(result, "w"))
"""


@pytest.fixture(scope="module")
def xc(fmu_dist, tmp_path_factory):
    root = tmp_path_factory.mktemp("xc")
    folders = crosscheck.write(root, [fmu_dist["2"], fmu_dist["3"]])
    return {folder.name: folder for folder in folders}


def test_the_layout_is_the_cross_checks(xc):
    from smeha import __version__

    assert set(xc) == {"SmehaGmt", "SmehaGmt3"}
    assert xc["SmehaGmt"].parts[-7:] == ("fmus", "2.0", "cs", "linux64", "smeha", __version__,
                                         "SmehaGmt")
    assert xc["SmehaGmt3"].parts[-7:-1] == ("fmus", "3.0", "cs", "x86_64-linux", "smeha",
                                            __version__)
    for name, folder in xc.items():
        assert sorted(p.name for p in folder.iterdir()) == sorted(
            [f"{name}.fmu", f"{name}_in.csv", f"{name}_ref.csv", f"{name}_ref.opt", "README.md"])


@pytest.mark.parametrize("name", ["SmehaGmt", "SmehaGmt3"])
def test_fmpys_cross_check_validator_finds_no_problem(name, xc):
    from fmpy.cross_check.validate_vendor_repo import validate_test_fmu

    assert validate_test_fmu(str(xc[name])) == []


@pytest.mark.parametrize("name", ["SmehaGmt", "SmehaGmt3"])
def test_fmpy_simulates_the_reference(name, xc, tmp_path):
    out = tmp_path / "result.json"
    proc = subprocess.run([sys.executable, "-c", _FMPY, str(xc[name]), name, str(out)],
                          cwd=tmp_path, env=child_env(), capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(out.read_text())
    assert got["outliers"] == 0.0
    ref = [[float(x) for x in line.split(",")]
           for line in (xc[name] / f"{name}_ref.csv").read_text().splitlines()[1:]]
    assert len(got["rows"]) == len(ref)
    # relative to each signal's largest value (a value near a zero crossing carries the
    # rounding of the whole signal)
    scale = [max(abs(row[j]) for row in ref) for j in range(len(ref[0]))]
    worst = max(abs(a - b) / (s or 1.0) for row, expected in zip(got["rows"], ref)
                for a, b, s in zip(row, expected, scale))
    assert worst <= 1e-12


@pytest.mark.parametrize("name", ["SmehaGmt", "SmehaGmt3"])
def test_fmusim_simulates_the_reference(name, xc, tmp_path):
    fmusim = os.environ.get("FMUSIM") or shutil.which("fmusim")
    if not fmusim:
        pytest.skip("fmusim is not installed (set FMUSIM or put it on PATH)")
    from fmpy.util import read_csv, read_ref_opt_file, validate_result

    folder = xc[name]
    opt = read_ref_opt_file(str(folder / f"{name}_ref.opt"))
    ref = read_csv(str(folder / f"{name}_ref.csv"))
    out = tmp_path / "out.csv"
    cmd = [fmusim, "--interface-type", "cs", "--input-file", str(folder / f"{name}_in.csv"),
           "--stop-time", repr(opt["StopTime"]), "--output-interval", repr(opt["StepSize"]),
           "--output-file", str(out)]
    for output in ref.dtype.names[1:]:
        cmd += ["--output-variable", output]
    proc = subprocess.run([*cmd, str(folder / f"{name}.fmu")], capture_output=True, text=True,
                          env=CLEAN_ENV, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert validate_result(read_csv(str(out)), ref) == 0.0


def test_the_compliance_checker_finds_no_problem(xc, tmp_path):
    fmucheck = (os.environ.get("FMUCHECK") or shutil.which("fmuCheck.linux64")
                or shutil.which("fmuCheck"))
    if not fmucheck:
        pytest.skip("fmuCheck is not installed (set FMUCHECK or put it on PATH)")
    folder = xc["SmehaGmt"]
    proc = subprocess.run([fmucheck, "-k", "cs", "-l", "3", "-h", "1e-05", "-s", "0.02", "-n",
                           "0", "-i", str(folder / "SmehaGmt_in.csv"), "-o",
                           str(tmp_path / "cc.csv"), str(folder / "SmehaGmt.fmu")],
                          capture_output=True, text=True, env=CLEAN_ENV, timeout=300)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text
    assert "\t0 Warning(s)\n\t0 Error(s)" in text and "0 warning(s) and error(s)" in text, text


def test_smeha_build_cross_check_writes_what_it_built(fmu_dist, tmp_path, monkeypatch, capsys):
    # the command line: --cross-check DIR takes the FMUs this build wrote
    from smeha.fmu import build

    def fake_build_all(fmi, out, validate):
        for key in ("2", "3") if fmi == "both" else (fmi,):
            shutil.copyfile(fmu_dist[key], out / fmu_dist[key].name)
        return 0

    monkeypatch.setattr(build, "build_all", fake_build_all)
    out, xc_dir = tmp_path / "dist", tmp_path / "xc"
    assert cli.main(["build", "--fmi", "both", "--out", str(out), "--cross-check",
                     str(xc_dir)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("FMI Cross-Check files:") == 2
    assert (xc_dir / "fmus" / "2.0" / "cs" / "linux64").is_dir()
    assert (xc_dir / "fmus" / "3.0" / "cs" / "x86_64-linux").is_dir()
