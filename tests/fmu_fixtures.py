"""Session fixtures of the FMU tests (imported by tests/test_fmu*.py).

How the FMU is kept away from the repository's gmt
--------------------------------------------------------
A pythonfmu FMU runs in its host's interpreter and imports ``gmt`` by name; if
the host has already imported the repository's ``gmt`` (the pytest process
has: ``conftest.py`` and the doctests import it), the FMU silently runs that
copy instead of the one it bundles. So:

* the FMUs are built **once per pytest run, in a child process** (``build_fmu.py``,
  which itself runs pythonfmu's builder in a further child);
* every FMU is stepped **in another child** (``tests/fmu_runner.py``) that never
  imports gmt; it records that ``gmt`` was absent before the FMU loaded and
  which file the FMU's gmt came from (the test checks it is the bundled copy);
* the gmt reference trajectories are computed in a third child that imports
  the repository's gmt and loads no FMU.

The pytest process only compares the JSON the children write.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: A clean environment: nothing that points a process at a Python.
CLEAN_ENV = {"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8"}
#: A clean environment that names the Python the FMUs run in, as a user of a C host does
#: (this venv's; an FMU records no path of the machine that built it).
HOST_ENV = dict(CLEAN_ENV, SMEHA_FMU_PYTHON=sys.executable)
RUNNER = Path(__file__).resolve().with_name("fmu_runner.py")


def child_env() -> dict:
    """Environment of the children: no PYTHONPATH leaking the source tree in."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def build_fmus(out: Path, fmi: str = "both") -> subprocess.CompletedProcess:
    """``python build_fmu.py --fmi <fmi> --out <out>`` in a child process."""
    return subprocess.run([sys.executable, str(REPO / "build_fmu.py"), "--fmi", fmi,
                           "--out", str(out)], cwd=REPO, env=child_env(),
                          capture_output=True, text=True, timeout=600)


def run_runner(command: str, workdir: Path, *args, timeout=600) -> dict:
    """Run ``fmu_runner.py COMMAND OUT ARGS`` in a child (cwd outside the repo); return its JSON."""
    workdir.mkdir(parents=True, exist_ok=True)
    out = workdir / f"{command}-{abs(hash(args)) % 10**8}.json"
    proc = subprocess.run([sys.executable, str(RUNNER), command, str(out),
                           *map(str, args)], cwd=workdir, env=child_env(),
                          capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0 or not out.is_file():
        pytest.fail(f"fmu_runner {command} failed with exit status {proc.returncode}"
                    f" (negative: killed by that signal)\n{proc.stdout}\n{proc.stderr}")
    return json.loads(out.read_text())


#: Results shared by every test module of the pytest run. The test modules import
#: these fixtures, and pytest makes one fixture definition per importing module,
#: so a session fixture alone would build (and run) once per module.
_SESSION: dict = {}


def _once(key, compute):
    if key not in _SESSION:
        _SESSION[key] = compute()
    return _SESSION[key]


@pytest.fixture(scope="session")
def fmu_dist(tmp_path_factory):
    """Both FMUs, built once: {"2": SmehaGmt.fmu, "3": SmehaGmt3.fmu, "dir": ..., "log": ...}."""
    def build():
        out = tmp_path_factory.mktemp("dist")
        proc = build_fmus(out)
        if proc.returncode != 0:
            pytest.fail(f"build_fmu.py failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
        return {"2": out / "SmehaGmt.fmu", "3": out / "SmehaGmt3.fmu", "dir": out,
                "log": proc.stdout}
    return _once("dist", build)


@pytest.fixture(scope="session")
def runner_dir(tmp_path_factory):
    return _once("runner_dir", lambda: tmp_path_factory.mktemp("fmu_runner"))


@pytest.fixture(scope="session")
def reference(runner_dir):
    """gmt.Transducer trajectories of every case (repository gmt, separate process)."""
    return _once("reference", lambda: run_runner("reference", runner_dir / "reference"))


@pytest.fixture(scope="session")
def behaviour(fmu_dist, runner_dir):
    """Per FMI version: trajectories, instances, reset and state results (lazy)."""
    def get(fmi):
        return _once(("behaviour", fmi), lambda: run_runner(
            "behaviour", runner_dir / f"behaviour{fmi}", fmu_dist[fmi]))
    return get


@pytest.fixture(scope="session")
def bad_input(fmu_dist, runner_dir):
    """Per FMI version: statuses and log messages of every bad input (lazy)."""
    def get(fmi):
        return _once(("bad_input", fmi), lambda: run_runner(
            "bad_input", runner_dir / f"bad{fmi}", fmu_dist[fmi]))
    return get


def max_relative_difference(a, b) -> float:
    """max |a - b| / max(|a|, |b|) over two equal-shape tables (0 where equal)."""
    import numpy as np

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, (a.shape, b.shape)
    scale = np.maximum(np.abs(a), np.abs(b))
    diff = np.abs(a - b)
    rel = np.where(diff == 0.0, 0.0, diff / np.where(scale == 0.0, 1.0, scale))
    return float(rel.max()) if rel.size else 0.0
