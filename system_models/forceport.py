"""The force port: cut the co-simulation where the physics is one-way (the default coupling).

In the paper's model nothing flows back from the rod to the magnetics: the
current, the compensator, the field, the magnetisation and the
magnetostrictive force F = A_r E^H lambda (eqs 1-26, 28, 31-37) do not depend
on the rod's motion. The stiff part of the system is the rod's mass-spring-
damper (eq 27) against the pump chamber's oil, a ~30 kHz mode (oil stiffness
beta A_d^2 / V ~ 9e8 N/m against K = 2e7 N/m). So the transducer hands over
F, and the plant integrates eq 27 *together with* the chamber, implicitly
(TR-BDF2: L-stable, second order), with m, c, K read from the transducer
(the FMU's calculated parameters: one source of truth, and a mechanics
variant acts in the plant). The transducer is stepped once per communication
step, before the plant and without save, restore or iteration, and the plant
integrates a window of steps in one compiled call (:func:`kernel.plant_run`).

The force over a step follows how it is produced: the digital compensator's
DAC holds its current between samples, so its force is piecewise constant
and held over each step (communication points fall on its samples); the
uncompensated amplifier follows u continuously, so its force is smooth and
taken linear between its values at the step's ends (the transducer is
stepped one step ahead of the plant to have the end value). With the
time-domain magnetics (:mod:`gmt.timedomain`) the force follows the flux
density, which cannot jump, so it is taken linear in both modes.
"""
from __future__ import annotations

import math

import numpy as np

import gmt

from . import kernel
from .implicit import integration_failure
from .plant import PlantParameters
from .plant import initial_state as plant_start
from .record import circuit_columns, columns, stack_first
from .rod import RodParameters


def run_force_port(backend, control, circuit, settings, drive, controller, grid, writer,
                   progress, n_steps, initial=None, substeps=None):
    """The force port's run (module docstring): the transducer one step ahead, the plant
    a window at a time, rows into ``writer`` at ``grid``'s points.

    ``initial``: the plant's state to start from (a previous run's return value, to
    continue it: the closed-loop position study runs one pump period at a time); None
    starts at rest. ``substeps``: the plant's substep control (:func:`kernel.new_control`)
    to carry on with, updated in place (with ``initial``, the continued run steps on as
    one run would, not from a short substep); None starts short. Returns the plant's
    state at the run's end."""
    rod = RodParameters.of(backend.mechanics())
    plant = PlantParameters(circuit, rod)
    packed = plant.packed
    n = kernel.state_size(packed)
    out = 10 if rod.size == 2 else 12  # index of the chamber side's y in the state
    z = (plant_start(plant, backend.rod_state()[0]) if initial is None
         else np.array(initial, dtype=float))
    # a continuous drive, or the time-domain magnetics: the force linear over a step
    linear = not drive.compensated or drive.continuous_force
    volume = compressed = 0.0
    if substeps is None:  # the plant's substep length, carried across windows
        substeps = kernel.new_control()
    valves = 0 if settings.direction == "down" else 2  # V1 or V3: open while compressing
    first = circuit_columns(z[:10], z[out:out + 2], packed)
    # the transducer's step from t = 0: (t, h, u, current, force)
    times = grid.points(0.0, 1)
    u0 = control(0.0)
    # the control the transducer holds over a step: u at its start, except for the
    # time-domain magnetics driven continuously, whose B integrates the held current:
    # u at mid-step then (a held u(t_k) would lag the drive by half a step)
    mid = 0.5 if drive.continuous_force and not drive.compensated else 0.0
    # the transducer's own sensors (flux density, the free rod's displacement): None
    # where the backend has none (NaN in the record)
    sensors = getattr(backend, "sensors", None)
    y_start = backend.rod_state()[0] if sensors else math.nan
    first_step = backend.drive_step(0.0, times[1], control(mid * times[1]) if mid else u0)
    flux0, y_end = _read(sensors, y_start)
    # (u, current, force, B at the step's start; the free rod at its start and its end)
    pending = (u0, *first_step, flux0, y_start, y_end)
    t = 0.0
    previous = None  # the last row's valve phase (the final row repeats it)
    while grid.before_end(t):
        # the window's communication points, and one more for the transducer's look-ahead
        points = grid.points(t, settings.window + 1)
        m = min(settings.window, points.size - 1)
        starts, steps = points[:m], np.diff(points[:m + 1])
        u, current, force, flux, y_free = _drive_window(backend, control, points, m, mid,
                                                        sensors, pending)
        pending = (u[m], current[m], force[m], flux[m], y_free[m], y_free[m + 1])
        commands = controller.commands_over(starts)
        forces = np.column_stack((force[:m], force[1:] if linear else force[:m]))
        status, done, rows = kernel.plant_run(
            z, steps, forces, commands, settings.load_force, packed,
            max_substep=settings.hydraulic_step, control=substeps)
        if status != kernel.OK:
            at = starts[done]
            if status == kernel.CHAMBER_EMPTIED:
                raise gmt.ParameterError(f"the rod empties the pump chamber at t = {at:g} s")
            raise integration_failure(rows[done - 1] if done else z, at, steps[done])
        cols, vol_end, comp_end, first = _window_columns(
            rows, n, out, first, volume, compressed, starts,
            dict(control=u[:m], current=current[:m], force=force[:m], flux_density=flux[:m],
                 free_displacement=y_free[:m], compressing=controller.phases_over(starts),
                 valves_compressing=commands[:, valves]))
        writer.add(cols, m)
        z = rows[-1, :n].copy()
        volume, compressed = vol_end[-1], comp_end[-1]
        previous = commands[-1, valves]
        t = float(points[m])
        controller.forget_before(t)
        if progress is not None:
            progress(min(int(round(t / settings.step)), n_steps), n_steps)
    final = dict(first, time=t, control=control(t), current=pending[1], force=pending[2],
                 flux_density=pending[3], free_displacement=pending[4],
                 compressing=float(controller.phase_at(t)),
                 valves_compressing=previous if previous is not None else 0.0,
                 volume_into_big=volume, compression_volume=compressed, iterations=0.0)
    writer.add(final, 1)
    return z


def _drive_window(backend, control, points, m, mid, sensors, pending):
    """The transducer over a window's ``m`` steps, one step ahead of the plant: the control
    u, current, force, flux density at each step's start (index 0 from ``pending``, the
    look-ahead of the window before) and the free rod's displacement (``y_free[k + 1]``:
    after step k). The run's last step holds its force."""
    u = np.empty(m + 1)
    current, force = np.empty(m + 1), np.empty(m + 1)
    flux, y_free = np.empty(m + 1), np.empty(m + 2)
    u[0], current[0], force[0], flux[0], y_free[0], y_free[1] = pending
    for k in range(1, m + 1):
        if k < points.size - 1:
            u[k] = control(points[k])
            h = points[k + 1] - points[k]
            current[k], force[k] = backend.drive_step(
                points[k], h, control(points[k] + mid * h) if mid else u[k])
            flux[k], y_free[k + 1] = _read(sensors, y_free[k])
        else:  # the run's end: the last step holds its force
            u[k], current[k], force[k] = u[k - 1], current[k - 1], force[k - 1]
            flux[k], y_free[k + 1] = flux[k - 1], y_free[k]
    return u, current, force, flux, y_free


def _window_columns(rows, n, out, first, volume, compressed, starts, drive):
    """The record's columns of a window from the plant's ``rows`` (row k: the state at the
    start of step k, the end of step k - 1) and the transducer's ``drive`` columns; with the
    running pumped volumes at the window's step ends, and the columns of its last end (the
    next window's first row)."""
    ends_x, ends_q, ends_pa = rows[:, :n], rows[:, n:n + 4], rows[:, n + 4]
    cols = stack_first(first, columns(ends_x[:-1], ends_x[:-1, out:out + 2],
                                        ends_q[:-1], ends_pa[:-1]))
    vol_end, comp_end = volume + rows[:, n + 5], compressed + rows[:, n + 6]
    cols.update({
        "time": starts, **drive,
        "volume_into_big": np.concatenate(([volume], vol_end[:-1])),
        "compression_volume": np.concatenate(([compressed], comp_end[:-1])),
        "iterations": 1.0})
    last = columns(ends_x[-1:], ends_x[-1:, out:out + 2], ends_q[-1:], ends_pa[-1:])
    return cols, vol_end, comp_end, last


def _read(sensors, y_before) -> tuple:
    """(B over the step just taken, the free rod's displacement at its end) from the
    backend's ``sensors``; NaN for B and ``y_before`` held where it has none."""
    if sensors is None:
        return math.nan, y_before
    return tuple(sensors())
