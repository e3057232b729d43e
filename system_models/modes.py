"""Coupled modes of the transducer's mechanics with the hydraulic circuit, per valve stage.

The pump delivers f A_d dy (paper, eqs 39-41) only while the pump piston
follows the magnetostrictive force: below the lowest mode of the transducer's
mechanics coupled to the oil and the cylinder's load. This module linearises
the circuit about a state at rest and gives those modes.

The linear model
----------------
Degrees of freedom: the transducer's (one mass y, or the rod y_1 and the
output y_2 that carries the pump piston; :class:`~system_models.rod.RodParameters`)
and the cylinder's piston x. In each stage of Figure 2 (the valves open in
that stage, :func:`system_models.controller.valve_commands`) the open valves
join the volumes they connect into one node (their orifice resistance is left
out: at the study's flows it drops some kPa, against MPa); each node's
pressure rises with the volume the masses push into it,

    p_n = (x_n . q) / C_n,    C_n = sum V_i / beta_e + [V_g / (n_g p)],

where q = (y, x), x_n holds the areas by which each coordinate shrinks the
node (A_d for the pump piston; -A_B and +A_S for the cylinder's piston on its
big and small cavity), C_n the node's compliance (its oil at the effective
bulk modulus beta_e(p), eq of :func:`system_models.fluid.effective_bulk_modulus`,
and the accumulator's gas at its polytropic stiffness n_g p / V_g when the
node holds it; Merritt, *Hydraulic Control Systems*, 1967, sec. 2.5 and
ch. 5). The node's potential energy (x_n . q)^2 / (2 C_n) gives its stiffness
x_n x_n^T / C_n. With the mass matrix M (the transducer's masses and the
cylinder's), the stiffness K (the transducer's K, k_j and the nodes') and the
damping D (c, c_j and the cylinder's viscous friction):

* the undamped natural frequencies solve det(K - w^2 M) = 0 (Inman,
  *Engineering Vibration*, 4th ed., Pearson 2014, sec. 4.2);
* the damped poles are the eigenvalues of [[0, I], [-M^-1 K, -M^-1 D]]
  (sec. 4.6, non-proportional damping): a complex pair l gives a mode at
  |l| / (2 pi) with damping ratio -Re(l) / |l|; a real pole is an over-damped
  relaxation.

The cylinder's load force and the mean pressures shift the rest state but not
these modes; the end stops are left out (the piston is mid-stroke).

Examples
--------
With Table 2's mechanics on the realistic circuit (``presets.realistic_circuit``),
while the pump compresses into the big cavity the lowest mode is the transducer's
spring K carrying the cylinder's 1 kg, which the oil reflects onto the pump piston
as 1 kg (A_d / A_B)^2 = 16 kg; while it expands, the closed big cavity holds the
cylinder, which rings on that cavity's oil:

>>> from system_models import presets
>>> from system_models.rod import RodParameters
>>> m = circuit_modes(RodParameters(), presets.realistic_circuit())
>>> [round(s.natural_frequencies_Hz[0]) for s in m]
[165, 511]
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .accumulator import oil_volume_at
from .circuit import CircuitParameters, initial_state
from .controller import DIRECTIONS, valve_commands
from .cylinder import cavity_volumes
from .fluid import effective_bulk_modulus
from .rod import RodParameters

__all__ = ["StageModes", "circuit_modes", "stage_matrices", "modes_of", "piston_receptance",
           "pressure_step"]

#: The valves of Figure 2 as (first node, second node): V1 P-B, V2 B-A, V3 P-S, V4 S-A.
VALVE_NODES = (("P", "B"), ("B", "A"), ("P", "S"), ("S", "A"))


@dataclass(frozen=True)
class StageModes:
    """The coupled modes in one stage of the pump (valves of that stage open).

    Attributes
    ----------
    stage : str
        ``"compressing"`` or ``"expanding"``.
    natural_frequencies_Hz : tuple of float
        Undamped natural frequencies, ascending, [Hz].
    resonances : tuple of (float, float)
        Each under-damped pole pair as (|l| / (2 pi) [Hz], damping ratio [-]),
        ascending.
    relaxations_Hz : tuple of float
        Each over-damped (real) pole as |l| / (2 pi), ascending, [Hz].
    """

    stage: str
    natural_frequencies_Hz: tuple
    resonances: tuple
    relaxations_Hz: tuple

    def as_dict(self) -> dict:
        return {"stage": self.stage,
                "natural_frequencies_Hz": list(self.natural_frequencies_Hz),
                "resonances": [{"frequency_Hz": f, "damping_ratio": z}
                               for f, z in self.resonances],
                "relaxations_Hz": list(self.relaxations_Hz)}


def _nodes(commands) -> list[set]:
    """The volumes P, B, S, A joined by the open valves (``commands``: V1..V4 open)."""
    groups = [{"P"}, {"B"}, {"S"}, {"A"}]
    for is_open, (a, b) in zip(commands, VALVE_NODES):
        if is_open:
            ga = next(g for g in groups if a in g)
            gb = next(g for g in groups if b in g)
            if ga is not gb:
                ga |= gb
                groups.remove(gb)
    return groups


def stage_matrices(rod: RodParameters, circuit: CircuitParameters, commands,
                   pressure: float | None = None, piston_position: float | None = None):
    """M, K, D of the transducer and the cylinder in one valve state, SI.

    Parameters
    ----------
    rod : RodParameters
        The transducer's mechanics (one mass, or two with ``output_mass`` > 0).
    circuit : CircuitParameters
    commands : sequence of bool
        V1..V4 open.
    pressure, piston_position : float, optional
        The state linearised about, [Pa] and [m]; default
        :func:`system_models.circuit.initial_state`'s (1.5 times the
        accumulator's pre-charge, mid-stroke).

    Returns
    -------
    tuple of ndarray
        (M [kg], K [N/m], D [N s/m]), coordinates (y, x) or (y_1, y_2, x); the
        pump piston moves with the last transducer coordinate.
    """
    state = initial_state(circuit, pressure, piston_position)
    p, x = float(state[0]), float(state[4])
    cyl, acc = circuit.cylinder, circuit.accumulator
    two = rod.output_mass > 0.0
    n = 3 if two else 2
    out, cx = n - 2, n - 1  # the pump piston's coordinate, the cylinder's
    mass = np.zeros((n, n))
    stiff = np.zeros((n, n))
    damp = np.zeros((n, n))
    mass[0, 0], stiff[0, 0], damp[0, 0] = rod.mass, rod.stiffness, rod.damping
    if two:
        mass[1, 1] = rod.output_mass
        joint = np.array([[1.0, -1.0], [-1.0, 1.0]])
        stiff[:2, :2] += rod.joint_stiffness * joint
        damp[:2, :2] += rod.joint_damping * joint
    mass[cx, cx], damp[cx, cx] = cyl.mass, cyl.friction
    big, small = cavity_volumes(cyl, x)
    volume = {"P": circuit.chamber.dead_volume, "B": big, "S": small, "A": 0.0}
    area = {"P": (out, circuit.chamber.piston_area), "B": (cx, -cyl.big_area),
            "S": (cx, cyl.small_area), "A": None}
    beta = float(effective_bulk_modulus(circuit.fluid, p))
    gas = acc.gas_volume - oil_volume_at(acc, p)
    for node in _nodes(commands):
        compliance = sum(volume[v] for v in node) / beta
        if "A" in node:
            compliance += gas / (acc.polytropic_index * p)
        g = np.zeros(n)
        for v in node:
            if area[v] is not None:
                g[area[v][0]] += area[v][1]
        stiff += np.outer(g, g) / compliance
    return mass, stiff, damp


def modes_of(mass, stiffness, damping, stage: str = "") -> StageModes:
    """Undamped natural frequencies and damped poles of M q'' + D q' + K q = 0 (docstring)."""
    mass, stiffness, damping = (np.asarray(a, dtype=float) for a in (mass, stiffness, damping))
    root = 1.0 / np.sqrt(np.diag(mass))  # M is diagonal: M^-1/2 K M^-1/2 is symmetric
    w2 = np.linalg.eigvalsh(root[:, None] * stiffness * root[None, :])
    natural = tuple(float(math.sqrt(max(v, 0.0)) / (2.0 * math.pi)) for v in np.sort(w2))
    n = len(mass)
    inv = np.diag(root * root)
    system = np.block([[np.zeros((n, n)), np.eye(n)],
                       [-inv @ stiffness, -inv @ damping]])
    poles = np.linalg.eigvals(system)
    scale = max(1.0, float(np.max(np.abs(poles))))
    pairs, real = [], []
    for lam in poles:
        if abs(lam.imag) > 1e-9 * scale:
            if lam.imag > 0.0:
                pairs.append((float(abs(lam) / (2.0 * math.pi)), float(-lam.real / abs(lam))))
        else:
            real.append(float(abs(lam.real) / (2.0 * math.pi)))
    return StageModes(stage, natural, tuple(sorted(pairs)), tuple(sorted(real)))


def circuit_modes(rod: RodParameters, circuit: CircuitParameters, direction: str = "down",
                  pressure: float | None = None,
                  piston_position: float | None = None) -> tuple[StageModes, StageModes]:
    """The coupled modes while the pump compresses and while it expands (module docstring).

    Parameters
    ----------
    rod : RodParameters
    circuit : CircuitParameters
    direction : {"down", "up"}
        The commanded cylinder direction (which valves each stage opens).
    pressure, piston_position : float, optional
        As :func:`stage_matrices`.

    Returns
    -------
    tuple of StageModes
        (compressing, expanding).
    """
    _check_direction(direction)
    return tuple(modes_of(*stage_matrices(rod, circuit, valve_commands(direction, c), pressure,
                                          piston_position), stage)
                 for c, stage in ((True, "compressing"), (False, "expanding")))


def piston_receptance(rod: RodParameters, circuit: CircuitParameters, frequency: float,
                      direction: str = "down", pressure: float | None = None,
                      piston_position: float | None = None) -> tuple[complex, complex]:
    """The pump piston's displacement per unit magnetostrictive force on the rod, [m/N].

    Y / F = e_out^T (K - w^2 M + j w D)^-1 e_rod at w = 2 pi ``frequency`` (Inman,
    sec. 5.2, the receptance of a damped system), in each stage of the pump
    (:func:`stage_matrices`, the force on the rod's coordinate, the piston on the
    last transducer coordinate). Its phase is the piston's lag behind the force;
    its modulus times K is the stroke against the free rod's static one.

    Returns
    -------
    tuple of complex
        (compressing, expanding).
    """
    _check_direction(direction)
    w = 2.0 * math.pi * float(frequency)
    out = []
    for compressing in (True, False):
        mass, stiff, damp = stage_matrices(rod, circuit, valve_commands(direction, compressing),
                                           pressure, piston_position)
        force = np.zeros(len(mass))
        force[0] = 1.0
        y = np.linalg.solve(stiff - w * w * mass + 1j * w * damp, force)
        out.append(complex(y[len(mass) - 2]))
    return tuple(out)


def _check_direction(direction):
    if direction not in DIRECTIONS:
        from gmt.errors import ParameterError
        raise ParameterError(f"direction = {direction!r} is not one of {DIRECTIONS}")


def pressure_step(circuit: CircuitParameters, load_force: float = 0.0, direction: str = "down",
                  pressure: float | None = None) -> float:
    """The pump chamber's pressure step at a valve switch, at rest, [Pa].

    In each stage the chamber joins the accumulator, or a cylinder cavity whose
    pressure the piston's static balance p_B A_B - p_S A_S = F_load sets with
    the other cavity at the accumulator's pressure p_A (the load opposing
    "down"; Merritt, *Hydraulic Control Systems*, 1967, ch. 5). The step is
    the compressing stage's chamber pressure minus the expanding stage's: with
    the differential cylinder and no load, p_A (A_S - A_B) / A_B, the rebound
    the ``differential`` preset shows (:mod:`system_models.presets`).

    Parameters
    ----------
    circuit : CircuitParameters
    load_force : float
        F_load on the cylinder, [N].
    direction : {"down", "up"}
    pressure : float, optional
        p_A, [Pa]; default :func:`system_models.circuit.initial_state`'s.
    """
    _check_direction(direction)
    p_a = float(initial_state(circuit, pressure)[0])
    cyl = circuit.cylinder
    chamber = {"B": (p_a * cyl.small_area + load_force) / cyl.big_area,
               "S": (p_a * cyl.big_area - load_force) / cyl.small_area}
    out = []
    for compressing in (True, False):
        node = next(g for g in _nodes(valve_commands(direction, compressing)) if "P" in g)
        out.append(p_a if "A" in node else chamber["B" if "B" in node else "S"])
    return out[0] - out[1]
