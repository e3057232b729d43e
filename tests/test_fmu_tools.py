"""The FMUs in the FMI community's own hosts: fmusim, the FMU Compliance Checker, OMSimulator.

fmusim (modelica/Reference-FMUs) and fmuCheck (modelica-tools/FMUComplianceChecker) are not
Python packages: a machine that has built them names them in ``FMUSIM`` / ``FMUCHECK`` or
puts them on ``PATH`` (``fmusim``, ``fmuCheck.linux64`` or ``fmuCheck``); where neither is
found, the tests are skipped. docs/FMU.md ("Run time: which Python") says how they were
built and what they gave on other machines.

Each host runs in a clean environment (``env -i PATH=/usr/bin:/bin``) that names the Python
the FMU runs in (``SMEHA_FMU_PYTHON``, this venv's) on the paper's 50 Hz drive, and its
outputs must be fmpy's (tests/fmu_runner.py ``drive``): fmusim's to the last printed digit
(16 significant digits: 1e-12 relative bounds the printing, not the model), fmuCheck's to
its clock's rounding (see the test). fmuCheck also checks the EHA system's FMUs: the drive's,
the plant's and fmpy's container FMU of the three.
"""
from __future__ import annotations

import math
import os
import shutil
import subprocess

import numpy as np
import pytest

try:
    from fmu_fixtures import HOST_ENV, fmu_dist, run_runner, runner_dir  # noqa: F401
    from test_system_fmu import system_dist  # noqa: F401  (fixture)
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import HOST_ENV, fmu_dist, run_runner, runner_dir  # noqa: F401
    from tests.test_system_fmu import system_dist  # noqa: F401

pytestmark = pytest.mark.integration

#: The drive of tests/test_fmu_hosts.py: u = cos(2 pi 50 t), 1500 steps of 10 us.
STEPS, H, FREQUENCY = 1500, 1e-5, 50.0
OUTPUTS = ("current", "displacement", "velocity", "flux_density", "force")


def _built(request, *names):
    """The fixtures ``names`` (the FMUs and what is run from them), set up only once the test
    has found its tool: a test skipped for a missing tool builds nothing."""
    return [request.getfixturevalue(name) for name in names]


def _tool(variable: str, *names: str) -> str:
    found = os.environ.get(variable) or next(filter(None, map(shutil.which, names)), None)
    if not found or not os.access(found, os.X_OK):
        pytest.skip(f"{names[0]} is not installed (set {variable} or put it on PATH)")
    return found


@pytest.fixture(scope="module")
def drive_csv(tmp_path_factory):
    """The drive as fmusim and fmuCheck read it: "time","u", t = k h, u written with repr."""
    path = tmp_path_factory.mktemp("drive") / "drive.csv"
    lines = ['"time","u"']
    for k in range(STEPS + 2):
        t = k * H
        lines.append(f"{t!r},{math.cos(2.0 * math.pi * FREQUENCY * t)!r}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def reference(fmu_dist, runner_dir):
    def get(fmi):
        res = run_runner("drive", runner_dir / f"tools{fmi}", fmu_dist[fmi],
                         str(STEPS), repr(H), repr(FREQUENCY), "1", "0")
        assert res["statuses"] == [0]
        return np.array(res["rows"])
    return get


def _table(path, names=OUTPUTS):
    """Columns ``time`` and ``names`` of a host's CSV output, as an array."""
    header = path.read_text().splitlines()[0].replace('"', "").split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return data[:, [header.index(n) for n in ("time", *names)]]


def _close(got, ref, rtol=1e-12):
    scale = np.maximum(np.abs(got), np.abs(ref)).max(axis=0)
    return np.max(np.abs(got - ref) / np.where(scale > 0, scale, 1.0))


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_fmusim_runs_the_fmu_as_fmpy_does(fmi, request, tmp_path):
    fmusim = _tool("FMUSIM", "fmusim")
    fmu_dist, drive_csv, reference = _built(request, "fmu_dist", "drive_csv", "reference")
    out = tmp_path / "out.csv"
    # one step beyond: fmusim's clock accumulates h and may stop a step short of k h
    cmd = [fmusim, "--interface-type", "cs", "--input-file", str(drive_csv), "--stop-time",
           repr((STEPS + 1) * H), "--output-interval", repr(H), "--output-file", str(out)]
    for name in OUTPUTS:
        cmd += ["--output-variable", name]
    proc = subprocess.run([*cmd, str(fmu_dist[fmi])], capture_output=True, text=True,
                          env=HOST_ENV, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "[Error]" not in proc.stdout + proc.stderr
    got = _table(out)[1:STEPS + 1]  # the row at t = 0 is before the first step
    ref = reference(fmi)
    assert got.shape == ref.shape
    assert _close(got, ref) <= 1e-12


def test_fmucheck_finds_no_problem_and_runs_the_fmu_as_fmpy_does(request, tmp_path):
    fmucheck = _tool("FMUCHECK", "fmuCheck.linux64", "fmuCheck")
    fmu_dist, drive_csv, reference = _built(request, "fmu_dist", "drive_csv", "reference")
    out = tmp_path / "out.csv"
    proc = subprocess.run([fmucheck, "-k", "cs", "-h", repr(H), "-s", repr(STEPS * H), "-n",
                           "0", "-i", str(drive_csv), "-o", str(out), str(fmu_dist["2"])],
                          capture_output=True, text=True, env=HOST_ENV, timeout=300)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text
    assert "\t0 Warning(s)\n\t0 Error(s)" in text and "0 warning(s) and error(s)" in text, text
    got = _table(out)
    ref = reference("2")
    # the checker's clock adds h at each step (its t at step 1586 is 0.015859999999999524),
    # so the inputs it interpolates at those times differ from u(k h) in the last digits,
    # which the hysteresis branch points magnify: measured 7.1e-9 relative (force), against
    # 1e-15 for fmusim, whose clock gives k h; 1e-7 bounds that, not the model
    rows = min(len(got) - 1, len(ref))
    assert rows >= STEPS - 1
    assert _close(got[1:rows + 1, 1:], ref[:rows, 1:]) <= 1e-7



#: What the checker says, at its last step, of an FMU that declares
#: canHandleVariableCommunicationStepSize="false" (fmi2_cs_sim.c: it keeps the step and runs
#: past the stop time): the container FMU declares so because it steps its units at the
#: system's 10 us and refuses a step that is not a whole number of them
FIXED_STEP_NOTICE = ("[WARNING][FMUCHK] FMU does not support variable communication stepsize. "
                     "Stepsize may not be altered to reach stopTime exactly.")


@pytest.mark.parametrize("name", ["SmehaDrive", "SmehaPlant", "SmehaEha"])
def test_fmucheck_finds_no_problem_in_the_systems_fmus(name, request, tmp_path):
    # the drive's and the plant's FMUs, and the three as one (fmpy's container FMU), at the
    # start values for 0.02 s in steps of 0.1 ms; the container's transducer, at 100 Hz
    # compensated, reports its design-point warning, which must reach the checker's log as
    # the FMU wrote it (the container formats it once before passing it on as a format)
    fmucheck = _tool("FMUCHECK", "fmuCheck.linux64", "fmuCheck")
    (system_dist,) = _built(request, "system_dist")
    proc = subprocess.run([fmucheck, "-k", "cs", "-l", "3", "-h", "1e-4", "-s", "0.02", "-o",
                           str(tmp_path / "out.csv"), str(system_dist[0] / f"{name}.fmu")],
                          capture_output=True, text=True, env=HOST_ENV, timeout=300)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, text
    assert "\t0 Error(s)" in text and "[ERROR]" not in text and "[FATAL]" not in text, text
    notices = [line for line in text.splitlines() if line.startswith("[WARNING]")]
    assert set(notices) <= ({FIXED_STEP_NOTICE} if name == "SmehaEha" else set()), text
    assert f"\t{len(notices)} Warning(s)" in text, text
    for line in text.splitlines():
        if "[FMU]" in line and "tolerances" in line:
            assert "(tolerances 5 percent in frequency, 1 percent in amplitude)" in line, line


# -- OpenModelica's OMSimulator ---------------------------------------------------------------
#: OMSimulator's run of a lone FMU: 500 steps of 10 us from the start values (its command line
#: sets no inputs: u = 0, the DC drive the design point flags, which moves the rod by the
#: quadrature term of eq 31 alone)
OMS_STEPS, OMS_H = 500, 1e-5


def _omsimulator() -> str:
    from smeha.fmu import systemrun

    exe = systemrun.omsimulator()
    if exe is None:
        pytest.skip(f"OMSimulator is not installed (set {systemrun.OMSIMULATOR_VARIABLE} to "
                    "its executable or put it on PATH; docs/FMU.md names its sources)")
    return exe


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_omsimulator_runs_the_fmu_as_fmpy_does(fmi, request, tmp_path):
    from smeha.fmu.systemrun import omsimulator_errors

    exe = _omsimulator()
    fmu_dist, runner_dir = _built(request, "fmu_dist", "runner_dir")
    out = tmp_path / "oms.csv"
    proc = subprocess.run([exe, str(fmu_dist[fmi]), f"--stopTime={OMS_STEPS * OMS_H!r}",
                           f"--stepSize={OMS_H!r}", f"--intervals={OMS_STEPS}",
                           "--emitEvents=false",
                           f"--resultFile={out}", f"--tempDir={tmp_path}"], cwd=tmp_path,
                          capture_output=True, text=True, env=HOST_ENV, timeout=300)
    log = proc.stdout + proc.stderr
    # OMSimulator exits 0 even when its log holds errors: the log is read
    assert proc.returncode == 0 and not omsimulator_errors(log), log
    table = _table(out)
    # a row per communication point, the last of the rows OMSimulator writes at a time
    # (it writes the final point twice); the row at t = 0 is before the first step
    last = {t: row for t, row in zip(table[:, 0], table)}
    got = np.array([last[t] for t in sorted(last)])[1:]
    res = run_runner("drive", runner_dir / f"oms{fmi}", fmu_dist[fmi], str(OMS_STEPS),
                     repr(OMS_H), repr(FREQUENCY), "0", "0")
    ref = np.array(res["rows"])
    assert got.shape == ref.shape
    # the same arithmetic on the same doubles; 1e-9 bounds OMSimulator's printing and clock
    # (its times are accumulated), not the model
    assert _close(got, ref) <= 1e-9
