"""The hydraulic plant of the force port: the circuit with the transducer's rod in it.

Boundary (what a plant FMU would expose): the state; over each step the
magnetostrictive force F at its start and end (linear in between, equal for
a held force) and the four valve commands; the load on the cylinder. Out:
the state at the step's end, the volume into the big cavity and the oil
taken up by compression (for the flow check of eqs 39-41 and the volume
balance). The transducer needs nothing back (the force port of
:mod:`system_models.forceport`).

State (SI): the circuit's ten (:data:`system_models.circuit.STATE_NAMES`),
then the rod's (:mod:`system_models.rod`): y, v, or y_1, v_1, y_2, v_2 with
two masses. The pump chamber moves with the rod's end (y, or y_2).

:func:`rhs` is the readable right-hand side (the circuit's
:func:`~system_models.circuit.rhs` plus :func:`~system_models.rod.rod_rates`);
:func:`run` advances it with the compiled TR-BDF2 of
:mod:`system_models.kernel`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .circuit import CircuitInputs, CircuitParameters, STATE_NAMES, initial_state as _circuit_start
from .circuit import rhs as circuit_rhs
from .rod import RodParameters, rod_rates


@dataclass(frozen=True)
class PlantParameters:
    """The circuit and the rod it carries."""

    circuit: CircuitParameters = field(default_factory=CircuitParameters)
    rod: RodParameters = field(default_factory=RodParameters)

    @property
    def state_names(self) -> tuple:
        rod = ("rod_displacement", "rod_velocity")
        if self.rod.size == 4:
            rod = ("rod_displacement", "rod_velocity", "output_displacement", "output_velocity")
        return STATE_NAMES + rod

    @property
    def packed(self) -> np.ndarray:
        """The kernel's parameter array (cached)."""
        from . import kernel
        return kernel.pack(self.circuit, self.rod)


def chamber_side(z, plant: PlantParameters) -> tuple[float, float]:
    """(y, v) of the rod's end in the pump chamber: the rod's, or the output mass's."""
    return (z[12], z[13]) if plant.rod.size == 4 else (z[10], z[11])


def initial_state(plant: PlantParameters, rod_displacement: float, **circuit) -> np.ndarray:
    """The circuit at rest (:func:`system_models.circuit.initial_state`, ``circuit``
    its keyword arguments) and the rod at rest under the chamber's force A_d p_P there,
    ``rod_displacement`` [m] being the transducer's rest without it.

    A rod started at its free rest would spring back at the first step by A_d p_P / K
    (96 um at the realistic circuit's 1.5 MPa: :meth:`RodParameters.loaded_state`)."""
    x = _circuit_start(plant.circuit, **circuit)
    force = plant.circuit.chamber.piston_area * x[0]
    return np.concatenate((x, plant.rod.loaded_state(rod_displacement, force)))


def rhs(t, z, force, commands, load, plant: PlantParameters) -> np.ndarray:
    """dz/dt of the plant (readable; the kernel compiles the same).

    Parameters
    ----------
    t : float
        Time, [s] (the plant is time-invariant; kept for solve_ivp).
    z : array
        State (module docstring).
    force : float
        Magnetostrictive force on the rod, [N].
    commands : sequence of 4 floats
        Valve commands.
    load : float
        Load on the cylinder, [N].
    """
    y, v = chamber_side(z, plant)
    dx = circuit_rhs(t, z[:10], CircuitInputs(y, v, tuple(commands), load), plant.circuit)
    r = plant.rod
    two = r.size == 4
    rates = rod_rates(z[10], z[11], z[12] if two else 0.0, z[13] if two else 0.0, force,
                      plant.circuit.chamber.piston_area * z[0], r.mass, r.damping,
                      r.stiffness, r.output_mass, r.joint_stiffness, r.joint_damping)
    return np.concatenate((dx, rates[:r.size]))


class PlantRun(NamedTuple):
    """What :func:`run` returns."""

    status: int  #: kernel.OK, kernel.NEWTON_FAILED or kernel.CHAMBER_EMPTIED
    done: int  #: steps completed
    states: np.ndarray  #: (done, n) the state at the end of each completed step
    flows: np.ndarray  #: (done, 4) valve flows V1..V4 there, [m^3/s]
    accumulator_pressure: np.ndarray  #: (done,) [Pa]
    volume_into_big: np.ndarray  #: (done,) since the start of the call, [m^3]
    compression_volume: np.ndarray  #: (done,) oil taken up by compression since then, [m^3]


def run(z0, steps, forces, commands, load, plant: PlantParameters, max_substep=None,
        control=None) -> PlantRun:
    """Advance the plant over consecutive steps (one compiled call, :func:`kernel.plant_run`).

    Parameters
    ----------
    z0 : array
        State at the start.
    steps : sequence of float
        Step lengths, [s].
    forces : (W, 2) array
        Force at each step's start and end, [N] (linear in between).
    commands : (W, 4) array
        Valve commands over each step (1 open, 0 closed); valves without
        their own dynamics take them at the step's start.
    load : float
        Load on the cylinder, [N].
    max_substep : float, optional
        Longest TR-BDF2 substep, [s] (None: the step); after a valve action
        the substeps start at 1 us and grow fourfold.
    control : array, optional
        :func:`kernel.new_control`, carried from call to call of one run.
    """
    from . import kernel
    status, done, rows = kernel.plant_run(z0, steps, forces, commands, load, plant.packed,
                                          max_substep, control)
    n = len(z0)
    return PlantRun(status, done, rows[:, :n], rows[:, n:n + 4], rows[:, n + 4],
                    rows[:, n + 5], rows[:, n + 6])
