"""The prescribed rod (the displacement port): the circuit over a step with the rod's motion given.

:func:`circuit_step` integrates the ten circuit states over one communication
step, the rod moving on the cubic Hermite path through its (y, v) at both ends
(the transducer FMU integrated it), in equal TR-BDF2 substeps, halving any
whose Newton fails.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .equations import _chamber_volume, _hermite, _hold_valves, _packed
from .trbdf2 import CHAMBER_EMPTIED, NEWTON_FAILED, OK, _substep, _workspace


@njit(cache=True)
def _chamber_holds_oil(drive, h, P):
    """Whether the chamber keeps a positive volume wherever a prescribed rod goes in [0, h]."""
    ymax = -np.inf
    for k in range(17):
        ymax = max(ymax, _hermite(h * k / 16.0, drive[0], drive[1], drive[2], drive[3], h))
    return _chamber_volume(ymax, P) > 0.0


@njit(cache=True)
def _advance(x, drive, h, substeps, cmds, load, P, max_newton, max_halvings, totals, lu, piv,
             key, counts, work, xn, incr, stack_s0, stack_s1, stack_d):
    """x over one step of h in ``substeps`` equal TR-BDF2 substeps, in place.

    A substep whose Newton fails is halved, at most ``max_halvings`` times
    (an explicit stack replaces implicit._integrate's recursion). Adds the
    quadratures to ``totals``. Returns the deepest halving used, or -1 when
    Newton failed on the smallest substep.
    """
    deepest = 0
    dt = h / substeps
    for j in range(substeps):
        top = 0
        stack_s0[0], stack_s1[0], stack_d[0] = j * dt, (j + 1) * dt, 0
        while top >= 0:
            s0, s1, depth = stack_s0[top], stack_s1[top], stack_d[top]
            top -= 1
            if _substep(x, s0, s1, drive, h, cmds, load, P, max_newton, xn, incr, lu, piv,
                        key, counts, True, work):
                x[:] = xn
                for i in range(3):
                    totals[i] += incr[i]
                continue
            if depth == max_halvings:
                return -1
            mid = 0.5 * (s0 + s1)
            deepest = max(deepest, depth + 1)
            # second half below the first: the first half is taken next
            top += 1
            stack_s0[top], stack_s1[top], stack_d[top] = mid, s1, depth + 1
            top += 1
            stack_s0[top], stack_s1[top], stack_d[top] = s0, mid, depth + 1
    return deepest


@njit(cache=True)
def _circuit_step(x0, drive, h, substeps, cmds, load, P, max_newton, max_halvings, out):
    """The prescribed-rod step of :func:`circuit_step`; returns (status, deepest halving)."""
    if not _chamber_holds_oil(drive, h, P):
        return CHAMBER_EMPTIED, 0
    lu, piv, key, counts, work, xn, incr, s0, s1, sd = _workspace(x0.size, max_halvings)
    totals = np.zeros(3)
    x = x0.copy()
    deepest = _advance(x, drive, h, substeps, cmds, load, P, max_newton, max_halvings, totals,
                       lu, piv, key, counts, work, xn, incr, s0, s1, sd)
    if deepest < 0:
        return NEWTON_FAILED, max_halvings
    out[:10] = x
    out[10:] = totals
    return OK, deepest


def circuit_step(x0, rod0, rod1, h, commands, load, params, substeps=1, max_newton=60,
                 max_halvings=10):
    """Advance the circuit over one step with TR-BDF2, the rod prescribed (displacement port).

    The same method as :func:`system_models.implicit.tr_bdf2` with the rod on
    the cubic Hermite path through ``rod0 = (y, v)`` at 0 and ``rod1`` at h.

    Parameters
    ----------
    x0 : array of 10
        State at the start (:data:`circuit.STATE_NAMES`), [SI]; valves without
        their own dynamics are set to ``commands`` first.
    rod0, rod1 : (float, float)
        Rod displacement [m] and velocity [m/s] at the start and the end.
    h : float
        Step, [s].
    commands : sequence of 4 floats
        Valve commands held over the step (1 open, 0 closed).
    load : float
        Load on the cylinder, [N].
    params : CircuitParameters or array
        The circuit, or its :func:`pack` (saves the cache look-up per call).
    substeps, max_newton, max_halvings
        As :func:`implicit.tr_bdf2`.

    Returns
    -------
    (int, array, float, float, float, int)
        Status (:data:`OK`, :data:`NEWTON_FAILED`, :data:`CHAMBER_EMPTIED`);
        the state at h; the integral of p_P [Pa s]; the net volume into the
        big cavity [m^3]; the oil taken up by compression [m^3]; the deepest
        halving used.
    """
    P = _packed(params)
    cmds = np.asarray(commands, dtype=float)
    x = np.array(x0, dtype=float)
    _hold_valves(x, cmds, P)
    drive = np.array([rod0[0], rod0[1], rod1[0], rod1[1]], dtype=float)
    out = np.empty(13)
    status, deepest = _circuit_step(x, drive, float(h), int(substeps), cmds, float(load), P,
                                    int(max_newton), int(max_halvings), out)
    return status, out[:10], out[10], out[11], out[12], deepest
