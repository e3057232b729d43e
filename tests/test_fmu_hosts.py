"""The FMUs in hosts that are not fmpy-in-this-venv.

* **A C host** (``tests/fmu_c_host.c``, ours, FMI types declared from the standard) is
  compiled by the system compiler and loads each FMU's binary with
  ``dlopen(RTLD_NOW | RTLD_LOCAL)``, as C and C++ tools do, in a clean environment: no
  ``LD_PRELOAD``, no ``PYTHONPATH``, ``PATH=/usr/bin:/bin``, and the Python named by
  ``SMEHA_FMU_PYTHON`` (the FMU records no path of the machine that built it). Its outputs must equal fmpy's for the same drive, and it
  must exit with status 0, through the FMU library's destructors, every time.
* **Two interpreters in one process**: fmpy run by the system's statically linked
  ``/usr/bin/python3.11`` (when there is one): the FMU must use the host's interpreter.
* **Failing loudly**: every bad parameter makes ``fmpy.simulate_fmu`` raise and
  ``fmpy simulate`` exit non-zero naming the parameter; the C host gets Error (FMI 2.0
  and 3.0; the loader turns pythonfmu 0.7's Fatal into Error) and the reason on stderr.
* **The loader** (``fmu_src/smeha_fmu_loader.c``) finds a Python in the
  documented order: the one named by ``SMEHA_FMU_PYTHON`` (executable or prefix), the
  ``python3`` on ``PATH``; with none usable, instantiation fails, naming what was tried,
  and the host does not crash. Other machines (the build's Python hidden) are tested by
  hand with fmusim and fmuCheck (docs/FMU.md, "Run time: which Python").

The reference is fmpy in this venv's Python (tests/fmu_runner.py ``drive``), which
the other FMU tests check against gmt to the last bit.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

try:
    from fmu_fixtures import (CLEAN_ENV, HOST_ENV, child_env, fmu_dist,  # noqa: F401
                              max_relative_difference, run_runner, runner_dir)
    from fmu_runner import BAD_PARAMETERS, DRIVE_OUTPUTS
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import (CLEAN_ENV, HOST_ENV, child_env, fmu_dist,  # noqa: F401
                                    max_relative_difference, run_runner, runner_dir)
    from tests.fmu_runner import BAD_PARAMETERS, DRIVE_OUTPUTS

pytestmark = pytest.mark.integration

HOST_SOURCE = Path(__file__).resolve().with_name("fmu_c_host.c")
#: The paper's uncompensated drive, i = cos(2 pi 50 t) A, 1500 steps of 10 us.
DRIVE = ("1500", "1e-5", "50", "1", "0")
#: C host runs per FMI version: each must exit 0 (benchmarks/fmu_exit_crashes.py runs 50).
RUNS = 3
#: Status of doStep for an unusable instance (tests/test_fmu.py UNUSABLE): Error for both.
UNUSABLE = {"2": 3, "3": 3}
#: Exit status of the C host when instantiation fails (tests/fmu_c_host.c).
NOT_INSTANTIATED = 4


@pytest.fixture(scope="module")
def c_host(tmp_path_factory):
    """tests/fmu_c_host.c compiled by the system's C compiler."""
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    cc = shutil.which(cc) or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler on this machine")
    exe = tmp_path_factory.mktemp("c_host") / "fmu_c_host"
    proc = subprocess.run([cc, "-std=c11", "-D_GNU_SOURCE", "-O2", "-Wall", "-Wextra", "-Werror",
                           "-o", str(exe), str(HOST_SOURCE), "-ldl", "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


class Unzipped:
    """An FMU extracted for the C host: binary, resources, token, value references."""

    def __init__(self, fmu: Path, where: Path):
        with zipfile.ZipFile(fmu) as z:
            z.extractall(where)
        root = ET.parse(where / "modelDescription.xml").getroot()
        self.fmi = root.get("fmiVersion")[0]
        self.token = root.get("guid" if self.fmi == "2" else "instantiationToken")
        ident = root.find("CoSimulation").get("modelIdentifier")
        platform = "linux64" if self.fmi == "2" else "x86_64-linux"
        self.binary = where / "binaries" / platform / f"{ident}.so"
        self.resources = where / "resources"
        variables = (root.find("ModelVariables").findall("ScalarVariable") if self.fmi == "2"
                     else list(root.find("ModelVariables")))
        self.vr = {v.get("name"): int(v.get("valueReference")) for v in variables}
        self.kind = {v.get("name"): (v[0].tag if self.fmi == "2" else v.tag) for v in variables}

    def setting(self, name, value) -> str:
        kind = self.kind[name]
        letter = {"Real": "r", "Float64": "r", "Boolean": "b", "String": "s"}[kind]
        if letter == "b":
            value = int(bool(value))
        return f"{letter}:{self.vr[name]}={value}"

    def run(self, exe, drive=DRIVE, settings=(), env=HOST_ENV):
        args = [str(exe), self.fmi, str(self.binary), f"{self.resources}/", self.token,
                str(self.vr["u"]), *drive, *settings, "--",
                *(str(self.vr[n]) for n in DRIVE_OUTPUTS)]
        return subprocess.run(args, capture_output=True, text=True, env=env, timeout=300)


@pytest.fixture(scope="module")
def unzipped(fmu_dist, tmp_path_factory):
    cache = {}

    def get(fmi):
        if fmi not in cache:
            cache[fmi] = Unzipped(fmu_dist[fmi], tmp_path_factory.mktemp(f"unzipped{fmi}"))
        return cache[fmi]
    return get


def rows(stdout: str):
    return [[float(x) for x in line.split(",")] for line in stdout.splitlines() if line]


# -- loads anywhere, same numbers, exits cleanly ----------------------------------------------
@pytest.mark.parametrize("fmi", ["2", "3"])
def test_c_host_without_python_runs_the_fmu_as_fmpy_does(fmi, c_host, unzipped, fmu_dist,
                                                         runner_dir):
    fmu = unzipped(fmi)
    ref = run_runner("drive", runner_dir / f"drive{fmi}", fmu_dist[fmi], *DRIVE)
    assert ref["statuses"] == [0]
    codes, tables = [], []
    for _ in range(RUNS):
        proc = fmu.run(c_host)
        codes.append(proc.returncode)
        tables.append(rows(proc.stdout))
        assert "Error" not in proc.stderr and "Fatal" not in proc.stderr, proc.stderr
        # the loader took the Python SMEHA_FMU_PYTHON names, this venv's
        assert f"runs in Python {sys.version_info[0]}.{sys.version_info[1]}, " \
            f"SMEHA_FMU_PYTHON={sys.executable}" in proc.stderr, proc.stderr
    # exit status 0 every time: no crash at exit (pythonfmu's exit-time double release is
    # pre-empted, smeha_fmu_runtime.arm_clean_exit)
    assert codes == [0] * RUNS, codes
    # the same arithmetic on the same doubles: fmpy's numbers exactly (1e-12 relative
    # allowed, as between the FMU and gmt in tests/test_fmu.py)
    for table in tables:
        assert len(table) == int(DRIVE[0])
        assert max_relative_difference(table, ref["rows"]) <= 1e-12
    current = [r[1] for r in tables[0]]
    assert max(current) == pytest.approx(1.0, abs=1e-6)  # the drive reached the FMU


def _needed(binary: Path) -> list[str]:
    out = subprocess.run(["readelf", "-d", str(binary)], capture_output=True, text=True)
    if out.returncode != 0:
        pytest.skip("readelf is not installed")
    return [line.split("[")[-1].rstrip("]") for line in out.stdout.splitlines()
            if "(NEEDED)" in line]


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_the_binary_is_the_loader_and_needs_no_libpython(fmi, unzipped):
    # docs/FMU.md, "Run time": the host opens the loader; pythonfmu's binary lies beside it;
    # neither names a libpython (the loader finds one at run time)
    fmu = unzipped(fmi)
    target = fmu.binary.with_name(fmu.binary.stem + ".pythonfmu.so")
    assert target.is_file()
    for binary in (fmu.binary, target):
        assert not [n for n in _needed(binary) if n.startswith("libpython")], binary


@pytest.mark.parametrize("how", ["executable", "prefix"])
def test_the_loader_takes_the_python_named_by_smeha_fmu_python(how, c_host, fmu_dist, tmp_path,
                                                               runner_dir):
    fmu = Unzipped(fmu_dist["2"], tmp_path)
    named = sys.executable if how == "executable" else sys.prefix  # the venv: bin/python3
    proc = fmu.run(c_host, env=dict(CLEAN_ENV, SMEHA_FMU_PYTHON=named))
    assert proc.returncode == 0, proc.stderr
    exe = named if how == "executable" else f"{sys.prefix}/bin/python3"
    version = f"{sys.version_info[0]}.{sys.version_info[1]}"
    assert f"runs in Python {version}, SMEHA_FMU_PYTHON={exe}" in proc.stderr, proc.stderr
    ref = run_runner("drive", runner_dir / "drive2", fmu_dist["2"], *DRIVE)
    assert max_relative_difference(rows(proc.stdout), ref["rows"]) <= 1e-12


def test_the_loader_takes_python3_on_path(c_host, fmu_dist, tmp_path):
    # no setting: the first python3 on PATH, this venv's
    fmu = Unzipped(fmu_dist["2"], tmp_path)
    venv_bin = Path(sys.prefix) / "bin"
    if not (venv_bin / "python3").is_file():
        pytest.skip(f"no python3 in {venv_bin}")
    proc = fmu.run(c_host, env=dict(CLEAN_ENV, PATH=f"{venv_bin}:/usr/bin:/bin"))
    assert proc.returncode == 0, proc.stderr
    assert f"python3 on PATH: {venv_bin}/python3" in proc.stderr, proc.stderr


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_no_usable_python_fails_instantiation_naming_what_was_tried(fmi, c_host, fmu_dist,
                                                                     tmp_path):
    # a package no Python has: every candidate is refused; instantiation returns NULL with one
    # message (logged whatever loggingOn says) and the host exits normally, no crash
    fmu = Unzipped(fmu_dist[fmi], tmp_path)
    record = fmu.resources / "smeha_fmu_environment.txt"
    record.write_text(record.read_text() + "required\tsmeha_absent_package\n")
    proc = fmu.run(c_host)
    assert proc.returncode == NOT_INSTANTIATED, proc.stderr
    assert "no usable Python" in proc.stderr and "smeha_absent_package" in proc.stderr
    assert "python3 on PATH" in proc.stderr  # each step of the search is named
    # this venv's Python has numpy: only the absent package is missing there (another
    # Python the search reaches, e.g. Debian's libpython3.11 without python3-numpy, may
    # lack numpy too, and is named so)
    version = f"{sys.version_info[0]}.{sys.version_info[1]}"
    assert (f"SMEHA_FMU_PYTHON={sys.executable}: Python {version}, without "
            "smeha_absent_package") in proc.stderr, proc.stderr
    # with nothing named, the search says so
    proc = fmu.run(c_host, env=CLEAN_ENV)
    assert "SMEHA_FMU_PYTHON not set" in proc.stderr, proc.stderr
    assert "set SMEHA_FMU_PYTHON to a python3 executable" in proc.stderr
    assert rows(proc.stdout) == []


def test_two_interpreters_in_one_process(fmu_dist, runner_dir, tmp_path):
    # fmpy in the system's statically linked Python 3.11 (numpy and fmpy from this venv's
    # site-packages): the FMU must run in the host's interpreter, whose C API its executable
    # exports, and give the same numbers
    system = Path("/usr/bin/python3.11")
    if not system.is_file() or Path(sys.executable).resolve() == system.resolve():
        pytest.skip("no second Python 3.11 at /usr/bin/python3.11")
    probe = subprocess.run([str(system), "-c", "import sysconfig; "
                            "print(sysconfig.get_config_var('Py_ENABLE_SHARED'))"],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip("/usr/bin/python3.11 does not run")
    site = sysconfig.get_path("purelib")
    env = dict(CLEAN_ENV, PYTHONPATH=site, PYTHONDONTWRITEBYTECODE="1")
    out = tmp_path / "drive.json"
    proc = subprocess.run([str(system), str(Path(__file__).with_name("fmu_runner.py")),
                           "drive", str(out), str(fmu_dist["2"]), *DRIVE], env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    import json

    got = json.loads(out.read_text())
    ref = run_runner("drive", runner_dir / "drive2", fmu_dist["2"], *DRIVE)
    assert got["python"] != ref["python"]  # two interpreters: the host's ran the FMU
    assert got["statuses"] == [0]
    assert max_relative_difference(got["rows"], ref["rows"]) <= 1e-12


# -- knows its design point (gmt's side in tests/test_design_point.py) --------
@pytest.mark.parametrize("fmi", ["2", "3"])
def test_fmu_flags_a_drive_off_its_design_point_and_warns_once(fmi, fmu_dist, runner_dir):
    # frequency left at 50 Hz, driven at 100 Hz (4000 steps, 40 ms)
    res = run_runner("drive", runner_dir / f"design{fmi}", fmu_dist[fmi],
                     "4000", "1e-5", "100", "1", "0")
    assert res["statuses"] == [0]
    flags = res["outside_design_point"]
    # judged at the drive's first full period (upward crossings at 7.5 and 17.5 ms)
    assert not any(flags[:1740]) and all(flags[1760:])
    warnings = [m for s, _, m in res["logs"] if s == 1 and "design point" in m]
    assert len(warnings) == 1 and "100 Hz" in warnings[0] and "50 Hz" in warnings[0]
    assert res["operating_point"][-1] == [50.0, 1.0]


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_time_domain_magnetics_in_the_c_host_and_fmpy_flag_nothing(fmi, c_host, unzipped,
                                                                   fmu_dist, runner_dir):
    # magnetics = "time_domain": the drive that the paper's model flags above (100 Hz against
    # the 50 Hz parameters), here with a 0.5 A DC offset, is inside the model: the flag stays
    # down in fmpy, and the C host (no Python on its PATH) gives fmpy's numbers
    drive = ("4000", "1e-5", "100", "1", "0.5")
    ref = run_runner("drive", runner_dir / f"td{fmi}", fmu_dist[fmi], *drive,
                     "magnetics=time_domain")
    assert ref["statuses"] == [0] and not any(ref["outside_design_point"])
    fmu = unzipped(fmi)
    proc = fmu.run(c_host, drive=drive, settings=[fmu.setting("magnetics", "time_domain")])
    assert proc.returncode == 0, proc.stderr
    table = rows(proc.stdout)
    assert len(table) == 4000 and max_relative_difference(table, ref["rows"]) <= 1e-12


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_fmu_flags_a_drive_at_rest_from_the_first_step(fmi, fmu_dist, runner_dir):
    # u = 0 from the start gives B = 0.027 T, M = 21 kA/m, F = 1.7 kN at zero
    # field with the flag down for half a period; now flagged after the first doStep (0 A is
    # not the peak at which the model's drive I_m cos(w t) starts, gmt.design_point), with a
    # warning through the FMU's logger, and as standing still from the second
    one = run_runner("drive", runner_dir / f"rest1_{fmi}", fmu_dist[fmi], "1", "1e-5", "50",
                     "0", "0")
    assert one["statuses"] == [0] and one["outside_design_point"] == [True]
    warnings = [m for s, _, m in one["logs"] if s == 1 and "design point" in m]
    assert len(warnings) == 1 and "first sample, 0 A" in warnings[0]
    res = run_runner("drive", runner_dir / f"rest{fmi}", fmu_dist[fmi], "200", "1e-5", "50",
                     "0", "0")
    assert res["statuses"] == [0] and all(res["outside_design_point"])
    warnings = [m for s, _, m in res["logs"] if s == 1 and "design point" in m]
    assert len(warnings) == 2 and "stands still" in warnings[1]


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_the_papers_drive_is_not_flagged_at_the_first_step(fmi, fmu_dist, runner_dir):
    # u = cos(2 pi 50 t): its first sample is the peak I_m, where the model's drive starts
    one = run_runner("drive", runner_dir / f"peak1_{fmi}", fmu_dist[fmi], "1", "1e-5", "50",
                     "1", "0")
    assert one["statuses"] == [0] and one["outside_design_point"] == [False]
    assert not [m for s, _, m in one["logs"] if "design point" in m]


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_c_host_is_warned_of_a_drive_at_rest_at_the_first_step(fmi, c_host, unzipped):
    # the same in the C host (loggingOn, the FMU's logger to stderr): one doStep with u = 0
    # warns of the first sample; one with u = cos(2 pi 50 t) does not
    fmu = unzipped(fmi)
    rest = fmu.run(c_host, drive=("1", "1e-5", "50", "0", "0"))
    peak = fmu.run(c_host, drive=("1", "1e-5", "50", "1", "0"))
    assert rest.returncode == 0 and peak.returncode == 0, rest.stderr + peak.stderr
    assert "[Warning]" in rest.stderr and "first sample, 0 A" in rest.stderr, rest.stderr
    assert "design point" not in peak.stderr, peak.stderr


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_fmu_follows_the_drive_with_follow_drive(fmi, fmu_dist, runner_dir):
    res = run_runner("drive", runner_dir / f"follow{fmi}", fmu_dist[fmi],
                     "4000", "1e-5", "100", "1", "0", "follow_drive=1")
    assert res["statuses"] == [0] and not any(res["outside_design_point"])
    f, i_m = res["operating_point"][-1]
    assert f == pytest.approx(100.0, rel=1e-6) and i_m == pytest.approx(1.0, rel=1e-6)
    y = [row[2] for row in res["rows"][3000:]]  # the last 10 ms: one 100 Hz period
    # the model at 100 Hz: 36.0 um peak to peak (tests/test_design_point.py
    # checks it against the closed-form steady state)
    assert max(y) - min(y) == pytest.approx(36.0e-6, rel=5e-3)


# -- fails loudly -----------------------------------------------------------------------------
@pytest.mark.parametrize("fmi", ["2", "3"])
def test_c_host_gets_a_failing_status_and_the_reason_for_a_bad_parameter(fmi, c_host, unzipped):
    fmu = unzipped(fmi)
    proc = fmu.run(c_host, settings=[fmu.setting("frequency", 0.0)])
    assert proc.returncode == UNUSABLE[fmi], proc.stderr
    assert "frequency = 0 Hz is outside the allowed range" in proc.stderr
    assert rows(proc.stdout) == []


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_every_bad_parameter_makes_simulate_fmu_raise_naming_it(fmi, fmu_dist, runner_dir):
    res = run_runner("simulate_bad", runner_dir / f"simulate_bad{fmi}", fmu_dist[fmi])
    named = {case: n for case, (_, n) in BAD_PARAMETERS.items()}
    with zipfile.ZipFile(fmu_dist[fmi]) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    reals = {v.get("name") for v in root.iter() if v.get("causality") == "parameter"
             and (v.tag == "Float64" or v.find("Real") is not None)}
    from smeha.fmu.build import iface

    assert reals == {v.name for v in iface.VARIABLES
                     if v.causality == "parameter" and v.kind == "Real"}
    assert {f"{n}_nan" for n in reals} <= set(res)  # each one NaN
    for case, r in res.items():
        parameter = named.get(case, case.removesuffix("_nan"))
        assert r["raised"] is not None, case
        assert "FMICallException" in r["raised"], (case, r["raised"])
        # fmpy runs the FMU without logging: the reason reaches stderr all the same
        assert parameter in r["stderr"] and "refused" in r["stderr"], (case, r["stderr"])


@pytest.mark.parametrize("fmi", ["2", "3"])
@pytest.mark.parametrize("name,value", [("frequency", "0"), ("model_variant", "maxwell")])
def test_fmpy_simulate_exits_non_zero_naming_the_parameter(fmi, name, value, fmu_dist):
    # the command line as docs/FMU.md shows it
    proc = subprocess.run([str(Path(sys.executable).with_name("fmpy")), "simulate",
                           str(fmu_dist[fmi]), "--start-values", name, value],
                          capture_output=True, text=True, env=child_env(), timeout=300)
    assert proc.returncode != 0
    assert f"{name} = " in proc.stderr and "refused" in proc.stderr, proc.stderr
