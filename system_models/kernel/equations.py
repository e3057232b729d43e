"""The kernel's equations: the plant's parameters as one array, and its rates on plain floats.

:func:`pack` lays the circuit's (and the rod's) parameters out as the float
array every compiled function takes; :func:`_rates` assembles dx/dt the way
:func:`system_models.circuit.rhs` (the rod prescribed) and
:func:`system_models.plant.rhs` (the rod integrated) do, calling the
components' own plain-number physics (``jitable``). :func:`_quadrature` gives
what the master accumulates over a substep (the chamber pressure, the flow
into the big cavity, the oil taken up by compression).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from ..accumulator import gas_spring_pressure
from ..circuit import CircuitParameters
from ..cylinder import piston_acceleration_of
from ..fluid import mixture_bulk_modulus
from ..rod import RodParameters, rod_rates
from ..valves import opening_area, orifice_flow

# indices into the packed parameter array (see :func:`pack`)
_RHO, _BETA, _AIR, _PREF, _NAIR = 0, 1, 2, 3, 4
_V0, _AD, _YREF = 5, 6, 7
_AB, _AS, _VDB, _VDS, _STROKE, _MASS, _FRIC, _KSTOP, _CSTOP = 8, 9, 10, 11, 12, 13, 14, 15, 16
_P0, _VGAS, _NACC, _KPORT = 17, 18, 19, 20
_VALVE = 21  # then per valve: area, C_d, transition pressure, leakage, tau (0: not first order)
_ROD = _VALVE + 4 * 5  # then: rod states (0: prescribed rod), m, c, K, m_2, k_j, c_j
_NPACK = _ROD + 7

#: Circuit states.
NC = 10


@lru_cache(maxsize=64)
def pack(params: CircuitParameters, rod: RodParameters | None = None) -> np.ndarray:
    """The parameters as the kernel's float array (SI); cached per circuit and rod.

    ``rod`` None: the circuit alone (the rod prescribed, :func:`circuit_step`);
    given: the plant (:func:`plant_run`).
    """
    fl, ch, cyl, acc = params.fluid, params.chamber, params.cylinder, params.accumulator
    values = [fl.density, fl.bulk_modulus, fl.air_fraction, fl.reference_pressure,
              fl.air_polytropic_index,
              ch.dead_volume, ch.piston_area, ch.reference_displacement,
              cyl.big_area, cyl.small_area, cyl.dead_volume_big, cyl.dead_volume_small,
              cyl.stroke, cyl.mass, cyl.friction, cyl.stop_stiffness, cyl.stop_damping,
              acc.precharge_pressure, acc.gas_volume, acc.polytropic_index, acc.port_stiffness]
    for v in params.valves:
        values += [v.area, v.discharge_coefficient, v.transition_pressure, v.leakage_fraction,
                   v.opening_time if v.response == "first_order" else 0.0]
    if rod is None:
        values += [0.0] * 7
    else:
        values += [float(rod.size), rod.mass, rod.damping, rod.stiffness, rod.output_mass,
                   rod.joint_stiffness, rod.joint_damping]
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out


def state_size(packed: np.ndarray) -> int:
    """Number of states the packed parameters describe (10 + the rod's)."""
    return NC + int(packed[_ROD])


@njit(cache=True)
def _beta(p, P):
    return mixture_bulk_modulus(p, P[_BETA], P[_AIR], P[_PREF], P[_NAIR])


@njit(cache=True)
def _valve_flow(k, x, p_a, P):
    """Flow through valve V(k+1) at state x, accumulator pressure p_a (as circuit.valve_flows)."""
    j = _VALVE + 5 * k
    if k == 0:
        dp = x[0] - x[1]
    elif k == 1:
        dp = x[1] - p_a
    elif k == 2:
        dp = x[0] - x[2]
    else:
        dp = x[2] - p_a
    return orifice_flow(opening_area(x[6 + k], P[j], P[j + 3]), dp, P[_RHO], P[j + 1], P[j + 2])


@njit(cache=True)
def _accumulator_pressure(x, P):
    return gas_spring_pressure(x[3], P[_P0], P[_VGAS], P[_NACC], P[_KPORT])


@njit(cache=True)
def _chamber_volume(y, P):
    """Pump chamber volume at rod displacement y (as :func:`chamber.chamber_volume`), [m^3]."""
    return P[_V0] - P[_AD] * (y - P[_YREF])


@njit(cache=True)
def _chamber_side(x, P):
    """(y, v) of the rod's end in the chamber, for the plant's states (one or two masses)."""
    if P[_ROD] == 4.0:
        return x[12], x[13]
    return x[10], x[11]


@njit(cache=True)
def _flows(x, P, q):
    """Valve flows V1..V4 into q (as :func:`circuit.valve_flows`)."""
    p_a = _accumulator_pressure(x, P)
    for k in range(4):
        q[k] = _valve_flow(k, x, p_a, P)


@njit(cache=True)
def _circuit_rates(x, y, v, cmds, load, P, out):
    """The circuit's dx/dt into out[:10] (as :func:`circuit.rhs`); y, v the rod's position
    and velocity.

    The flows are plain scalars: this runs ~10 times per substep, and an
    array for them would be a heap allocation each time.
    """
    p_a = _accumulator_pressure(x, P)
    q0 = _valve_flow(0, x, p_a, P)
    q1 = _valve_flow(1, x, p_a, P)
    q2 = _valve_flow(2, x, p_a, P)
    q3 = _valve_flow(3, x, p_a, P)
    pos, vel = x[4], x[5]
    vb = P[_VDB] + P[_AB] * pos
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - pos)
    vp = _chamber_volume(y, P)
    out[0] = _beta(x[0], P) / vp * (P[_AD] * v - q0 - q2)
    out[1] = _beta(x[1], P) / vb * (q0 - q1 - P[_AB] * vel)
    out[2] = _beta(x[2], P) / vs * (q2 - q3 + P[_AS] * vel)
    out[3] = q1 + q3
    out[4] = vel
    out[5] = piston_acceleration_of(x[1], x[2], pos, vel, load, P[_AB], P[_AS], P[_FRIC],
                                    P[_MASS], P[_STROKE], P[_KSTOP], P[_CSTOP])
    for k in range(4):
        tau = P[_VALVE + 5 * k + 4]
        out[6 + k] = (cmds[k] - x[6 + k]) / tau if tau > 0.0 else 0.0


@njit(cache=True)
def _rates(x, a, b, cmds, load, P, out):
    """dx/dt into out. Prescribed rod: a = y, b = v. Plant: a = the force F [N] (b unused)."""
    nrod = P[_ROD]
    if nrod == 0.0:
        _circuit_rates(x, a, b, cmds, load, P, out)
        return
    y, v = _chamber_side(x, P)
    _circuit_rates(x, y, v, cmds, load, P, out)
    two = nrod == 4.0
    d = rod_rates(x[10], x[11], x[12] if two else 0.0, x[13] if two else 0.0, a,
                  P[_AD] * x[0], P[_ROD + 1], P[_ROD + 2], P[_ROD + 3], P[_ROD + 4],
                  P[_ROD + 5], P[_ROD + 6])
    out[10], out[11] = d[0], d[1]
    if two:
        out[12], out[13] = d[2], d[3]


def _packed(params) -> np.ndarray:
    return params if isinstance(params, np.ndarray) else pack(params)


def flows(x, params) -> np.ndarray:
    """Valve flows V1..V4 at state x, compiled (as :func:`circuit.valve_flows`), [m^3/s].

    ``params``: a CircuitParameters or a :func:`pack`.
    """
    q = np.empty(4)
    _flows(np.asarray(x, dtype=float), _packed(params), q)
    return q


def accumulator_pressure(x, params) -> float:
    """Accumulator pressure at state x, compiled (as :func:`accumulator.accumulator_pressure`)."""
    return _accumulator_pressure(np.asarray(x, dtype=float), _packed(params))


def rates(x, a, b, commands, load, packed) -> np.ndarray:
    """Python entry to the compiled right-hand side (for tests): dx/dt.

    ``packed`` from :func:`pack`; with a rod, ``a`` is the force [N] and ``b``
    is ignored, else they are the rod's y [m] and v [m/s].
    """
    x = np.asarray(x, dtype=float)
    out = np.empty(x.size)
    _rates(x, float(a), float(b), np.asarray(commands, dtype=float), float(load), packed, out)
    return out


@njit(cache=True)
def _quadrature(x, y, f, P):
    """(p_P, Q_V1 - Q_V2, oil absorbed by compression per second) at x, with f = rates(x)."""
    p_a = _accumulator_pressure(x, P)
    vp = _chamber_volume(y, P)
    vb = P[_VDB] + P[_AB] * x[4]
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - x[4])
    absorbed = (vp / _beta(x[0], P) * f[0] + vb / _beta(x[1], P) * f[1]
                + vs / _beta(x[2], P) * f[2])
    return x[0], _valve_flow(0, x, p_a, P) - _valve_flow(1, x, p_a, P), absorbed


@njit(cache=True)
def _hermite(s, y0, v0, y1, v1, h):
    """Rod position at s into the step on the cubic through (y0, v0), (y1, v1)."""
    dy = y1 - y0
    r = s / h
    return (y0 + v0 * s + (3.0 * dy - h * (2.0 * v0 + v1)) * r * r
            + (h * (v0 + v1) - 2.0 * dy) * r * r * r)


@njit(cache=True)
def _hold_valves(x, cmds, P):
    """Valves without their own dynamics (ideal, dead time) take their command at once."""
    for k in range(4):
        if P[_VALVE + 5 * k + 4] == 0.0:
            x[6 + k] = cmds[k]
