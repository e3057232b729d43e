"""The EHA system's parts that need no FMU built: fast tests.

* The plant FMU's valve controller (``system_models.controller.FedValveController``)
  sees u only at each step; the design (docs/FMU.md, "The EHA as an FMI system") rests
  on its switching exactly one sample after the harness's controller, which knows u
  ahead (``SampledValveController``), at the same samples, and on each valve acting its
  dead time after that (paper, Figure 2's stages; the valves' dead time).
* The plant FMU's variable table covers every field of ``system_models``' circuit, and
  its parameter values give back the circuit they were written from, for every preset.
* The build renames a bundled package's imports of another bundled package, and refuses
  a form it cannot rename.
* The system's SSV Booleans reach fmpy's ``simulate_ssp`` as Booleans (fmpy 0.3.32 turns
  the text "false" into true).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from smeha.fmu import build as fmu_build
from system_models import presets
from system_models.controller import (FedValveController, SampledValveController, dead_times,
                                      valve_commands)
from system_models.plant import PlantParameters
from system_models.rod import RodParameters

PERIOD = 1e-5


def _switches(times, commands):
    """Times at which the commands change, per valve."""
    out = []
    for k in range(4):
        column = [c[k] for c in commands]
        out.append([times[i] for i in range(1, len(times)) if column[i] != column[i - 1]])
    return out


@pytest.mark.parametrize("direction", ["down", "up"])
@pytest.mark.parametrize("frequency,offset", [(50.0, 0.0), (100.0, 1.5)])
def test_fed_controller_switches_one_sample_after_the_one_that_knows_u_ahead(
        direction, frequency, offset):
    def u(t):
        return offset + np.cos(2.0 * np.pi * frequency * t)
    delays = dead_times(presets.realistic_circuit().valves)  # 0.2 ms each
    ahead = SampledValveController(direction, u, PERIOD, delays)
    fed = FedValveController(direction, delays)
    n = int(round(2.5 / frequency / PERIOD))
    times = [j * PERIOD for j in range(n)]
    fed_commands = []
    for t in times:
        fed.sample(t, float(u(t)))
        fed_commands.append(tuple(fed.commands))
    ahead_commands = [ahead.commands_at(t) for t in times]
    # after the start (the fed controller starts compressing, and learns that u falls at
    # its second sample), and before the end (it may not have seen the last switch yet)
    start, end = 0.25 / frequency, times[-1] - 1e-3
    expected = [[t + PERIOD for t in valve if start < t < end]
                for valve in _switches(times, ahead_commands)]
    got = [[t for t in valve if start + PERIOD < t < end + PERIOD]
           for valve in _switches(times, fed_commands)]
    assert sum(map(len, expected)) >= 8  # the valves switched, twice a cycle
    assert got == [pytest.approx(want, abs=1e-12) for want in expected]


def test_each_valve_acts_its_dead_time_after_the_sample_that_commands_it():
    fed = FedValveController("down", (0.0, 1e-4, 2e-4, 3e-4))
    fed.sample(0.0, 0.0)
    fed.sample(1e-5, 1.0)  # rising: compressing, stage 1 (the start's stage: no action)
    assert fed.stage == 1 and fed.commands == [1.0, 0.0, 0.0, 1.0]
    fed.sample(2e-5, 0.5)  # falling: stage 2 commanded at 20 us
    assert fed.stage == 2
    # V1 has no dead time: it closes at once; V3 opens 0.2 ms later; V2, V4 keep theirs
    assert fed.commands == [0.0, 0.0, 0.0, 1.0]
    assert fed.next_action(2e-5, 1.0) == pytest.approx(2e-5 + 2e-4)
    fed.advance(2e-5 + 2e-4)
    assert fed.commands == [0.0, 0.0, 1.0, 1.0] == [float(c) for c in valve_commands(
        "down", False)]
    assert not fed.valves_compressing
    state = fed.get_state()
    fed.sample(3e-4, 2.0)
    fed.set_state(state)
    assert fed.get_state() == state


def _plant_table():
    return fmu_build.table("smeha_plant_interface")


def test_the_plant_table_covers_system_models_circuit():
    table = _plant_table()
    table.check_against_system_models()  # every field, the responses, the start values
    kinds = {v.name: v.kind for v in table.VARIABLES}
    assert kinds["cylinder_through_rod"] == "Boolean" and kinds["v3_response"] == "Integer"
    assert {"force", "u"} == {v.name for v in table.VARIABLES if v.causality == "input"}


@pytest.mark.parametrize("name", sorted(presets.CIRCUITS))
def test_parameter_values_give_back_the_circuit_and_rod(name):
    table = _plant_table()
    circuit = presets.circuit(name)
    rod = RodParameters(0.01, 1000.0, 1.9e7, 0.01, 3.9e5, 12.5)  # a two-mass rod
    values = {v.name: v.start for v in table.VARIABLES if v.causality == "parameter"}
    values.update(table.circuit_values(circuit), **table.rod_values(rod))
    assert table.plant_parameters(values) == PlantParameters(circuit, rod)


def test_a_bad_plant_parameter_is_named_with_its_range():
    import gmt

    table = _plant_table()
    values = {v.name: v.start for v in table.VARIABLES if v.causality == "parameter"}
    for name, value, words in (("v2_area", -1.0, r"v2_area = -1 m\^2"),
                               ("equivalent_mass", 0.0, "equivalent_mass = 0 kg"),
                               ("v4_response", 5, "v4_response = 5")):
        with pytest.raises(gmt.ParameterError, match=words):
            table.plant_parameters(dict(values, **{name: value}))


def test_imports_of_a_bundled_package_are_renamed():
    source = ("import gmt\nfrom gmt.errors import check_range\n\n\ndef f():\n"
              "    from gmt import mechanics  # gmt in a comment stays\n"
              "    return 'gmt'\n")
    out = fmu_build.rename_imports(source, {"gmt": "smeha_plant_gmt"})
    assert out == ("import smeha_plant_gmt as gmt\nfrom smeha_plant_gmt.errors import "
                   "check_range\n\n\ndef f():\n    from smeha_plant_gmt import mechanics  "
                   "# gmt in a comment stays\n    return 'gmt'\n")
    with pytest.raises(fmu_build.BuildError, match="cannot rename"):
        fmu_build.rename_imports("import gmt.errors\n", {"gmt": "smeha_plant_gmt"})


def test_ssv_booleans_reach_fmpy_as_booleans():
    from smeha.fmu import systemrun

    assert systemrun._typed("Boolean", "false") is False
    assert systemrun._typed("Boolean", "true") is True
    assert systemrun._typed("Real", "1e-05") == 1e-05
    with pytest.raises(ValueError, match="not true, false"):
        systemrun._typed("Boolean", "no")


def test_the_system_step_is_the_valve_controllers_period():
    from smeha.fmu import ssp
    from system_models.defaults import VALVE_CONTROLLER_PERIOD

    # the plant's controller samples u at each step: the harness's controller's rate
    assert ssp.SYSTEM_STEP == VALVE_CONTROLLER_PERIOD
    assert math.isclose(0.01 / ssp.SYSTEM_STEP, round(0.01 / ssp.SYSTEM_STEP))


def _doc_rows(start: str, end: str) -> dict:
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "FMU.md").read_text()
    part = doc[doc.index(start):doc.index(end, doc.index(start))]
    rows = {}
    for line in part.splitlines():
        if line.startswith("| `"):
            name, causality = line.split("|")[1].strip().strip("`"), line.split("|")[2].strip()
            # one row for the four valves' namesakes: `vN_area`, "V1-V4 (N = 1-4): ..."
            names = ([f"v{n}_{name[3:]}" for n in range(1, 5)]
                     if name.startswith("vN_") and "(N = 1-4)" in line else [name])
            rows.update(dict.fromkeys(names, causality))
    return rows


@pytest.mark.parametrize("module,start,end", [
    ("smeha_plant_interface", "Plant (`fmu_src/smeha_plant_interface.py`",
     "Drive (`fmu_src/smeha_drive_interface.py`"),
    ("smeha_drive_interface", "Drive (`fmu_src/smeha_drive_interface.py`", "Log messages")])
def test_docs_list_every_system_fmu_variable(module, start, end):
    # docs/FMU.md's tables are the user's reference: one row per variable the slave registers
    table = fmu_build.table(module)
    rows = _doc_rows(start, end)
    assert rows == {v.name: v.causality for v in table.VARIABLES}


def test_the_rod_starts_at_rest_under_the_chambers_pressure():
    # the rod started at its free rest sprang back by A_d p_P / K (96 um at the
    # realistic circuit's 1.5 MPa, 1256 mm^2, Table 2's K) at the first step. Started at
    # the statics of eq 27 with the chamber's force (system_models.rod), the plant with a
    # constant magnetostrictive force K y_free stays where it is (to the integrator's
    # tolerance), for one mass and for two (the joint deflected by the same force)
    import numpy as np

    from system_models import kernel, presets
    from system_models.plant import PlantParameters, initial_state
    from system_models.rod import RodParameters
    circuit = presets.circuit("realistic")
    for rod in (RodParameters(), RodParameters(0.01, 2945.0, 1.963e7, 0.01, 5e7, 100.0)):
        plant = PlantParameters(circuit, rod)
        y_free = 73.47e-6
        z0 = initial_state(plant, y_free)
        force = circuit.chamber.piston_area * z0[0]
        assert force / rod.stiffness == pytest.approx(95.98e-6, rel=1e-3)
        assert z0[10] == pytest.approx(y_free - force / rod.stiffness)
        steps = np.full(50, 1e-5)
        forces = np.full((50, 2), rod.stiffness * y_free)
        status, done, rows = kernel.plant_run(z0, steps, forces, np.zeros((50, 4)), 0.0,
                                              plant.packed)
        assert status == kernel.OK
        side = 12 if rod.size == 4 else 10
        assert np.max(np.abs(rows[:, side] - z0[side])) < 1e-9  # 1 nm against 96 um
