"""Hydraulic components of the EHA (system_models), fast checks."""
import math

import numpy as np
import pytest

from gmt import ParameterError
from system_models.accumulator import AccumulatorParameters, accumulator_pressure, oil_volume_at
from system_models.chamber import PumpChamberParameters, chamber_volume
from system_models.circuit import CircuitInputs, CircuitParameters, initial_state, rhs
from system_models.controller import pump_phase, stage, valve_commands
from system_models.cylinder import CylinderParameters, cavity_volumes
from system_models.fluid import FluidParameters, effective_bulk_modulus
from system_models.valves import ValveParameters, orifice_flow

# The paper's Figure 2 as a table: stage -> (direction, compressing, open valves)
FIGURE_2 = {1: ("down", True, {"V1", "V4"}), 2: ("down", False, {"V3", "V4"}),
            3: ("up", True, {"V2", "V3"}), 4: ("up", False, {"V1", "V2"})}


@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_each_stage_opens_the_valves_of_figure_2(number):
    direction, compressing, open_set = FIGURE_2[number]
    flags = valve_commands(direction, compressing)
    assert {f"V{k + 1}" for k, f in enumerate(flags) if f} == open_set
    assert stage(direction, compressing) == number


def test_pump_phase_follows_the_control_signal():
    assert pump_phase(1.0, 0.5, False) is True  # rising: compressing
    assert pump_phase(0.5, 1.0, True) is False  # falling: expanding
    assert pump_phase(1.0, 1.0, True) is True  # still: keeps its phase


def test_bad_direction_is_refused():
    with pytest.raises(ParameterError, match="direction"):
        valve_commands("sideways", True)


def test_orifice_flow_turbulent_far_and_linear_near_zero():
    a, rho, cd, dpt = 1e-5, 860.0, 0.65, 1e4
    dp = 1e6  # 100 dp_t: within 0.01 % of the turbulent law (correction ~ (dp_t/dp)^2 / 4)
    turbulent = cd * a * math.sqrt(2 * dp / rho)
    assert orifice_flow(a, dp, rho, cd, dpt) == pytest.approx(turbulent, rel=1e-4)
    assert orifice_flow(a, -dp, rho, cd, dpt) == pytest.approx(-turbulent, rel=1e-4)
    small = np.array([-1.0, 0.0, 1.0])  # Pa: linear, finite slope, no sqrt singularity
    q = orifice_flow(a, small, rho, cd, dpt)
    assert q[1] == 0.0 and q[2] == pytest.approx(-q[0])
    assert q[2] == pytest.approx(cd * a * math.sqrt(2 / rho) / math.sqrt(dpt), rel=1e-6)


def test_effective_bulk_modulus_with_and_without_air():
    oil = FluidParameters()
    assert effective_bulk_modulus(oil, 1e6) == pytest.approx(oil.bulk_modulus)
    airy = FluidParameters(air_fraction=0.01)
    # air compresses away with pressure: stiffer at 3 MPa than at 0.5 MPa, never above oil
    b_lo, b_hi = effective_bulk_modulus(airy, 0.5e6), effective_bulk_modulus(airy, 3e6)
    assert b_lo < b_hi < oil.bulk_modulus
    with pytest.raises(ParameterError, match="air_fraction"):
        FluidParameters(air_fraction=-0.1)


def test_accumulator_pressure_and_volume_are_inverse():
    acc = AccumulatorParameters()
    for p in (0.9e6, 1.0e6, 1.5e6, 3e6):
        assert accumulator_pressure(acc, oil_volume_at(acc, p)) == pytest.approx(p, rel=1e-12)
    # isentropic gas law: p0 V0^n = p V^n
    v = oil_volume_at(acc, 2e6)
    assert 1e6 * acc.gas_volume ** 1.4 == pytest.approx(2e6 * (acc.gas_volume - v) ** 1.4)


def test_chamber_and_cylinder_geometry():
    ch = PumpChamberParameters()
    assert chamber_volume(ch, ch.reference_displacement + 10e-6) == pytest.approx(
        ch.dead_volume - ch.piston_area * 10e-6)
    with pytest.raises(ParameterError, match="empties"):
        chamber_volume(ch, 1.0)
    cyl = CylinderParameters()
    vb0, vs0 = cavity_volumes(cyl, 0.0)
    vb1, vs1 = cavity_volumes(cyl, 0.01)
    assert vb1 - vb0 == pytest.approx(cyl.big_area * 0.01)
    assert vs0 - vs1 == pytest.approx(cyl.small_area * 0.01)
    with pytest.raises(ParameterError, match="rod_diameter"):
        CylinderParameters(rod_diameter=0.03)


def test_volume_balance_closes_to_round_off():
    """Every flow that leaves one volume enters another (continuity).

    For each volume, Q_in - Q_out = dV/dt + (V / beta) dp/dt; summed over the
    chamber, both cavities and the accumulator the valve flows cancel, so
    sum(V/beta dp/dt) + sum(dV/dt) = 0 at any state and input.
    """
    rng = np.random.default_rng(7)
    params = CircuitParameters(fluid=FluidParameters(air_fraction=0.005))
    cyl, ch, fl = params.cylinder, params.chamber, params.fluid
    for _ in range(50):
        x = initial_state(params)
        x[:3] = rng.uniform(0.5e6, 5e6, 3)
        x[3] = oil_volume_at(params.accumulator, rng.uniform(1.1e6, 2e6))
        x[4] = rng.uniform(0.0, cyl.stroke)
        x[5] = rng.uniform(-0.05, 0.05)
        x[6:] = rng.uniform(0.0, 1.0, 4)
        y, v = ch.reference_displacement + rng.uniform(-20e-6, 20e-6), rng.uniform(-0.02, 0.02)
        dx = rhs(0.0, x, CircuitInputs(y, v, (1, 0, 0, 1), 100.0), params)
        vb, vs = cavity_volumes(cyl, x[4])
        compress = sum(vol / effective_bulk_modulus(fl, p) * dp for vol, p, dp in
                       ((chamber_volume(ch, y), x[0], dx[0]), (vb, x[1], dx[1]), (vs, x[2], dx[2])))
        geometric = -ch.piston_area * v + cyl.big_area * x[5] - cyl.small_area * x[5] + dx[3]
        scale = ch.piston_area * abs(v) + cyl.big_area * abs(x[5]) + abs(dx[3]) + 1e-12
        assert abs(compress + geometric) <= 1e-12 * scale
