"""The integrated rod (the force port): the plant, circuit and rod, over a window of steps.

:func:`plant_run` integrates the plant's states (the circuit's, then the
rod's) over consecutive communication steps in one compiled call, the
magnetostrictive force given at both ends of each step; its substeps start
short after every valve action and grow (:data:`SWITCH_START`, :data:`GROWTH`).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .equations import _accumulator_pressure, _chamber_side, _chamber_volume, _flows, _hold_valves
from .trbdf2 import CHAMBER_EMPTIED, NEWTON_FAILED, OK, _substep, _workspace

#: The plant's substeps after a valve action: the first is SWITCH_START, each
#: next GROWTH times longer, up to the longest allowed. Opening a valve joins
#: volumes at different pressures: a transient of ~1 us (the orifice against the
#: oil's compliance) and the rod-oil ring that follows. A long first substep
#: steps over it with the stiff-order reduction of a one-step method, a
#: first-order error in the substep on the pumped volume (measured: -0.34 % at
#: 25 us, -0.13 % at 10 us fixed substeps, 100 Hz compensated, realistic); the
#: graded start resolves it in four substeps (1, 4, 16, 64 us) and leaves the
#: flow within 0.05 % of converged with one 100 us substep a step elsewhere.
SWITCH_START, GROWTH = 1e-6, 4.0


@njit(cache=True)
def _advance_graded(x, drive, h, max_dt, cmds, load, P, max_newton, max_halvings, totals,
                    lu, piv, key, counts, work, xn, incr, control):
    """x over one step of h, in place, in substeps of control[0] growing by GROWTH to max_dt.

    Lengths are the remainder over a whole number, so that once grown every
    substep of a step has one length and Newton keeps its matrix. A substep
    whose Newton fails is halved (at most ``max_halvings`` times in a row).
    control[0] gets the length for what follows. Adds the quadratures to
    ``totals``; returns False when Newton failed on the shortest substep.
    """
    dt_min = h / 2.0 ** max_halvings
    failures = 0
    s = 0.0
    dt_try = min(control[0], max_dt)
    while h - s > 1e-12 * h:
        left = h - s
        m = max(1, int(np.ceil(left / dt_try - 1e-9)))
        s1 = h if m == 1 else s + left / m
        dt = s1 - s
        if not _substep(x, s, s1, drive, h, cmds, load, P, max_newton, xn, incr, lu, piv,
                        key, counts, True, work):
            failures += 1
            if dt <= dt_min or failures > max_halvings:
                return False
            dt_try = 0.5 * dt
            continue
        failures = 0
        x[:] = xn
        for i in range(3):
            totals[i] += incr[i]
        s = s1
        if dt_try < max_dt:
            dt_try = min(GROWTH * dt, max_dt)
    control[0] = dt_try
    return True


#: Columns of :func:`plant_run`'s rows after the n states: the four valve flows
#: [m^3/s], the accumulator pressure [Pa], the volume into the big cavity and the
#: oil taken up by compression since the call's start [m^3].
PLANT_EXTRA = ("q_v1", "q_v2", "q_v3", "q_v4", "p_accumulator", "volume_into_big",
               "compression_volume")


@njit(cache=True)
def _plant_run(x0, steps, forces, commands, load, P, max_dt, max_newton, max_halvings, rows,
               counts, control):
    """The steps of :func:`plant_run`; returns (status, steps done)."""
    n = x0.size
    lu, piv, key, _, work, xn, incr, _, _, _ = _workspace(n, max_halvings)
    totals = np.zeros(3)
    x = x0.copy()
    drive = np.zeros(4)
    q = np.empty(4)
    for k in range(steps.size):
        cmds = commands[k]
        for j in range(4):
            if cmds[j] != control[1 + j]:  # a valve acts: start again short
                control[0] = SWITCH_START
            control[1 + j] = cmds[j]
        _hold_valves(x, cmds, P)
        drive[0], drive[1] = forces[k, 0], forces[k, 1]
        if not _advance_graded(x, drive, steps[k], max_dt, cmds, load, P, max_newton,
                               max_halvings, totals, lu, piv, key, counts, work, xn, incr,
                               control):
            y = _chamber_side(x, P)[0]
            return (CHAMBER_EMPTIED if _chamber_volume(y, P) <= 0.0 else NEWTON_FAILED), k
        rows[k, :n] = x
        _flows(x, P, q)
        rows[k, n:n + 4] = q
        rows[k, n + 4] = _accumulator_pressure(x, P)
        rows[k, n + 5] = totals[1]
        rows[k, n + 6] = totals[2]
    return OK, steps.size


def new_control() -> np.ndarray:
    """What :func:`plant_run` carries from call to call: the next substep's length and the
    valve commands in force (a run starts short, as after a valve action)."""
    return np.array([SWITCH_START, np.nan, np.nan, np.nan, np.nan])


def plant_run(x0, steps, forces, commands, load, packed, max_substep=None, control=None,
              counts=None, max_newton=60, max_halvings=10):
    """Integrate the plant (circuit + rod) over consecutive steps in one compiled call.

    TR-BDF2 substeps: after each valve action (and at the start) the first is
    :data:`SWITCH_START` long and each next :data:`GROWTH` times longer, up
    to ``max_substep`` (None: the step).

    Parameters
    ----------
    x0 : array
        Plant state at the start (the circuit's 10, then the rod's).
    steps : float array (W,)
        Step lengths, [s].
    forces : float array (W, 2)
        Magnetostrictive force at the start and the end of each step, [N],
        linear in between (equal for a held force).
    commands : float array (W, 4)
        Valve commands over each step (1 open, 0 closed); valves without
        their own dynamics take them at the step's start.
    load : float
        Load on the cylinder, [N].
    packed : array
        :func:`pack` of the circuit and the rod.
    max_substep : float, optional
        Longest substep, [s].
    control : float array, optional
        :func:`new_control`'s array, updated; pass the same one to the calls
        of one run.
    counts : int array of 3, optional
        Running totals to add the work to: substeps attempted, Newton
        iterations, Jacobians formed.

    Returns
    -------
    (int, int, array (W, n + 7))
        Status, the steps completed, and per completed step the state at its
        end followed by :data:`PLANT_EXTRA`.
    """
    x0 = np.asarray(x0, dtype=float)
    rows = np.empty((len(steps), x0.size + len(PLANT_EXTRA)))
    status, done = _plant_run(x0, np.asarray(steps, dtype=float),
                              np.asarray(forces, dtype=float),
                              np.asarray(commands, dtype=float), float(load), packed,
                              np.inf if max_substep is None else float(max_substep),
                              int(max_newton), int(max_halvings), rows,
                              _NO_COUNTS if counts is None else counts,
                              new_control() if control is None else control)
    return status, done, rows[:done]


#: Where calls that keep no counts add them up.
_NO_COUNTS = np.zeros(3, dtype=np.int64)
