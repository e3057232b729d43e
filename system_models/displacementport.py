"""The displacement port (``coupling="displacement"``): the force port's cross-check.

The transducer integrates its own rod with the chamber's force A_d p_P held
over the step as its input; the plant takes the rod's motion back. Exchanging
force and motion once a step (Jacobi or Gauss-Seidel) is only conditionally
stable across the stiff rod-oil mode, so the master couples them implicitly
through the FMU's state save/restore (:func:`solve_interface`):

1. save the FMU state at t;
2. guess the held force F (the end pressure of the last step times A_d);
3. restore, step the FMU over [t, t + h] with F held, read y(t + h), v(t + h);
4. integrate the circuit over the step along the cubic Hermite rod
   trajectory through (y, v) at both ends (:func:`kernel.circuit_step`);
5. the residual r(F) = F - A_d p_P(t + h): the held force equals the
   chamber's force at the end of the step -- the implicit (backward) choice,
   which damps the rod-oil mode however stiff the oil;
6. quasi-Newton (secant) on r, its slope carried from step to step, until
   |r| is below ``force_tolerance``; the last FMU step taken is the one kept.

It pays two FMU steps, a save and a restore, and ~2.5 hydraulic
integrations a step, and its held force is a first-order error in h; it is
kept as the independent check of the force port
(:mod:`system_models.forceport`; the two agree on the flow,
``tests/test_cosim.py``).

The continuous uncompensated drive holds u(t_k + h/2) over a step, the
value that makes a held input lag it by no half step; the digital
compensator samples u(t_k).
"""
from __future__ import annotations

import math

import gmt
from gmt.errors import RunError

from . import kernel
from .circuit import initial_state
from .implicit import integration_failure
from .record import circuit_columns
from .rod import RodParameters


class CouplingError(RunError):
    """The interface iteration did not converge in a step."""


def _substeps(h, settings) -> int:
    """Equal substeps of a step of h: ceil(h / hydraulic_step), one without it."""
    if settings.hydraulic_step is None:
        return 1
    return max(1, math.ceil(h / settings.hydraulic_step - 1e-9))


def _valve_phase(commands, direction):
    """The phase the valves act on: V1 open going down, V3 going up (Figure 2)."""
    return commands[0 if direction == "down" else 2]


#: Range kept for the interface slope dr/dF of the secant iteration.
SLOPE_RANGE = (0.5, 1.0e4)


def run_displacement_port(backend, control, circuit, settings, drive, controller, grid,
                          writer, progress, n_steps):
    """The displacement port's run (module docstring): the transducer's rod, the chamber
    force iterated a step at a time, rows into ``writer`` at ``grid``'s points."""
    packed = kernel.pack(circuit)
    area = circuit.chamber.piston_area
    x = initial_state(circuit)
    force = x[0] * area
    # the rod starts at rest under the chamber's force, as the force port's
    # (system_models.plant.initial_state). The transducer's rod starts free, so it is
    # handed the chamber's force beyond that preload and the master moves its output back
    # by the preload's static deflection: the mechanics are linear (eq 27), so the sum is
    # the preloaded rod's motion exactly
    preload = force
    offset = -RodParameters.of(backend.mechanics()).static_deflection(preload)
    y0, v0 = backend.rod_state()
    rod = (y0 + offset, v0)
    volume = compressed = 0.0
    slope = [None]  # the secant slope, carried from step to step
    t = 0.0
    previous = None
    while grid.before_end(t):
        h = grid.next(t) - t
        commands = controller.commands_at(t)
        # the digital compensator samples u(t); the continuous drive holds u(t + h/2)
        u = control(t) if drive.compensated else control(t + 0.5 * h)
        result = solve_interface(backend, t, h, u, force, x, rod, commands, packed, settings,
                                  area, slope, (preload, offset))
        x1, (y1, v1), current, force1, iterations, dvol, dcomp = result
        row = circuit_columns(x[:10], rod, packed)
        previous = _valve_phase(commands, settings.direction)
        row.update(time=t, control=u, current=current, force=force1,
                   compressing=float(controller.phase_at(t)), valves_compressing=previous,
                   volume_into_big=volume, compression_volume=compressed,
                   iterations=float(iterations))
        writer.add(row, 1)
        volume += dvol
        compressed += dcomp
        x, rod, force = x1, (y1, v1), force1
        t += h
        if progress is not None:
            progress(min(int(round(t / settings.step)), n_steps), n_steps)
    row = circuit_columns(x[:10], rod, packed)
    row.update(time=t, control=control(t), current=0.0, force=force,
               compressing=float(controller.phase_at(t)),
               valves_compressing=previous if previous is not None else 0.0,
               volume_into_big=volume, compression_volume=compressed, iterations=0.0)
    writer.add(row, 1)


def solve_interface(backend, t, h, u, force, x, rod, commands, packed, settings, area, slope,
                    preload=(0.0, 0.0)):
    """One displacement-port step: the held chamber force F with F = A_d p_P(t + h).

    ``preload``: (F_0 [N], its static deflection [m], negative): the transducer's rod is
    handed F - F_0 and its output moved by the deflection (run_displacement_port).

    Returns (x at t + h, (y, v) at t + h, current, F, iterations, volume into
    the big cavity, compression volume).
    """
    saved = backend.save()
    f_k, r_prev, f_prev = force, None, None
    substeps = _substeps(h, settings)
    for it in range(1, settings.max_iterations + 1):
        if it > 1:
            backend.restore(saved)
        y1, v1, current = backend.step(t, h, u, f_k - preload[0])
        y1 += preload[1]
        status, x1, _, dvol, dcomp, halvings = kernel.circuit_step(
            x, rod, (y1, v1), h, commands, settings.load_force, packed, substeps)
        if status != kernel.OK:
            if f_prev is None:
                if status == kernel.CHAMBER_EMPTIED:
                    raise gmt.ParameterError(
                        f"rod displacement {max(rod[0], y1):g} m empties the pump chamber")
                raise integration_failure(x, t, h)
            # the trial force drove the rod somewhere the oil cannot follow
            # (e.g. emptying the chamber): back off towards the last force
            # that integrated, and trust the slope less
            f_k = 0.5 * (f_k + f_prev)
            slope[0] = None if slope[0] is None else min(slope[0] * 4.0, SLOPE_RANGE[1])
            continue
        if halvings:
            # repeat with that discretisation throughout, so r(F) stays smooth
            substeps *= 2 ** halvings
            r_prev = f_prev = None
            continue
        r = f_k - area * x1[0]
        if abs(r) <= settings.force_tolerance:
            return x1, (y1, v1), current, f_k, it, dvol, dcomp
        # secant slope dr/dF, carried over from step to step; updated only
        # from iterates far enough apart that Newton's tolerance in the
        # hydraulics cannot corrupt it, and kept in its physical range:
        # dr/dF = 1 + A_d dp/dF >= 1 (pushing the rod back lowers the
        # chamber pressure), up to ~1e3 and more for the stiffest oil
        if r_prev is not None and abs(f_k - f_prev) > 10.0 * settings.force_tolerance:
            slope[0] = min(max((r - r_prev) / (f_k - f_prev), SLOPE_RANGE[0]), SLOPE_RANGE[1])
        f_prev, r_prev = f_k, r
        if slope[0] is None:
            # first step of the run: a small probe gives dr/dF by difference
            f_k = f_k - math.copysign(min(abs(r), 1.0), r)
        else:
            f_k = f_k - r / slope[0]
    raise CouplingError(
        f"interface force did not converge in {settings.max_iterations} iterations "
        f"at t = {t:g} s (residual {r:g} N); reduce the step")
