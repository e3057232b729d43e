"""FMUs of different builds in one process each run their own build's code.

pythonfmu FMUs share their host's Python and its ``sys.modules``: pythonfmu imports each
FMU's slave module by name, and the slave imports the rest by name, so with names common
to every build an FMU instantiated after one of another build would run the first one's
modules without a word. The build bundles every module under ``<name>_<build id>``
(``smeha.fmu.build.bundled_names``). Here a second build is made from a copy of the
source tree whose transducer slave doubles the ``displacement`` output (an exact factor):
its FMU loaded between two FMUs of the session's build must read twice theirs, bit for bit,
and theirs must be unchanged (SmehaGmt3 loaded after it still runs the session's code).
"""
from __future__ import annotations

import math
import shutil
import subprocess
import sys
import zipfile

import pytest

from fmu_fixtures import REPO, child_env, fmu_dist, run_runner, runner_dir  # noqa: F401

pytestmark = pytest.mark.integration

RECORD = "resources/smeha_fmu_environment.txt"


def _build(fmu) -> str:
    with zipfile.ZipFile(fmu) as z:
        lines = z.read(RECORD).decode().splitlines()
    return next((line.split("\t", 1)[1] for line in lines if line.startswith("build\t")), "")


def _other_build(tmp_path):
    """SmehaGmt.fmu built from a copy of the tree whose slave doubles ``displacement``."""
    tree = tmp_path / "tree"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for part in ("smeha", "fmu_src", "system_models"):
        shutil.copytree(REPO / part, tree / part, ignore=ignore)
    shutil.copy2(REPO / "build_fmu.py", tree)
    slave = tree / "fmu_src" / "smeha_fmu_slave.py"
    text = slave.read_text()
    assert text.count("reals = (out.current, out.displacement,") == 1
    slave.write_text(text.replace("reals = (out.current, out.displacement,",
                                  "reals = (out.current, 2.0 * out.displacement,"))
    out = tmp_path / "dist"
    proc = subprocess.run([sys.executable, str(tree / "build_fmu.py"), "--fmi", "2", "--out",
                           str(out)], cwd=tree, env=child_env(), capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out / "SmehaGmt.fmu"


def test_each_build_runs_its_own_code(fmu_dist, runner_dir, tmp_path):
    a2, a3 = fmu_dist["2"], fmu_dist["3"]
    b2 = _other_build(tmp_path)
    res = run_runner("builds", runner_dir / "builds", a2, b2, a3)
    first, other, same = res["runs"]
    assert all(run["instantiated"] for run in res["runs"]), res["runs"]
    assert [m for run in res["runs"] for m in run["logs"] if m[0] >= 3] == []
    # the other build's FMU ran its own slave, not the one SmehaGmt of the first build loaded
    assert other["rows"] == [2.0 * y for y in first["rows"]]
    # one build: the same code, the same outputs (bit-identical), also after the other build
    assert same["rows"] == first["rows"]
    assert len(_build(a2)) == 12 and _build(a2) == _build(a3) != _build(b2)
    # the first FMU steps on, continuing its own trajectory (0.1 ms into 20 ms periods)
    again = res["first_again"]
    assert len(again) == 10 and all(math.isfinite(y) for y in again)
    assert again[0] != first["rows"][-1]
