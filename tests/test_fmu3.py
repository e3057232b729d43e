"""The FMI 3.0 FMU (pythonfmu3): native units, validation, equality with gmt, state, errors.

Same cases and child-process arrangement as tests/test_fmu.py (see
tests/fmu_fixtures.py).
"""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

try:
    from fmu_fixtures import (bad_input, behaviour, child_env, fmu_dist,  # noqa: F401
                              max_relative_difference, reference, runner_dir)
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import (bad_input, behaviour, child_env, fmu_dist,  # noqa: F401
                                    max_relative_difference, reference, runner_dir)

try:
    from test_fmu import CASES, RTOL, VARIANT_CASES, check_bad_input, check_variant_state
except ImportError:
    from tests.test_fmu import CASES, RTOL, VARIANT_CASES, check_bad_input, check_variant_state

from smeha.fmu.build import iface

pytestmark = pytest.mark.integration


def model_description(fmu) -> ET.Element:
    with zipfile.ZipFile(fmu) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


def test_fmi3_fmu_validates(fmu_dist):
    from fmpy.validation import validate_fmu

    fmu = fmu_dist["3"]
    assert validate_fmu(str(fmu)) == []
    cli = [sys.executable, "-c", "import sys; from fmpy.cli import main; sys.exit(main())",
           "validate", str(fmu)]
    proc = subprocess.run(cli, capture_output=True, text=True, env=child_env(), timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_fmi3_declares_units_natively(fmu_dist):
    root = model_description(fmu_dist["3"])
    assert root.get("fmiVersion") == "3.0"
    cs = root.find("CoSimulation")
    assert cs.get("modelIdentifier") == "SmehaGmt3"
    assert cs.get("canHandleVariableCommunicationStepSize") == "true"
    assert cs.get("canGetAndSetFMUState") == "true"
    defined = {u.get("name") for u in root.find("UnitDefinitions")}
    variables = {v.get("name"): v for v in root.find("ModelVariables")}
    assert variables["time"].get("causality") == "independent"
    for var in iface.VARIABLES:
        element = variables[var.name]
        assert element.get("description"), var.name
        if var.kind == "Real":
            assert element.tag == "Float64"
            assert element.get("unit") == var.unit and var.unit in defined, var.name
    assert variables["saturation_count"].tag == "Int32"
    assert variables["compensated"].tag == "Boolean"


def test_fmi3_runs_its_bundled_gmt(behaviour):
    res = behaviour("3")
    assert res["gmt_imported_before_fmu"] is False
    gmt_dir = Path(res["gmt_file"]).parent
    assert gmt_dir.parent == Path(res["unzipdir"]) / "resources"
    assert gmt_dir.name.startswith("smeha_fmu_gmt_")


@pytest.mark.parametrize("case", CASES + VARIANT_CASES)
def test_fmi3_outputs_equal_gmt(behaviour, reference, case):
    res = behaviour("3")
    assert res[f"status_{case}"] == [0]
    assert max_relative_difference(res[f"solo_{case}"], reference[case]) <= RTOL


def test_fmi3_instances_reset_and_state(behaviour, reference):
    res = behaviour("3")
    assert max_relative_difference(res["pair_fixed50"], reference["fixed50"]) <= RTOL
    assert max_relative_difference(res["pair_comp_demand"], reference["comp_demand"]) <= RTOL
    assert res["reset_same"] == reference["comp_demand"]
    assert res["reset_defaults"] == reference["fixed50"]
    first = res["state_first"]
    for key in ("state_again", "state_from_bytes", "state_twice", "state_moved"):
        assert res[key] == first, key
    assert res["state_reserialized_equal"]
    for case in ("v_delay", "v_hysteresis", "v_eddy"):
        check_variant_state(res, reference, case)


def test_fmi3_bad_input_is_discarded_and_a_bad_parameter_fails_every_step(bad_input):
    check_bad_input(bad_input("3"), "3")
