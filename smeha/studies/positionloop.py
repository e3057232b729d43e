"""The closed-loop co-simulation of the cylinder's position: one pump period at a time.

A position controller sampled once a pump period T = 1/f decides, at each period's
start, the **direction** of the cylinder (Figure 2: stages 1-2 "down", 3-4 "up") and
the **drive amplitude** for that period. The period then runs as the flow study's
co-simulation does (:func:`system_models.forceport.run_force_port`: the transducer
through its FMU or in-process, the plant integrating the rod and the circuit, the valve
controller switching at the drive's extremes after the valves' dead times), continued
from the previous period's state: the transducer keeps its state and clock, the plant
its state (:func:`run_force_port`'s ``initial``), the valves the commands in force
(``SampledValveController``'s ``in_force``).

Each period starts at the drive's minimum, where the chamber is at its largest and
about to compress, so a new direction starts with a compression and a new amplitude
joins the old one without a jump of the compensated demand:

* compensated: u = a (1 - cos(w t')), t' from the period's start: the demand
  y_d = 10 um/V u (Figure 9) spans 20 a um from the stroke's bottom; u and its slope are
  0 at each period's start whatever a is;
* uncompensated: i = K_a u, u = -A cos(w t'): the current amplitude A [A] (the amplifier's
  1 A/V); a new A steps the current at the period's start by the change of A.

The load on the cylinder is held over a period (a load step falls on a period's start).
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from system_models import kernel
from system_models.controller import SampledValveController, dead_times
from system_models.cosim import CosimSettings
from system_models.forceport import run_force_port
from system_models.plant import PlantParameters
from system_models.plant import initial_state as plant_start
from system_models.record import Grid, Writer
from system_models.rod import RodParameters

from .flow import Sinusoid

__all__ = ["Decision", "LoopRecord", "period_signal", "run_loop", "TIME_TOLERANCE"]

#: Two instants closer than this are the same, [s]: a communication point's time against a
#: period's start or a scenario's event, both sums of steps whose round-off is ~1e-16 s.
TIME_TOLERANCE = 1e-12


@dataclass(frozen=True)
class Decision:
    """What the position controller commands for one pump period."""

    direction: str  #: "down" (x grows, Figure 2 stages 1-2) or "up" (stages 3-4)
    amplitude: float  #: a [V] compensated, A [A] uncompensated, >= 0
    saturated: bool = False  #: the controller asked for more than its amplitude limit


def period_signal(mode: str, amplitude: float, frequency: float) -> Sinusoid:
    """u(t') over one period, t' from its start at the drive's minimum (module docstring)."""
    if mode == "compensated":
        return Sinusoid(amplitude, -amplitude, frequency)
    return Sinusoid(0.0, -amplitude, frequency)


class _Shifted:
    """The transducer seen from one period: the period's times plus its start."""

    def __init__(self, backend):
        self.inner, self.start = backend, 0.0

    def drive_step(self, time, step, control):
        return self.inner.drive_step(self.start + time, step, control)

    def rod_state(self):
        return self.inner.rod_state()

    def mechanics(self):
        return self.inner.mechanics()

    def drive(self):
        return self.inner.drive()


@dataclass
class LoopRecord:
    """A closed-loop run: the co-simulation's rows and one row of decisions a period.

    ``rows``: :data:`system_models.cosim.RESULT_FIELDS` at every communication point
    (absolute time), plus ``direction`` (+1 down, -1 up), ``amplitude`` and ``load`` of
    the period. ``periods``: a structured array, one row a period: ``time`` at its
    start, ``position`` and ``command`` there [m], ``direction``, ``amplitude``,
    ``saturated`` (the controller at its limit), ``load`` [N], ``outside`` (1: the coil
    current outside the model's design point at the period's end,
    :class:`gmt.design_point.DriveMonitor`). ``wall_s``: the
    co-simulation's wall time, controller included.
    """

    rows: np.ndarray
    periods: np.ndarray
    wall_s: float
    frequency: float
    cpu_s: float = float("nan")  #: the process's CPU time over the run (FMU in-process)


PERIOD_FIELDS = ("time", "position", "command", "direction", "amplitude", "saturated", "load",
                 "outside")


def run_loop(backend, mode: str, circuit, frequency: float, periods: int,
             decide: Callable[[int, float, float], Decision],
             command: Callable[[float], float] = lambda t: 0.0,
             load: Callable[[float], float] = lambda t: 0.0,
             settings: CosimSettings | None = None) -> LoopRecord:
    """Run ``periods`` pump periods in closed loop.

    Parameters
    ----------
    backend : system_models.cosim.TransducerBackend
        The transducer, initialised and at rest (its drive mode must be ``mode``).
    mode : {"compensated", "uncompensated"}
    circuit : system_models.circuit.CircuitParameters
    frequency : float
        Pump frequency f, [Hz].
    periods : int
        Number of pump periods to run.
    decide : callable
        decide(k, t, x) -> :class:`Decision` at period k's start t [s] with the
        piston's position x [m] there.
    command : callable
        The position command r(t) [m] (recorded, for the report).
    load : callable
        The load on the cylinder at a period's start t, [N] (opposing "down").
    settings : CosimSettings, optional
        Step, hydraulic substep, valve controller period (duration, direction and load
        are set per period).
    """
    settings = settings or CosimSettings()
    period = 1.0 / frequency
    drive = backend.drive()
    sample = drive.sample_period if drive.compensated else 0.0
    shifted = _Shifted(backend)
    deads = dead_times(circuit.valves)
    plant = PlantParameters(circuit, RodParameters.of(backend.mechanics()))
    z = plant_start(plant, backend.rod_state()[0])  # at rest, the piston mid-stroke
    in_force = None
    substeps = kernel.new_control()  # the plant's substeps run on across the periods
    blocks, table = [], np.zeros(periods, dtype=[(n, float) for n in PERIOD_FIELDS])
    x = float(z[4])  # the piston's position (system_models.circuit.STATE_NAMES)
    watch = hasattr(backend, "outside_design_point")
    wall, cpu = _time.perf_counter(), _time.process_time()
    for k in range(periods):
        t0 = k * period
        shifted.start = t0
        decision = decide(k, t0, x)
        force = float(load(t0))
        table[k] = (t0, x, command(t0), 1.0 if decision.direction == "down" else -1.0,
                    decision.amplitude, float(decision.saturated), force, 0.0)
        control = period_signal(mode, decision.amplitude, frequency)
        chunk = CosimSettings(duration=period, step=settings.step, coupling="force",
                              direction=decision.direction, load_force=force,
                              controller_period=settings.controller_period,
                              hydraulic_step=settings.hydraulic_step, window=settings.window)
        controller = SampledValveController(decision.direction, control,
                                            settings.controller_period, deads, in_force)
        grid = Grid(settings.step, period, sample, controller)
        n_steps = int(math.ceil(period / settings.step))
        writer = Writer(n_steps + 8, True, None)
        z = run_force_port(shifted, control, circuit, chunk, drive, controller, grid, writer,
                           None, n_steps, initial=z, substeps=substeps)
        rows = writer.result()
        in_force = controller.commands_at(period)
        rows["time"] += t0
        extra = np.empty(len(rows), dtype=[("direction", float), ("amplitude", float),
                                            ("load", float)])
        extra["direction"], extra["amplitude"], extra["load"] = (table[k]["direction"],
                                                                 decision.amplitude, force)
        keep = slice(None) if k == periods - 1 else slice(None, -1)  # the end is the next start
        blocks.append((rows[keep], extra[keep]))
        x = float(rows["piston_position"][-1])
        if watch:
            table[k]["outside"] = float(backend.outside_design_point())
    wall, cpu = _time.perf_counter() - wall, _time.process_time() - cpu
    return LoopRecord(_merged(blocks), table, wall, frequency, cpu)


def _merged(blocks) -> np.ndarray:
    """The periods' rows, each beside its decision's fields, as one structured array."""
    rows = np.concatenate([b[0] for b in blocks])
    extra = np.concatenate([b[1] for b in blocks])
    merged = np.zeros(len(rows), dtype=rows.dtype.descr + extra.dtype.descr)
    for name in rows.dtype.names:
        merged[name] = rows[name]
    for name in extra.dtype.names:
        merged[name] = extra[name]
    return merged
