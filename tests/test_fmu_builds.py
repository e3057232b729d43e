"""FMUs of different builds in one process: the later one refuses, the earlier keeps running.

pythonfmu FMUs share their host's Python and its ``sys.modules``: an FMU instantiated
after one of another build would import the modules the first one loaded (same names)
and run that build's code without a word. Each FMU records its build identifier
(``smeha.fmu.build.build_id``) and refuses, at instantiation, to run beside modules of
another build (``smeha_fmu_runtime.refuse_other_build``). Another build is made here by
rewriting the identifier in a copy of the session's FMUs: the check reads nothing else.
FMUs of one build (SmehaGmt and SmehaGmt3 of one ``build_fmu.py`` run) still load and run
side by side, and give the same outputs (same code, same drive).
"""
from __future__ import annotations

import math
import zipfile

import pytest

from fmu_fixtures import fmu_dist, run_runner, runner_dir  # noqa: F401  (fixtures)

pytestmark = pytest.mark.integration

RECORD = "resources/smeha_fmu_environment.txt"
OTHER = "000000000000"


def _build(fmu) -> str:
    with zipfile.ZipFile(fmu) as z:
        lines = z.read(RECORD).decode().splitlines()
    return next((line.split("\t", 1)[1] for line in lines if line.startswith("build\t")), "")


def _other_build(fmu, dest):
    """A copy of ``fmu`` whose record names the build :data:`OTHER`."""
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            if info.filename == RECORD:
                kept = [line for line in data.decode().splitlines()
                        if not line.startswith("build\t")]
                data = "\n".join([*kept, f"build\t{OTHER}", ""]).encode()
            zout.writestr(info, data)
    return dest


def test_another_build_refused_first_keeps_running(fmu_dist, runner_dir, tmp_path):
    a2, a3 = fmu_dist["2"], fmu_dist["3"]
    b2 = _other_build(a2, tmp_path / "SmehaGmt.fmu")
    b3 = _other_build(a3, tmp_path / "SmehaGmt3.fmu")
    # the later builds find the slave modules of A2 and A3 imported (one name per model)
    res = run_runner("builds", runner_dir / "builds", a2, a3, b3, b2)
    first, same3, other3, other2 = res["runs"]
    assert first["instantiated"] and same3["instantiated"]
    # one build: the same code, the same outputs (bit-identical; gmt computes both)
    assert same3["rows"] == first["rows"]
    ours = _build(a2)
    assert len(ours) == 12 and ours == _build(a3)
    for refused, model in ((other3, "SmehaGmt3"), (other2, "SmehaGmt")):
        assert not refused["instantiated"], f"{model} of build {OTHER} ran beside build {ours}"
        problems = [m for m in refused["logs"] if m[0] >= 3]  # Error or Fatal
        assert len(problems) == 1, refused["logs"]
        status, category, text = problems[0]
        assert status == 3 and category == "logStatusError"  # Error: nothing is corrupted
        assert f"build {OTHER}" in text and f"build {ours}" in text, text
        assert "smeha build --system" in text and "separate process" in text, text
        assert "Traceback" not in text and "PyObject_Call" not in text, text
        assert text.startswith(f"{model} (build {OTHER})"), text
    # the first FMU steps on, continuing its trajectory
    again = res["first_again"]
    assert len(again) == 10 and all(math.isfinite(y) for y in again)
    assert again[0] != first["rows"][-1]
