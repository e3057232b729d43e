"""The EHA as an FMI system: three FMUs, one SSP package, four masters.

``smeha build --system`` builds the plant FMU (``system_models``' plant: the pump chamber
with the rod's eq 27, the valves and their controller, the cylinder, the accumulator) and
the drive FMU (the control signal); :mod:`smeha.fmu.ssp` connects them to the transducer FMU
in an SSP 1.0 package and an OSP system structure, and packs the three as one FMU (fmpy's
container FMU). Each is run in its master -- fmpy's ``simulate_ssp``, libcosim (a C++
master), fmpy's ``simulate_fmu`` for the container -- and checked against:

* **the project's co-simulation harness** (``smeha.studies.flow.run_case``: the transducer
  FMU stepped ahead, the plant integrated over windows, a valve controller that knows u
  ahead), its cylinder flow by the flow check of eqs 39-41, at 50 and 100 Hz in both
  modes, within 1 %. The harness runs the same plant *physics* in-process;
  what the comparison checks is everything the FMI system adds and could get wrong:
  the FMUs as packaged (bundled copies under other names, numba's shipped cache), every
  circuit parameter through the SSV/OSP files and the plant's variable table, the rod's
  mechanics taken from the transducer FMU, the valve controller that sees u only at
  each step, the masters' held outputs and one-step-late transfers (Jacobi), the force
  extrapolation, the drive signal. A mismatch of one step between the force and the
  valve timing alone costs 0.9 % at 100 Hz uncompensated (docs/FMU.md).
* **an independent reference**: in the ideal limit of eqs 40/41 (``--circuit ideal``:
  the chamber pressure does not load the rod) the pumped flow is f A_d dy with dy the
  *free* transducer's stroke between the valve switches (paper, eqs 39-41), computed
  from the transducer alone with no hydraulics (``smeha.studies.flow.free_dy``: eq 30's
  periodic solution uncompensated, the transducer stepped alone compensated). Within 1 %
  (the tolerance of that limit's own test).

Runs are short (4 pumping cycles: the flow check discards 2 and averages the next whole
one), the same in the harness and the systems, so they share the start-up; the flows of
4- and 8-cycle runs differ by at most 0.06 % (docs/FMU.md), and system and harness agree
to 0.03 % at both lengths. Each run is a child process (tests/system_runner.py).
"""
from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

try:
    from fmu_fixtures import HOST_ENV, child_env, run_runner
    from test_fmu_hosts import Unzipped, c_host  # noqa: F401  (fixture)
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import HOST_ENV, child_env, run_runner
    from tests.test_fmu_hosts import Unzipped, c_host  # noqa: F401

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[1]
RUNNER = Path(__file__).resolve().with_name("system_runner.py")
#: The harness's cases: (frequency [Hz], mode).
CASES = [(50.0, "uncompensated"), (50.0, "compensated"), (100.0, "uncompensated"),
         (100.0, "compensated")]
#: Pumping cycles simulated (system_models.flowcheck.MINIMUM_CYCLES: 2 discarded, then a
#: whole one averaged).
CYCLES = 4
#: Tolerance on the flow against the harness, and in the ideal limit.
TOLERANCE = 0.01
#: Pump piston area A_d, [m^2] (paper, Table 2).
PISTON_AREA = 1256e-6

_SESSION: dict = {}


def _once(key, compute):
    if key not in _SESSION:
        _SESSION[key] = compute()
    return _SESSION[key]


def _run(command, workdir: Path, *args, timeout=900) -> dict:
    workdir.mkdir(parents=True, exist_ok=True)
    out = workdir / f"{command}-{abs(hash(args)) % 10**8}.json"
    proc = subprocess.run([sys.executable, str(RUNNER), command, str(out), *map(str, args)],
                          cwd=workdir, env=child_env(), capture_output=True, text=True,
                          timeout=timeout)
    if proc.returncode != 0 or not out.is_file():
        pytest.fail(f"system_runner {command} failed ({proc.returncode}):\n{proc.stdout}\n"
                    f"{proc.stderr}")
    return json.loads(out.read_text())


def _key(f, mode) -> str:
    return f"{f:g}:{mode}"


@pytest.fixture(scope="session")
def system_dist(tmp_path_factory):
    """``build_fmu.py --system`` (= ``smeha build --system``): the FMUs and the default system."""
    def build():
        out = tmp_path_factory.mktemp("system_dist")
        proc = subprocess.run([sys.executable, str(REPO / "build_fmu.py"), "--system", "--out",
                               str(out)], cwd=REPO, env=child_env(), capture_output=True,
                              text=True, timeout=900)
        if proc.returncode != 0:
            pytest.fail(f"build_fmu.py --system failed ({proc.returncode}):\n{proc.stdout}\n"
                        f"{proc.stderr}")
        return out, proc.stdout
    return _once("dist", build)


@pytest.fixture(scope="session")
def systems(system_dist, tmp_path_factory):
    """The .ssp and OSP files of every case, realistic and ideal circuits."""
    def write():
        folder = tmp_path_factory.mktemp("systems")
        dist = system_dist[0]
        realistic = _run("write", folder, dist, folder, "realistic", CYCLES,
                         *(_key(f, m) for f, m in CASES))
        ideal = _run("write", folder, dist, folder, "ideal", CYCLES,
                     *(_key(100.0, m) for m in ("uncompensated", "compensated")))
        return {"realistic": realistic, "ideal": ideal, "folder": folder}
    return _once("systems", write)


@pytest.fixture(scope="session")
def harness(system_dist, tmp_path_factory):
    """The harness's flow check of every case (one child, the transducer FMU)."""
    return _once("harness", lambda: _run(
        "harness", tmp_path_factory.mktemp("harness"), system_dist[0] / "SmehaGmt.fmu",
        "realistic", CYCLES, *(_key(f, m) for f, m in CASES)))


def _host_run(host, circuit, f, mode, systems):
    entry = systems[circuit][_key(f, mode)]
    path = {"fmpy": entry["ssp"], "libcosim": entry["osp"], "container": entry["container"]}[host]
    return _once((host, circuit, f, mode), lambda: _run(
        host, systems["folder"] / f"{host}_{circuit}_{f:g}_{mode}", path, f))


# -- the cylinder flow against the harness --------------------------------------------------
@pytest.mark.parametrize("host", ["fmpy", "libcosim", "container"])
@pytest.mark.parametrize("f,mode", CASES)
def test_system_gives_the_harness_flow(host, f, mode, systems, harness):
    if host == "libcosim":
        pytest.importorskip("libcosimpy")
    run = _host_run(host, "realistic", f, mode, systems)
    reference = harness[_key(f, mode)]
    # the whole experiment ran: DefaultExperiment / EndTime at the system's 10 us step
    assert run["steps"] == round(CYCLES / f / 1e-5)
    assert run["cycles"] == reference["cycles"] >= 1
    assert run["flow"] > 0.0
    assert abs(run["flow"] / reference["flow"] - 1.0) < TOLERANCE, (run, reference)


def test_libcosim_runs_the_plant_with_the_transducer_fmus_mechanics(systems):
    pytest.importorskip("libcosimpy")
    run = _host_run("libcosim", "realistic", 100.0, "compensated", systems)
    transducer, plant = run["units"]["transducer"], run["units"]["plant"]
    for name in ("equivalent_mass", "equivalent_damping", "equivalent_stiffness",
                 "output_mass", "joint_stiffness", "joint_damping"):
        assert plant[name] == transducer[name], name
    # paper, Table 2: m = 0.02 kg, c = 2945 N s/m, K = 1.963e7 N/m
    assert (plant["equivalent_mass"], plant["equivalent_damping"],
            plant["equivalent_stiffness"]) == (0.02, 2945.0, 1.963e7)


# -- the container's start ------------------------------------------------------------------------
#: Stop time of the container's start-up run, [s]: two periods at 100 Hz, long enough for the
#: transducer's design-point monitor to judge the current (a five-sample oscillation at the
#: start is flagged within 10 ms).
START_RUN = 0.02


def test_the_container_starts_the_transducer_at_the_drives_initial_output(system_dist,
                                                                          tmp_path):
    # reference: the transducer FMU alone in fmpy (tests/fmu_runner.py "drive"), driven by
    # the drive's law u = offset + amplitude cos(2 pi f t) at t = k h from the first step,
    # with the container's parameters; the container must give its transducer the same u:
    # the drive's u(t0) at the first step (its output in Initialization Mode), not 0
    dist = system_dist[0]
    got = _run("container_log", tmp_path / "container", dist / "SmehaEha.fmu", START_RUN)
    p, h = got["parameters"], got["step"]
    steps = round(START_RUN / h)
    settings = [f"{name.split('.', 1)[1]}={value}" for name, value in p.items()
                if name.startswith("transducer.")]
    alone = run_runner("drive", tmp_path / "alone", dist / "SmehaGmt.fmu", steps, repr(h),
                       p["drive.frequency"], p["drive.amplitude"], p["drive.offset"], *settings)
    assert alone["statuses"] == [0]
    current = np.array(got["current"][1:steps + 1])  # the row at t = 0 is before the first step
    reference = np.array(alone["rows"])[:, 1]
    # the same arithmetic on the same u: measured 5e-15 relative (the container's clock and
    # fmpy's may differ from k h in the last bits); 1e-12 bounds that, while u = 0 at the
    # first step gives currents that differ at the first digit
    assert np.max(np.abs(current - reference)) <= 1e-12 * np.max(np.abs(reference))
    # the compensator's first samples (one every compensator_period) move one way; u = 0
    # at the first step makes them alternate (-0.68, +0.68, -0.27, +1.00, -0.11 A)
    every = round(float(p["transducer.compensator_period"]) / h)
    samples = current[:5 * every:every]
    assert np.all(np.diff(samples) < 0.0) or np.all(np.diff(samples) > 0.0), samples
    # its warnings are the transducer's own, as the FMU alone gives them (at 100 Hz
    # compensated, the compensator's current amplitude off the model's I_m)
    warned = [m for _, m in got["messages"]]
    assert not any("oscillates" in m for m in warned), warned
    assert warned == [m for status, _, m in alone["logs"] if status >= 1], (warned, alone)


# -- the ideal limit of eqs 40/41: an independent reference -------------------------------------
@pytest.mark.parametrize("mode", ["uncompensated", "compensated"])
def test_ideal_limit_pumps_the_free_transducers_stroke(mode, systems, tmp_path):
    run = _host_run("fmpy", "ideal", 100.0, mode, systems)
    free = _once(("free", mode), lambda: _run("free", tmp_path, 100.0, mode, CYCLES))
    # eq 39 with dy of the free transducer (eq 40 uncompensated, eq 41 compensated)
    assert abs(run["flow"] / (100.0 * PISTON_AREA * free["dy_free"]) - 1.0) < TOLERANCE, (
        run, free)


# -- the files ----------------------------------------------------------------------------------
def test_build_writes_a_valid_ssp_and_osp(system_dist):
    from fmpy.ssp.ssd import read_ssd, read_ssv

    dist, log = system_dist
    ssp = dist / "SmehaEha.ssp"
    osp = dist / "SmehaEha" / "OspSystemStructure.xml"
    assert str(ssp) in log and str(osp) in log and str(dist / "SmehaEha.fmu") in log
    ssd = read_ssd(str(ssp))  # validated against the SSP 1.0 schema (fmpy's copy)
    assert [c.name for c in ssd.system.elements] == ["drive", "transducer", "plant"]
    with zipfile.ZipFile(ssp) as z:
        names = set(z.namelist())
    assert {"SystemStructure.ssd", "resources/SmehaGmt.fmu", "resources/SmehaPlant.fmu",
            "resources/SmehaDrive.fmu", "resources/plant.ssv"} <= names
    for comp in ("drive", "transducer", "plant"):
        read_ssv(str(ssp), resource=f"resources/{comp}.ssv")  # validated too
    with zipfile.ZipFile(ssp) as z:
        ssd_text = z.read("SystemStructure.ssd").decode()
        ssvs = {c: z.read(f"resources/{c}.ssv").decode() for c in ("drive", "transducer", "plant")}
    # OMSimulator's master annotation beside libcosim's, the same step; no String binding
    # (OMSimulator reads none; the default case's Strings are at their start values)
    assert '<ssc:Annotation type="org.openmodelica">' in ssd_text
    assert '<oms:FixedStepMaster description="oms-ma" stepSize="1e-05" />' in ssd_text
    assert 'baseStepSize="1e-05"' in ssd_text
    assert not any("ssv:String" in text for text in ssvs.values())
    # the OSP file refers to the FMUs next to it
    text = osp.read_text()
    for name in ("SmehaGmt", "SmehaPlant", "SmehaDrive"):
        assert f'source="../{name}.fmu"' in text


def test_the_plant_fmu_carries_its_physics_under_names_of_its_own(system_dist):
    with zipfile.ZipFile(system_dist[0] / "SmehaPlant.fmu") as z:
        names = set(z.namelist())
        record = z.read("resources/smeha_fmu_environment.txt").decode()
        build = record.split("build\t", 1)[1].split()[0]  # the suffix of every bundled name
        rod = z.read(f"resources/smeha_plant_system_models_{build}/rod.py").decode()
    assert f"from smeha_plant_gmt_{build}.errors import" in rod and "from gmt" not in rod
    # numba's cache of the compiled kernel, made at build time
    assert any(n.startswith(f"resources/smeha_plant_system_models_{build}/")
               and "/__pycache__/" in n
               and "._plant_run-" in n and n.endswith(".nbc") for n in names)
    assert "required\tnumpy\nrequired\tnumba\n" in record


#: Bad plant parameters and what the message must say (the FMU variable, its value, its range).
BAD_PLANT = {"v2_area=-1": "v2_area = -1 m^2 is outside",
             "equivalent_mass=0": "equivalent_mass = 0 kg is outside",
             "hydraulic_step=2": "hydraulic_step = 2.0 s is outside"}


@pytest.mark.parametrize("setting", sorted(BAD_PLANT))
def test_a_bad_plant_parameter_stops_fmpy_and_is_named(setting, system_dist, tmp_path_factory):
    # the plant fails loudly: fmpy.simulate_fmu raises (the first step is Fatal) and
    # the reason, naming the parameter and its range, reaches stderr (one child for all)
    results = _once("bad", lambda: _run("plant_bad", tmp_path_factory.mktemp("bad"),
                                        system_dist[0] / "SmehaPlant.fmu", *sorted(BAD_PLANT)))
    result = results[setting]
    assert result["error"] is not None
    assert BAD_PLANT[setting] in result["stderr"] and "refused" in result["stderr"], result


def test_a_plant_missing_a_package_names_it_at_error_level_without_debug_logging(
        system_dist, tmp_path):
    # a Python host that lacks a package the plant needs (as Python 3.13 with fmpy and numpy
    # only lacks numba): fmpy.simulate_fmu, debug logging off, must fail and its default
    # logger print the package at Error level; the FMU's record gains a package no Python has
    src = system_dist[0] / "SmehaPlant.fmu"
    fmu = tmp_path / "SmehaPlant.fmu"
    record = "resources/smeha_fmu_environment.txt"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(fmu, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == record:
                data += b"required\tsmeha_absent_package\n"
            zout.writestr(name, data)
    code = ("import sys\nfrom fmpy import simulate_fmu\ntry:\n"
            f"    simulate_fmu({str(fmu)!r}, stop_time=1e-4, step_size=1e-5)\n"
            "except Exception as exc:\n    print('raised:', exc)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=child_env(), cwd=tmp_path, timeout=300)
    out = proc.stdout + proc.stderr
    assert "raised: fmi2DoStep failed with status 3 (error)" in out, out
    assert "[ERROR] the FMU needs the Python package(s) smeha_absent_package" in out, out


# -- the plant FMU in a C host --------------------------------------------------------------------
def test_the_plant_fmu_runs_in_a_c_host_as_in_fmpy(system_dist, c_host, tmp_path):
    # the C host loads the binary with dlopen(RTLD_LOCAL) in a clean environment (no Python
    # set up: the FMU starts the Python SMEHA_FMU_PYTHON names, which has numpy and numba,
    # and loads numba's cache) and drives u = cos(2 pi 100 t) V with the force held at 1442 N (about K y at
    # the rest position), 1000 steps of 10 us
    fmu = Unzipped(system_dist[0] / "SmehaPlant.fmu", tmp_path / "plant")
    outputs = ("rod_displacement", "p_pump", "p_big", "volume_into_big", "q_v1")
    args = [str(c_host), "2", str(fmu.binary), f"{fmu.resources}/", fmu.token,
            str(fmu.vr["u"]), "1000", "1e-5", "100", "1", "0", f"r:{fmu.vr['force']}=1442",
            "--", *(str(fmu.vr[n]) for n in outputs)]
    proc = subprocess.run(args, capture_output=True, text=True, env=HOST_ENV, timeout=300)
    assert proc.returncode == 0, proc.stderr
    rows = [[float(x) for x in line.split(",")] for line in proc.stdout.split()]
    reference = _run("plant_drive", tmp_path / "fmpy", system_dist[0] / "SmehaPlant.fmu",
                     1000, 1e-5, 100.0, 1.0, 0.0, 1442.0, *outputs)
    assert len(rows) == len(reference["rows"]) == 1000
    assert rows == reference["rows"]  # bit for bit: the same binary, the same inputs


# -- the SSP as written, in OpenModelica's OMSimulator -------------------------------------------
def test_omsimulator_runs_the_built_ssp_as_fmpy_does(system_dist, tmp_path):
    # OMSimulator applies the SSD's parameter connections in Initialization Mode (the
    # transducer's calculated parameters into the plant) and reads the master from its own
    # annotation: the .ssp of `smeha build --system`, unmodified, must run with no error line
    # in its log (it exits 0 even with errors). Reference: fmpy's run of the same file.
    # Tolerances: 0.1 % on the piston position; the flows differ by fmpy's first step alone
    # (its connectors start at 0, OMSimulator's at the outputs after initialisation:
    # 9.5e-6 relative, docs/FMU.md), which 1e-4 bounds
    import numpy as np

    from smeha.fmu import systemrun

    exe = systemrun.omsimulator()
    if exe is None:
        pytest.skip(f"OMSimulator is not installed (set {systemrun.OMSIMULATOR_VARIABLE} to "
                    "its executable or put it on PATH; docs/FMU.md names its sources)")
    ssp = system_dist[0] / "SmehaEha.ssp"
    oms = systemrun.run_omsimulator(ssp, exe, env=HOST_ENV)  # raises on an error line
    try:
        from fmu_fixtures import run_runner
    except ImportError:  # tests/ imported as a package
        from tests.fmu_fixtures import run_runner
    ref = run_runner("ssp_fmpy", tmp_path / "fmpy", ssp, 100.0)
    times, piston = np.array(ref["time"]), np.array(ref["piston_position"])
    assert np.allclose(oms.record["time"], times, rtol=0, atol=1e-9)
    scale = np.abs(piston).max()
    assert np.abs(oms.record["piston_position"] - piston).max() <= 1e-3 * scale
    flow = systemrun.flow(oms.record, 100.0, PISTON_AREA).flow_sim
    assert flow == pytest.approx(ref["flow"], rel=1e-4)
