"""smeha installed from its wheel, as a user of a package index would.

``pip wheel`` builds the wheel from this source tree; it is installed into a fresh venv in
a temporary folder outside the clone, and every command runs from a folder of its own
there. The venv borrows the installed dependencies of this environment through a ``.pth``
file (installing numpy, scipy, numba, Dask ... again would take minutes and test pip);
this environment's own smeha is an editable install, whose import hook lives in a ``.pth``
file of its site-packages that Python does not read from a borrowed folder, so only the
wheel's smeha, gmt and system_models are importable (the test checks where they come from).

Then: ``smeha build`` writes the FMUs into the installation's per-user cache folder
(``$XDG_CACHE_HOME/smeha/<version>-<key>/``, the test's own cache) and says so; fmpy runs
the FMU built there and it reproduces the 50 Hz drive; ``smeha flow`` at one frequency,
from another folder, runs the flow study through that FMU without building it again;
``--out`` still overrides.
"""
from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[1]

_CHECK_FMU = """
import sys
import numpy as np
from fmpy import simulate_fmu
t = np.arange(0.0, 0.01 + 1e-6, 1e-5)
inputs = np.array(list(zip(t, np.cos(2 * np.pi * 50 * t), 0 * t)),
                  dtype=[("time", float), ("u", float), ("external_force", float)])
res = simulate_fmu(sys.argv[1], input=inputs, stop_time=0.01, output_interval=1e-5,
                   output=["current", "displacement"])
print("max current", max(res["current"]), "stroke", np.ptp(res["displacement"]))
"""


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv python, a working folder outside the clone) with the wheel installed."""
    where = tmp_path_factory.mktemp("wheel")
    if str(where.resolve()).startswith(str(ROOT)):
        pytest.skip("the temporary folder is inside the clone")
    wheels = where / "wheels"
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env["XDG_CACHE_HOME"] = str(where / "cache")  # the per-user cache the FMUs go into
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w",
                           str(wheels), str(ROOT)], capture_output=True, text=True, env=env,
                          cwd=where, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (wheel,) = wheels.glob("smeha-*.whl")
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; "
                           "print(sysconfig.get_path('purelib'))"], capture_output=True,
                          text=True, check=True).stdout.strip()
    # the dependencies of this environment, borrowed (see the module docstring)
    Path(site, "borrowed_dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    proc = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install",
                           "--no-deps", "-q", str(wheel)], capture_output=True, text=True,
                          env=env, cwd=where, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    work = where / "work"
    work.mkdir()
    return python, work, env


def where_cache(installed) -> Path:
    return Path(installed[2]["XDG_CACHE_HOME"])


def _dist(installed) -> Path:
    """The installation's FMU folder, as the installed smeha names it."""
    proc = _run(installed, "-c", "from smeha.fmu import build; print(build.DIST)")
    assert proc.returncode == 0, proc.stderr
    return Path(proc.stdout.strip())


def _run(installed, *args, timeout=900):
    python, work, env = installed
    return subprocess.run([str(python), *args], capture_output=True, text=True, cwd=work,
                          env=env, timeout=timeout)


def test_the_wheel_holds_the_fmu_sources_and_imports_from_itself(installed):
    python, work, _ = installed
    proc = _run(installed, "-c", "import smeha, gmt, system_models; from smeha.fmu import build; "
                "print(smeha.__file__); print(gmt.__file__); print(system_models.__file__); "
                "print(build.IN_SOURCE_TREE, build.FMU_SRC, build.DIST)")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    venv = str(python.parent.parent)
    assert all(line.startswith(venv) for line in lines[:3]), lines  # the wheel's, not ours
    in_tree, sources, dist = lines[3].split()
    assert in_tree == "False"
    assert (Path(sources) / "smeha_fmu_interface.py").is_file()
    assert (Path(sources) / "smeha_fmu_loader.c").is_file()
    # built once per installation into the per-user cache, found from any folder
    assert Path(dist).parent == where_cache(installed) / "smeha"
    from smeha import __version__
    assert Path(dist).name.startswith(f"{__version__}-")


def test_smeha_build_and_flow_work_from_the_wheel(installed):
    python, work, _ = installed
    smeha = python.parent / "smeha"
    proc = subprocess.run([str(smeha), "build"], capture_output=True, text=True, cwd=work,
                          env=installed[2], timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    fmu = _dist(installed) / "SmehaGmt.fmu"
    assert f"FMI 2.0 co-simulation FMU: {fmu}, validated: no problems found" in proc.stdout
    check = _run(installed, "-c", _CHECK_FMU, str(fmu))
    assert check.returncode == 0, check.stderr
    words = check.stdout.split()
    assert float(words[2]) == pytest.approx(1.0, abs=1e-6)  # the drive reached the FMU
    # the stroke over the half period is gmt's (this tree's gmt, the same drive; the FMU
    # equals gmt to 1e-12 in tests/test_fmu.py; fmpy prints 16 digits)
    from smeha.fmu import crosscheck
    y = [row[2] for row in crosscheck.reference() if row[0] <= 0.01 + 1e-9]
    assert float(words[4]) == pytest.approx(max(y) - min(y), rel=1e-9)
    # from another folder: the same FMU, not built again; no dist/ anywhere
    elsewhere = work.parent / "elsewhere"
    elsewhere.mkdir()
    built = fmu.stat().st_mtime_ns
    flow = subprocess.run([str(smeha), "flow", "--frequencies", "100"], capture_output=True,
                          text=True, cwd=elsewhere, env=installed[2], timeout=900)
    assert flow.returncode == 0, flow.stdout + flow.stderr
    assert "100" in flow.stdout and "Errno" not in flow.stdout + flow.stderr
    assert fmu.stat().st_mtime_ns == built
    assert not (work / "dist").exists() and not (elsewhere / "dist").exists()
    # --out still overrides
    out = subprocess.run([str(smeha), "build", "--out", str(elsewhere / "mine")],
                         capture_output=True, text=True, cwd=work, env=installed[2], timeout=900)
    assert out.returncode == 0 and (elsewhere / "mine" / "SmehaGmt.fmu").is_file(), out.stderr
