"""The assembled hydraulic circuit of the EHA as ``rhs(t, x, inputs, params)``.

Ports: P pump chamber, B big cavity, S small cavity, A accumulator, joined by
valves V1 (P-B), V2 (B-A), V3 (P-S), V4 (S-A) (the paper's Figure 2).

State vector (SI), see :data:`STATE_NAMES`:
p_P, p_B, p_S [Pa]; V_A, oil stored in the accumulator [m^3]; x, v of the
cylinder piston [m, m/s]; the opening fractions of V1..V4 [-] (used by
first-order valves; held at the command for ideal ones).

Inputs: the transducer rod's displacement and velocity (from the FMU), the
four valve commands (0 or 1) and the external load on the cylinder.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .accumulator import AccumulatorParameters, accumulator_pressure, oil_volume_at
from .chamber import PumpChamberParameters, chamber_pressure_rate, chamber_volume
from .cylinder import CylinderParameters, cavity_volumes, end_stop_force, piston_acceleration
from .fluid import FluidParameters, effective_bulk_modulus
from .valves import (ValveParameters, open_area, opening_rate, orifice_flow,
                     orifice_flow_derivative)

STATE_NAMES = ("p_pump", "p_big", "p_small", "accumulator_oil", "piston_position",
               "piston_velocity", "opening_v1", "opening_v2", "opening_v3", "opening_v4")


@dataclass(frozen=True)
class CircuitParameters:
    """Every component of the circuit."""

    fluid: FluidParameters = field(default_factory=FluidParameters)
    chamber: PumpChamberParameters = field(default_factory=PumpChamberParameters)
    valves: tuple = (ValveParameters(),) * 4
    cylinder: CylinderParameters = field(default_factory=CylinderParameters)
    accumulator: AccumulatorParameters = field(default_factory=AccumulatorParameters)

    def __post_init__(self):
        if len(self.valves) != 4 or not all(isinstance(v, ValveParameters) for v in self.valves):
            from gmt.errors import ParameterError
            raise ParameterError("valves must be four ValveParameters (V1, V2, V3, V4)")


class CircuitInputs(NamedTuple):
    """Inputs of the circuit over a step (held)."""

    rod_displacement: float  #: y of the transducer rod, [m]
    rod_velocity: float  #: dy/dt, [m/s]
    valve_commands: tuple  #: V1..V4, 1 open, 0 closed
    load_force: float = 0.0  #: on the cylinder, opposing "down", [N]


class Flows(NamedTuple):
    """Valve flows, [m^3/s], positive from the first port named to the second."""

    v1: float  #: P -> B
    v2: float  #: B -> A
    v3: float  #: P -> S
    v4: float  #: S -> A


def valve_flows(x, params: CircuitParameters) -> Flows:
    """Flows through V1..V4 at state x."""
    p_p, p_b, p_s = x[0], x[1], x[2]
    p_a = accumulator_pressure(params.accumulator, x[3])
    rho = params.fluid.density
    drops = (p_p - p_b, p_b - p_a, p_p - p_s, p_s - p_a)
    return Flows(*(orifice_flow(open_area(v, x[6 + k]), drops[k], rho, v.discharge_coefficient,
                                v.transition_pressure)
                   for k, v in enumerate(params.valves)))


def rhs(t, x, inputs: CircuitInputs, params: CircuitParameters):
    """dx/dt of the circuit (see module docstring for x).

    Parameters
    ----------
    t : float
        Time, [s] (the circuit is time-invariant; kept for solve_ivp).
    x : array of 10 floats
    inputs : CircuitInputs
    params : CircuitParameters
    """
    fl = params.fluid
    cyl = params.cylinder
    q = valve_flows(x, params)
    pos, vel = x[4], x[5]
    vb, vs = cavity_volumes(cyl, pos)
    dp_p = chamber_pressure_rate(params.chamber, fl, x[0], inputs.rod_displacement,
                                 inputs.rod_velocity, q.v1 + q.v3)
    dp_b = effective_bulk_modulus(fl, x[1]) / vb * (q.v1 - q.v2 - cyl.big_area * vel)
    dp_s = effective_bulk_modulus(fl, x[2]) / vs * (q.v3 - q.v4 + cyl.small_area * vel)
    dv_a = q.v2 + q.v4
    acc = piston_acceleration(cyl, x[1], x[2], pos, vel, inputs.load_force)
    dopen = [0.0] * 4
    for k, v in enumerate(params.valves):
        if v.response == "first_order":
            dopen[k] = opening_rate(v, x[6 + k], inputs.valve_commands[k])
    return np.array([dp_p, dp_b, dp_s, dv_a, vel, acc, *dopen])


def initial_state(params: CircuitParameters, pressure: float | None = None,
                  piston_position: float | None = None, valve_openings=(0.0, 0.0, 0.0, 0.0)):
    """A state at rest with every volume at one pressure.

    Parameters
    ----------
    pressure : float, optional
        Common pressure, [Pa]; default 1.5 times the accumulator pre-charge.
    piston_position : float, optional
        [m]; default mid-stroke.
    """
    p = 1.5 * params.accumulator.precharge_pressure if pressure is None else pressure
    x = params.cylinder.stroke / 2.0 if piston_position is None else piston_position
    return np.array([p, p, p, oil_volume_at(params.accumulator, p), x, 0.0, *valve_openings],
                    dtype=float)


def jacobian(x, inputs: CircuitInputs, params: CircuitParameters):
    """d(rhs)/dx, analytic, for the implicit integrator (10 x 10).

    Exact but for the bulk modulus's own pressure dependence, taken by a
    one-sided difference, and the end stops' kink.
    """
    fl, cyl, ch, acc = params.fluid, params.cylinder, params.chamber, params.accumulator
    rho = fl.density
    n = len(STATE_NAMES)
    jac = np.zeros((n, n))
    p_p, p_b, p_s, v_a, pos, vel = x[0], x[1], x[2], x[3], x[4], x[5]
    p_a = accumulator_pressure(acc, v_a)
    dpa_dv = ((acc.polytropic_index * p_a / (acc.gas_volume - v_a)) if v_a >= 0.0
              else acc.port_stiffness)
    ports = ((0, 1), (1, None), (0, 2), (2, None))  # (up, down) state index; None = accumulator
    pres = {0: p_p, 1: p_b, 2: p_s, None: p_a}
    q = np.empty(4)
    dq_up = np.empty(4)  # dQ/d(p_up) = -dQ/d(p_down)
    dq_open = np.empty(4)
    for k, v in enumerate(params.valves):
        up, down = ports[k]
        dp = pres[up] - pres[down]
        area = open_area(v, x[6 + k])
        q[k] = orifice_flow(area, dp, rho, v.discharge_coefficient, v.transition_pressure)
        dq_up[k] = orifice_flow_derivative(area, dp, rho, v.discharge_coefficient,
                                           v.transition_pressure)
        inside = 0.0 < x[6 + k] < 1.0 or v.response != "first_order"
        dq_open[k] = (q[k] / area * v.area * (1.0 - v.leakage_fraction)) if inside else 0.0

    def dflow(k, j):
        """dQ_k/dx_j."""
        up, down = ports[k]
        d = 0.0
        if up == j:
            d += dq_up[k]
        if down == j:
            d -= dq_up[k]
        if down is None and j == 3:
            d -= dq_up[k] * dpa_dv
        if j == 6 + k:
            d += dq_open[k]
        return d

    vp = chamber_volume(ch, inputs.rod_displacement)
    vb, vs = cavity_volumes(cyl, pos)
    net = ((ch.piston_area * inputs.rod_velocity - q[0] - q[2], vp, 0),
           (q[0] - q[1] - cyl.big_area * vel, vb, 1),
           (q[2] - q[3] + cyl.small_area * vel, vs, 2))
    for inflow, vol, i in net:
        beta = effective_bulk_modulus(fl, x[i])
        dbeta = (effective_bulk_modulus(fl, x[i] * (1 + 1e-6) + 1.0) - beta) / (x[i] * 1e-6 + 1.0)
        jac[i, i] += dbeta / vol * inflow
        sign = {0: ((0, -1.0), (2, -1.0)), 1: ((0, 1.0), (1, -1.0)), 2: ((2, 1.0), (3, -1.0))}[i]
        for j in (0, 1, 2, 3, 6, 7, 8, 9):
            jac[i, j] += beta / vol * sum(sg * dflow(k, j) for k, sg in sign)
        if i == 1:
            jac[1, 5] += -beta / vb * cyl.big_area
            jac[1, 4] += -beta / vb ** 2 * cyl.big_area * inflow
        if i == 2:
            jac[2, 5] += beta / vs * cyl.small_area
            jac[2, 4] += beta / vs ** 2 * cyl.small_area * inflow
    for j in (0, 1, 2, 3, 6, 7, 8, 9):
        jac[3, j] = dflow(1, j) + dflow(3, j)
    jac[4, 5] = 1.0
    stop_k = cyl.stop_stiffness if (pos < 0.0 or pos > cyl.stroke) else 0.0
    stop_c = cyl.stop_damping if end_stop_force(cyl, pos, vel) != 0.0 else 0.0
    jac[5, 1] = cyl.big_area / cyl.mass
    jac[5, 2] = -cyl.small_area / cyl.mass
    jac[5, 4] = -stop_k / cyl.mass
    jac[5, 5] = -(cyl.friction + stop_c) / cyl.mass
    for k, v in enumerate(params.valves):
        if v.response == "first_order":
            jac[6 + k, 6 + k] = -1.0 / v.opening_time
    return jac
