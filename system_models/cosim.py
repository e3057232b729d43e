"""Co-simulation of the transducer FMU with the hydraulic plant: the master.

The master steps the transducer (the FMU through fmpy, or :class:`gmt.Transducer`
in-process: :mod:`system_models.transducers`) and the hydraulics
(:mod:`system_models.plant`, :mod:`system_models.kernel`) over communication
steps, with the valves switched by a sampled controller
(:class:`~system_models.controller.SampledValveController`), and records one
row a communication point (:mod:`system_models.record`). :func:`cosimulate`
runs one co-simulation with its :class:`CosimSettings`; two couplings:

* the **force port** (default, :mod:`system_models.forceport`): cut where the
  physics is one-way. The transducer hands over its magnetostrictive force
  (nothing in eqs 1-26, 28, 31-37 depends on the rod's motion) and the plant
  integrates the rod's eq 27 together with the pump chamber, implicitly: one
  transducer step a communication step, no save, restore or iteration;
* the **displacement port** (``coupling="displacement"``,
  :mod:`system_models.displacementport`): the cross-check. The transducer
  integrates its own rod with the chamber's force held; the force is iterated
  through the FMU's state save/restore until it equals the chamber's force at
  the step's end.

Both couplings give the transducer the same control signal at its samples:
u(t_k) (the digital compensator samples it there); the continuous
uncompensated drive follows u (the force port interpolates its force over a
step, the displacement port holds u(t_k + h/2)).

The names a co-simulation needs are importable from here: the transducers
(:class:`DirectTransducer`, :class:`FmuTransducer`), the record's fields
(:data:`RESULT_FIELDS`, :data:`RESULT_UNITS`) and :class:`CouplingError`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

import gmt

from .circuit import CircuitParameters
from .controller import SampledValveController, dead_times
from .defaults import (DEFAULT_COUPLING, DEFAULT_STEP, HYDRAULIC_STEP, MAXIMUM_DURATION,
                       VALVE_CONTROLLER_PERIOD)
from .displacementport import CouplingError, run_displacement_port
from .forceport import run_force_port
from .record import RESULT_FIELDS, RESULT_UNITS, Grid, Writer
from .transducers import (FMU_MECHANICS, DirectTransducer, Drive, FmuTransducer,
                          TransducerBackend, fmi2_functions)

__all__ = ["COUPLINGS", "CosimSettings", "cosimulate", "volume_balance", "CouplingError",
           "DirectTransducer", "FmuTransducer", "TransducerBackend", "Drive", "FMU_MECHANICS",
           "fmi2_functions", "RESULT_FIELDS", "RESULT_UNITS"]

COUPLINGS = ("force", "displacement")


@dataclass(frozen=True)
class CosimSettings:
    """Settings of one co-simulation run.

    Attributes
    ----------
    duration : float
        Simulated time, [s].
    step : float
        Communication step h, [s] (default :data:`DEFAULT_STEP`). Steps are
        also cut at every valve action and, with a sampled compensator, at
        its samples.
    coupling : {"force", "displacement"}
        The force port (default) or the displacement port (module docstring).
    direction : {"down", "up"}
        Commanded cylinder direction (Figure 2).
    load_force : float
        External load on the cylinder, opposing "down", [N].
    controller_period : float
        Sample period of the valve controller, [s]
        (:data:`VALVE_CONTROLLER_PERIOD`); the valves act after their exact
        dead times, at communication points.
    hydraulic_step : float or None
        Longest substep of the hydraulic integrator, [s] (default
        :data:`~system_models.defaults.HYDRAULIC_STEP`). Force port: after
        every valve action the substeps start at 1 us and grow fourfold up to
        this (:func:`kernel.plant_run`); None: the communication step.
        Displacement port: ceil(h / hydraulic_step) equal substeps a step
        (None: one).
    window : int
        Force port: communication steps the plant integrates per compiled
        call (records and observers still see every step).
    force_tolerance : float
        Displacement port: interface residual |F - A_d p_P(t + h)| accepted,
        [N]; 1e-4 N is 0.08 Pa of chamber pressure, above the hydraulics'
        Newton noise.
    max_iterations : int
        Displacement port: secant iterations per step before giving up.
    """

    duration: float = 0.1
    step: float = DEFAULT_STEP
    coupling: str = DEFAULT_COUPLING
    direction: str = "down"
    load_force: float = 0.0
    controller_period: float = VALVE_CONTROLLER_PERIOD
    hydraulic_step: float | None = HYDRAULIC_STEP
    window: int = 64
    force_tolerance: float = 1e-4
    max_iterations: int = 25

    def __post_init__(self):
        gmt.errors.check_range("duration", self.duration, 0.0, MAXIMUM_DURATION, unit="s",
                               high_open=False)
        gmt.errors.check_range("step", self.step, 0.0, 1.0, unit="s")
        gmt.errors.check_range("controller_period", self.controller_period, 0.0, 1.0, unit="s")
        if self.hydraulic_step is not None:
            gmt.errors.check_range("hydraulic_step", self.hydraulic_step, 0.0, 1.0, unit="s")
        gmt.errors.check_range("force_tolerance", self.force_tolerance, 0.0, 1e6, unit="N")
        gmt.errors.check_range("window", self.window, 1, 1e6, low_open=False)
        if self.coupling not in COUPLINGS:
            raise gmt.ParameterError(f"coupling = {self.coupling!r} is not one of {COUPLINGS}")
        if self.direction not in ("down", "up"):
            raise gmt.ParameterError(f"direction = {self.direction!r} is not one of ('down', 'up')")


def cosimulate(backend: TransducerBackend, control: Callable[[float], float],
               circuit: CircuitParameters, settings: CosimSettings,
               progress: Callable[[int, int], None] | None = None,
               observer: Callable[[np.void], None] | None = None,
               keep_record: bool = True) -> np.ndarray:
    """Run one co-simulation.

    Parameters
    ----------
    backend : TransducerBackend
        The transducer (FMU or direct), initialised and at rest.
    control : callable
        u(t), [V] (vectorised over an array of times if it can be: the valve
        controller samples it in blocks).
    circuit : CircuitParameters
    settings : CosimSettings
    progress : callable, optional
        Called as progress(steps_done, n_steps), n_steps = duration / step.
    observer : callable, optional
        Called with each finished record (a row of the array below), in
        time order; e.g. :class:`system_models.flowcheck.RunningFlow`.
    keep_record : bool
        False keeps no record (memory stays flat however long the run; the
        observer sees every row); the result is then the final row alone.

    Returns
    -------
    numpy structured array
        One record per communication point t_k (fields :data:`RESULT_FIELDS`):
        the state at t_k and what acts over [t_k, t_k+1): the control signal
        given the transducer, the coil current, the magnetostrictive force
        (force port) or the chamber force held on the rod (displacement
        port), the controller's phase and the valves' phase (after their
        dead times); the last record carries the final state.
        ``volume_into_big`` is the net volume that has entered the big
        cavity through V1 and V2 since t = 0, and ``compression_volume`` the
        oil volume taken up by compression in the chamber and cavities since
        t = 0, [m^3] (see :func:`volume_balance`). ``rod_displacement`` is
        the rod's end in the pump chamber (the output mass with two masses).
    """
    n_steps = int(round(settings.duration / settings.step))
    end = n_steps * settings.step
    drive = backend.drive()
    controller = SampledValveController(settings.direction, control,
                                        settings.controller_period, dead_times(circuit.valves))
    grid = Grid(settings.step, end, drive.sample_period if drive.compensated else 0.0,
                controller)
    writer = Writer(n_steps, keep_record, observer)
    run = run_force_port if settings.coupling == "force" else run_displacement_port
    run(backend, control, circuit, settings, drive, controller, grid, writer, progress,
        n_steps)
    return writer.result()


def volume_balance(record, circuit: CircuitParameters) -> tuple[float, float]:
    """Oil volume bookkeeping of a run: (imbalance, pumped volume), [m^3].

    Continuity over the whole circuit: the volume the rod and piston sweep out
    of the chamber and cavities, plus the oil stored in the accumulator, plus
    the oil absorbed by compression, sums to zero. The imbalance is that sum
    at the end of the run (round-off when every flow leaving one volume enters
    another); the pumped volume, A_d times the rod's total travel, gives its
    scale.
    """
    from .accumulator import oil_volume_at
    first, last = record[0], record[-1]
    cyl, ch = circuit.cylinder, circuit.chamber
    dx = last["piston_position"] - first["piston_position"]
    geometric = (-ch.piston_area * (last["rod_displacement"] - first["rod_displacement"])
                 + cyl.big_area * dx - cyl.small_area * dx
                 + oil_volume_at(circuit.accumulator, last["p_accumulator"])
                 - oil_volume_at(circuit.accumulator, first["p_accumulator"]))
    pumped = ch.piston_area * float(np.sum(np.abs(np.diff(record["rod_displacement"]))))
    return float(geometric + last["compression_volume"]), pumped
