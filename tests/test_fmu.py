"""The FMI 2.0 FMU: build, model description, equality with gmt, state, errors.

The FMU is built once per pytest run in a child process and run in other
children that never import the repository's gmt; see ``tests/fmu_fixtures.py``.
Expected trajectories come from :class:`gmt.Transducer` stepped with the same
inputs (the FMU's contract is to be that model, step for step), computed in a
separate child.
"""
from __future__ import annotations

import re
import subprocess
import sys
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

try:
    from fmu_fixtures import (bad_input, behaviour, build_fmus, child_env,  # noqa: F401
                              fmu_dist, max_relative_difference, reference, run_runner,
                              runner_dir)
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import (bad_input, behaviour, build_fmus, child_env,  # noqa: F401
                                    fmu_dist, max_relative_difference, reference,
                                    run_runner, runner_dir)

try:
    from fmu_runner import BAD_PARAMETERS, TWO_DOF
except ImportError:  # tests/ imported as a package
    from tests.fmu_runner import BAD_PARAMETERS, TWO_DOF

from smeha.fmu.build import iface

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[1]

CASES = ("fixed50", "random100", "comp_control", "comp_demand")
#: One case per model variant (tests/fmu_runner.py VARIANTS): 100 Hz with random steps and
#: forces, the saturation variant through the compensator; v_slab and v_two_dof are forms
#: other than their cause's first (model_variant "cause:form").
VARIANT_CASES = ("v_hysteresis", "v_saturation", "v_eddy", "v_delay", "v_mechanics", "v_drift",
                 "v_slab", "v_two_dof")
#: Columns of a row (tests/fmu_runner.py OUTPUTS).
DISPLACEMENT, SATURATION_COUNT, SENSED = 1, 9, 10
#: FMU and gmt agree to 1e-12 relative (they run the same
#: code on the same doubles, so in practice the difference is exactly 0).
RTOL = 1e-12


def model_description(fmu) -> ET.Element:
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


# -- build and model description ------------------------------------------------------------
def test_build_writes_fmi2_fmu_with_bundled_gmt(fmu_dist):
    fmu = fmu_dist["2"]
    assert fmu.is_file()
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        slave = z.read("resources/slavemodule.txt").decode().strip()
        record = z.read("resources/smeha_fmu_environment.txt").decode()
    # every module under its name and the build's identifier (recorded)
    build = slave.removeprefix("smeha_gmt_fmu_")
    assert re.fullmatch("[0-9a-f]{12}", build) and f"build\t{build}\n" in record
    assert {f"resources/smeha_fmu_gmt_{build}/__init__.py",
            f"resources/smeha_fmu_gmt_{build}/transducer.py",
            f"resources/smeha_gmt_fmu_{build}.py", f"resources/smeha_fmu_interface_{build}.py",
            f"resources/smeha_fmu_slave_{build}.py", f"resources/smeha_fmu_runtime_{build}.py",
            "resources/smeha_fmu_environment.txt",
            "binaries/linux64/SmehaGmt.so"} <= names
    assert not any("__pycache__" in n for n in names)
    root = model_description(fmu)
    assert root.get("fmiVersion") == "2.0"
    cs = root.find("CoSimulation")
    assert cs.get("modelIdentifier") == "SmehaGmt"
    assert cs.get("canGetAndSetFMUstate") == "true"
    assert cs.get("canSerializeFMUstate") == "true"
    assert cs.get("canHandleVariableCommunicationStepSize") == "true"


def test_fmpy_validation_finds_no_problems(fmu_dist):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_dist["2"])) == []
    cli = [sys.executable, "-c", "import sys; from fmpy.cli import main; sys.exit(main())",
           "validate", str(fmu_dist["2"])]
    proc = subprocess.run(cli, capture_output=True, text=True, env=child_env(), timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "No problems found" in proc.stdout


def test_interface_names_causality_and_types(fmu_dist):
    svs = model_description(fmu_dist["2"]).find("ModelVariables").findall("ScalarVariable")
    got = {sv.get("name"): (sv.get("causality"), sv[0].tag) for sv in svs}
    # the interface's names and types
    assert {n: got[n] for n in ("u", "external_force")} == {
        "u": ("input", "Real"), "external_force": ("input", "Real")}
    outputs = {"current": "Real", "displacement": "Real", "velocity": "Real", "field": "Real",
               "flux_density": "Real", "magnetization": "Real", "strain": "Real",
               "force": "Real", "saturated": "Boolean", "saturation_count": "Integer",
               "sensed_displacement": "Real", "outside_design_point": "Boolean",
               "operating_frequency": "Real", "operating_current_amplitude": "Real"}
    assert {n: got[n] for n in outputs} == {n: ("output", t) for n, t in outputs.items()}
    params = {n for n, (c, _) in got.items() if c == "parameter"}
    import gmt  # the pytest process may import gmt: it never loads an FMU

    expected = (set(gmt.TransducerParameters.field_names())
                | {"frequency", "current_amplitude", "flux_density_amplitude", "follow_drive",
                   "amplifier_gain", "current_limit", "compensated", "displacement_per_volt",
                   "control_offset", "branch_rule", "compensator_period", "model_variant",
                   "variant_parameters", "magnetics", "inverse_model"}
                | set(gmt.TimeDomainParameters.field_names()))
    assert params == expected
    assert got["magnetics"][1] == got["inverse_model"][1] == "String"
    # the mechanics the force drives, for a host that integrates the rod
    assert {n for n, (c, _) in got.items() if c == "calculatedParameter"} == {
        "equivalent_mass", "equivalent_damping", "equivalent_stiffness", "output_mass",
        "joint_stiffness", "joint_damping"}
    assert got["compensated"][1] == "Boolean"
    assert got["branch_rule"][1] == got["model_variant"][1] == "String"
    assert got["variant_parameters"][1] == "String"
    by_name = {sv.get("name"): sv for sv in svs}
    assert by_name["saturation_count"].get("variability") == "discrete"
    assert all(by_name[p].get("variability") == "fixed" for p in params)


def test_interface_table_matches_gmt():
    iface.check_against_gmt()


def test_every_variable_has_description_and_every_real_a_defined_unit(fmu_dist):
    root = model_description(fmu_dist["2"])
    defined = {u.get("name"): u for u in root.find("UnitDefinitions")}
    for sv in root.find("ModelVariables").findall("ScalarVariable"):
        assert sv.get("description"), sv.get("name")
        real = sv.find("Real")
        if real is not None:
            assert real.get("unit") in defined, sv.get("name")
            assert real.get("unit") == iface.BY_NAME[sv.get("name")].unit

    def base(name):
        b = defined[name].find("BaseUnit")
        return {k: int(v) for k, v in b.attrib.items()}
    # SI: N = kg m s^-2, V = kg m^2 s^-3 A^-1, T = kg s^-2 A^-1 (BIPM SI brochure, table 4)
    assert base("N") == {"kg": 1, "m": 1, "s": -2}
    assert base("V") == {"kg": 1, "m": 2, "s": -3, "A": -1}
    assert base("T") == {"kg": 1, "s": -2, "A": -1}
    assert base("A/m") == {"A": 1, "m": -1}
    assert base("1") == {}
    units = {sv.get("name"): sv.find("Real").get("unit")
             for sv in root.find("ModelVariables").findall("ScalarVariable")
             if sv.find("Real") is not None}
    assert (units["u"], units["external_force"], units["displacement"], units["velocity"],
            units["field"], units["flux_density"], units["force"], units["frequency"]) == (
        "V", "N", "m", "m/s", "A/m", "T", "N", "Hz")


def test_initial_unknowns_list_every_output(fmu_dist):
    # FMI 2.0.x, section 2.2.8: InitialUnknowns lists the outputs and the calculated
    # parameters (initial "calculated")
    root = model_description(fmu_dist["2"])
    svs = root.find("ModelVariables").findall("ScalarVariable")
    outputs = [i + 1 for i, sv in enumerate(svs) if sv.get("causality") == "output"]
    calculated = [i + 1 for i, sv in enumerate(svs)
                  if sv.get("causality") == "calculatedParameter"]
    structure = root.find("ModelStructure")
    assert [int(u.get("index")) for u in structure.find("Outputs")] == outputs
    assert [int(u.get("index")) for u in structure.find("InitialUnknowns")] == sorted(
        outputs + calculated)


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_calculated_parameters_hold_their_values_in_initialization_mode(fmu_dist, runner_dir,
                                                                        fmi):
    # FMI 2.0.4 section 4.2.4 (condition 2: the InitialUnknowns, which section 2.2.8 makes
    # list every calculatedParameter) and FMI 3.0.2 section 2.3.3 let a host read them in
    # Initialization Mode; an SSP host routes them into the plant's parameters there.
    # Reference: eq 27's m, c, K are the parameters mass, damping, stiffness themselves
    # (exact), and the two-mass variant's values are tests/fmu_runner.py TWO_DOF's (its
    # rod mass, half of Table 2's 0.02 kg, is the variant's; damping and stiffness Table 2's).
    res = run_runner("init_mode", runner_dir / f"init_mode{fmi}", fmu_dist[fmi])
    assert res["gmt_imported_before_fmu"] is False
    paper, two = res["paper"], res["two_dof"]
    assert paper["entered"] == [0.05, 1000.0, 2e7, 0.0, 0.0, 0.0], paper["logs"]
    assert paper["inside"] == paper["exited"] == [0.05, 1000.0, 3e7, 0.0, 0.0, 0.0]
    assert two["entered"] == two["inside"] == two["exited"]
    assert two["entered"][:4] == [0.01, 2945.0, 1.963e7, 0.01]
    assert two["entered"][4:] == pytest.approx([TWO_DOF["joint_stiffness_N_per_m"],
                                                TWO_DOF["joint_damping_N_s_per_m"]], rel=1e-12)
    assert set(paper["statuses"]) == set(two["statuses"]) == {0}


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_the_fmu_holds_no_path_of_the_machine_that_built_it(fmu_dist, fmi):
    # an FMU travels: nothing in it names the source tree, this Python's installation or the
    # build's output folder (the loader finds a Python where the FMU runs)
    needles = {str(REPO), sys.prefix, sys.base_prefix, str(fmu_dist["dir"])}
    with zipfile.ZipFile(fmu_dist[fmi]) as z:
        found = [(name, needle) for name in z.namelist() for needle in needles
                 if needle.encode() in z.read(name)]
        record = z.read("resources/smeha_fmu_environment.txt").decode()
    assert found == []
    assert "required\tnumpy\n" in record and f"version\t{sys.version}\n" in record


def test_default_experiment_is_the_50_hz_case(fmu_dist):
    de = model_description(fmu_dist["2"]).find("DefaultExperiment")
    assert (float(de.get("startTime")), float(de.get("stopTime")),
            float(de.get("stepSize"))) == (0.0, 0.1, 1e-5)


def test_two_builds_give_the_same_model_description_but_the_date(fmu_dist, tmp_path):
    proc = build_fmus(tmp_path, "both")
    assert proc.returncode == 0, proc.stderr
    from smeha.fmu.build import deterministic_guid

    for name, id_attr in (("SmehaGmt.fmu", "guid"), ("SmehaGmt3.fmu", "instantiationToken")):
        first, second = fmu_dist["dir"] / name, tmp_path / name
        roots = [model_description(f) for f in (first, second)]
        for r in roots:
            del r.attrib["generationDateAndTime"]
        assert ET.tostring(roots[0]) == ET.tostring(roots[1])
        # GUID policy: uuid5 of the model description with GUID and date blanked
        assert roots[0].get(id_attr) == deterministic_guid(model_description(first))
        uuid.UUID(roots[0].get(id_attr))
        with zipfile.ZipFile(first) as a, zipfile.ZipFile(second) as b:
            assert a.namelist() == b.namelist()
            for member in a.namelist():
                if member != "modelDescription.xml":
                    assert a.read(member) == b.read(member), member


# -- running: the FMU is gmt, step for step ---------------------------------------------------
def test_fmu_runs_its_bundled_gmt(behaviour):
    res = behaviour("2")
    assert res["gmt_imported_before_fmu"] is False
    gmt_dir = Path(res["gmt_file"]).parent
    assert gmt_dir.parent == Path(res["unzipdir"]) / "resources"
    assert gmt_dir.name.startswith("smeha_fmu_gmt_")


@pytest.mark.parametrize("case", CASES + VARIANT_CASES)
def test_outputs_equal_gmt_time_stepping_model(behaviour, reference, case):
    res = behaviour("2")
    assert res[f"status_{case}"] == [0]
    assert all(s == 0 for s in res[f"init_{case}"])
    assert max_relative_difference(res[f"solo_{case}"], reference[case]) <= RTOL


@pytest.mark.parametrize("case", ("td_square", "td_step", "td_comp"))
def test_time_domain_magnetics_in_the_fmu(behaviour, reference, case):
    # magnetics = "time_domain" (gmt.timedomain): the FMU steps gmt's time-domain model, a
    # square, a step held as DC and the compensated drive give finite outputs, and the
    # design-point flag stays down (every drive is inside that model)
    import numpy as np

    res = behaviour("2")
    assert res[f"status_{case}"] == [0]
    assert max_relative_difference(res[f"solo_{case}"], reference[case]) <= RTOL
    assert np.all(np.isfinite(np.array(res[f"solo_{case}"])))
    assert res[f"outside_{case}"] is False


def test_compensated_cases_exercise_saturation(reference):
    # the state tests need a non-trivial counter; comp_demand has a 0.9 A current limit
    assert reference["comp_demand"][-1][SATURATION_COUNT] > 0


@pytest.mark.parametrize("case", VARIANT_CASES)
def test_each_variant_changes_what_its_extension_acts_on(reference, case):
    # the gmt reference with the variant against the same inputs through the paper's model:
    # the rod moves differently, except for the sensor delay, which moves only the reading
    import numpy as np

    variant = np.array(reference[case])
    paper = np.array(reference[f"paper:{case}"])
    y, sensed = variant[:, DISPLACEMENT], variant[:, SENSED]
    change = np.abs(y - paper[:, DISPLACEMENT]).max() / np.ptp(paper[:, DISPLACEMENT])
    if case == "v_delay":
        assert change == 0.0
        assert np.abs(sensed - y).max() > 0.01 * np.ptp(y)
    else:
        assert change > 1e-3, change
        assert np.array_equal(sensed, y)
    assert np.array_equal(paper[:, SENSED], paper[:, DISPLACEMENT])


def test_two_instances_in_one_process_are_independent(behaviour, reference):
    res = behaviour("2")
    assert max_relative_difference(res["pair_fixed50"], reference["fixed50"]) <= RTOL
    assert max_relative_difference(res["pair_comp_demand"], reference["comp_demand"]) <= RTOL


def test_reset_gives_the_trajectory_of_a_fresh_instance(behaviour, reference):
    res = behaviour("2")
    assert res["reset_status"] == 0
    assert res["reset_same"] == reference["comp_demand"]
    # after fmi2Reset the parameters are back at their start values
    assert res["reset_defaults"] == reference["fixed50"]


def test_fmu_state_round_trip_is_bit_identical(behaviour, reference):
    res = behaviour("2")
    k1, k2 = res["state_k1"], res["state_k2"]
    first = res["state_first"]
    assert res["state_set_status"] == 0
    assert res["state_again"] == first  # get/set
    assert res["state_from_bytes"] == first  # serialize/deserialize
    assert res["state_twice"] == first  # one state restored twice
    assert res["state_moved"] == first  # into an instance built with other parameters
    assert res["state_reserialized_equal"]
    assert max_relative_difference(first, reference["comp_demand"][k1:k2]) <= RTOL
    assert res["state_json_keys"] == ["built_from", "problem", "transducer", "variables"]


@pytest.mark.parametrize("case", ("v_delay", "v_hysteresis", "v_eddy", "v_slab", "v_two_dof"))
def test_fmu_state_round_trip_with_a_stateful_variant(behaviour, reference, case):
    check_variant_state(behaviour("2"), reference, case)


def check_variant_state(res, reference, case):
    # the delay line, the plays, the lag's sections, the diffusion's modes and the two
    # masses' rod state are saved with the FMU state:
    # restore and replay (also through serialisation and into an instance built with
    # the paper's model) is bit-identical
    r = res[f"vstate_{case}"]
    first = r["first"]
    assert r["again"] == first and r["from_bytes"] == first and r["moved"] == first
    assert first == reference[case][r["k1"]:r["k2"]]
    # the paper's uncompensated state has 7 values; then the elapsed time, the sensed y and
    # the memory of the extension
    assert r["transducer_state"] > 9


# -- bad input never kills the host ------------------------------------------------------------
INPUT_CASES = ("u_nan", "u_inf", "u_nan_compensated", "force_nan_compensated",
               "force_minus_inf", "step_zero", "step_negative", "step_nan", "step_inf",
               "u_nan_variant_delay", "step_zero_variant_hysteresis")
#: Bad parameters: case -> the parameter its message names (tests/fmu_runner.py).
PARAMETER_CASES = {case: named for case, (_, named) in BAD_PARAMETERS.items()}
DISCARD, ERROR, FATAL = 2, 3, 4
#: What doStep of an unusable instance (bad parameter, missing package) returns: Error. FMI
#: 3.0: pythonfmu3 takes a do_step result's status; FMI 2.0: pythonfmu 0.7 answers the slave's
#: exception with Fatal, which the FMU's loader turns into Error for the slave's
#: SmehaRecoverableError (docs/FMU.md, "Errors"; FMI 2.0.4 keeps Fatal for a model
#: corrupted for all instances).
UNUSABLE = {"2": ERROR, "3": ERROR}


def check_bad_input(results, fmi):
    assert results["process_survived"] is True
    assert results["gmt_imported_before_fmu"] is False
    for name in INPUT_CASES:
        r = results[name]
        assert r["bad_step"] == DISCARD, name
        assert [s for i, s in enumerate(r["statuses"]) if i != 10] == [0] * 20, name
        assert r["recovered_exactly"], name  # the discarded step changed nothing
        assert any(status == DISCARD and "discarded" in msg for status, _, msg in r["logs"])
        assert all(s != FATAL for s, _, _ in r["logs"]), name
    for name, parameter in PARAMETER_CASES.items():
        r = results[name]
        assert all(s == 0 for s in r["init"]), name
        # every step of the unusable instance fails, with a status no host can miss
        assert r["statuses"] == [UNUSABLE[fmi]] * 2, name
        assert any(status == ERROR and parameter in msg for status, _, msg in r["logs"]), name
    after = results["parameter_after_init"]
    assert after["bad_step"] == 0 and after["recovered_exactly"]
    assert any(s == ERROR and "mass" in m for s, _, m in after["logs"])
    # an unusable instance fails every step, survives a reset, then discards a bad input
    repeated = results["repeated_failures"]["statuses"]
    n_init = 3 if fmi == "2" else 2  # (setupExperiment,) enter and exit initialisation
    assert repeated == [UNUSABLE[fmi]] * 3 + [0] * n_init + [DISCARD] * 4 + [0], repeated
    corrupt = results["corrupt_state"]
    assert corrupt["bad_step"] == 0 and corrupt["recovered_exactly"]
    assert any(s == ERROR for s, _, _ in corrupt["logs"])
    # the reason reaches the process's stderr once per unusable instance (a host may run
    # without FMU logging, and pythonfmu 0.7 then drops every message)
    told = [line for line in results["stderr"].splitlines() if "refused" in line]
    assert len(told) == len(PARAMETER_CASES) + 1  # + repeated_failures' first instance
    assert all(any(p in line for line in told) for p in PARAMETER_CASES.values())


def test_bad_input_is_discarded_and_a_bad_parameter_fails_every_step(bad_input):
    check_bad_input(bad_input("2"), "2")


# -- memory --------------------------------------------------------------------------------------
def test_memory_is_flat_over_1e5_steps(fmu_dist, runner_dir):
    res = run_runner("memory", runner_dir / "memory", fmu_dist["2"], 100000)
    samples = res["samples"]
    growth = samples[-1][1] - samples[0][1]  # after 1e4 warm-up steps to 1e5 steps, [MB]
    assert growth < 2.0, samples


# -- the documentation's fmpy example runs as shown ----------------------------------------------
def test_the_docs_fmpy_example_runs_without_warnings(fmu_dist, tmp_path):
    # docs/FMU.md's simulate_fmu example must not print fmpy's
    # 'Warning: missing input for variable "external_force"'; run as written (a child: the
    # pytest process has imported the repository's gmt), on this run's FMU
    import re

    doc = (Path(__file__).resolve().parents[1] / "docs" / "FMU.md").read_text()
    section = doc[doc.index("### fmpy"):]
    code = re.search(r"```python\n(.+?)```", section, re.S).group(1)
    assert "simulate_fmu(" in code and '"dist/SmehaGmt.fmu"' in code
    code = code.replace('"dist/SmehaGmt.fmu"', repr(str(fmu_dist["2"])))
    code += "\nprint('rows', len(res), 'max current', max(res['current']))\n"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=child_env(),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "Warning" not in proc.stdout + proc.stderr, proc.stdout + proc.stderr
    rows, peak = re.search(r"rows (\d+) max current (\S+)", proc.stdout).groups()
    assert int(rows) == 10001 and abs(float(peak) - 1.0) < 1e-6  # the 50 Hz drive, 1 A


_TWICE = """
import sys
from pathlib import Path
from fmpy import extract, simulate_fmu
fmu, tamper = sys.argv[1], sys.argv[2] == "tamper"
for k in range(2):
    folder = extract(fmu)
    if tamper and k == 1:  # the second copy's physics differs from the one loaded first
        init = next((Path(folder) / "resources").glob("smeha_fmu_gmt_*/__init__.py"))
        init.write_text(init.read_text() + "# another version\\n")
    simulate_fmu(folder, stop_time=1e-4, output_interval=1e-5, debug_logging=True)
"""


@pytest.mark.parametrize("tamper", [False, True])
def test_loading_the_fmu_twice_warns_only_when_the_physics_differs(tamper, fmu_dist, tmp_path):
    # the same FMU loaded twice in one process (two extractions) shares its
    # physics under one module name; that is no cause for a warning, a different copy is
    proc = subprocess.run([sys.executable, "-c", _TWICE, str(fmu_dist["2"]),
                           "tamper" if tamper else "same"], cwd=tmp_path, env=child_env(),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    warned = "gmt is imported from" in proc.stdout + proc.stderr
    assert warned == tamper, proc.stdout + proc.stderr
