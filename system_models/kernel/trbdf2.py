"""TR-BDF2 and damped Newton, compiled: the substep both couplings share.

One substep (:func:`_substep`) takes TR-BDF2's two implicit stages
(:func:`_stages`), each solved by damped Newton (:func:`_newton`) with the
iteration matrix I - c J formed by forward differences and factorised in place
(:func:`_iteration_matrix`), kept while the substep length and the valve
commands stay the same (:func:`_factors_fit`). The same method as
:mod:`system_models.implicit`, written for speed (the package docstring).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..fluid import MINIMUM_PRESSURE
from ..implicit import NEWTON_ATOL, RESIDUAL_SCALE, TRBDF2_GAMMA
from .equations import _AIR, _ROD, _chamber_side, _chamber_volume, _hermite, _quadrature, _rates

#: Per state: size for the forward-difference Jacobian; Newton's absolute
#: tolerance; scale of the line search's residual norm. The circuit's, then
#: the rod's (y [m], v [m/s], twice for two masses).
_FD_SCALE = np.array([1e5, 1e5, 1e5, 1e-6, 1e-3, 1e-3, 1.0, 1.0, 1.0, 1.0]
                     + [1e-6, 1e-3] * 2)
#: Newton's tolerance: 1e3 times :mod:`.implicit`'s absolute one (1 Pa, 1e-15 m^3 of
#: stored oil, 0.1 nm and 0.1 um/s of the piston; 0.1 nm and 0.1 um/s of the rod) and
#: 1e-7 relative: far below TR-BDF2's own error on the flow (1e-4 at the default
#: steps, benchmarks/README.md) while the readable reference's 1e-10 cost two more
#: Newton iterations a substep (measured: 8.8 against 6.3, realistic circuit).
_ATOL = np.concatenate((NEWTON_ATOL, [1e-13, 1e-10] * 2)) * 1e3
RTOL = 1e-7
_RSCALE = np.concatenate((RESIDUAL_SCALE, [1e-9, 1e-6] * 2))

#: Status codes.
OK, NEWTON_FAILED, CHAMBER_EMPTIED = 0, 1, 2


@njit(cache=True)
def _iteration_matrix(x, dt, a, b, cmds, load, P, f, lu, piv, ft):
    """LU factors of I - dt J at x, J by forward differences; f = rates(x) given. False if
    singular. ``ft`` is scratch space of x.size.
    """
    n = x.size
    xp = x.copy()
    for j in range(n):
        d = 1e-7 * max(abs(x[j]), _FD_SCALE[j])
        xp[j] = x[j] + d
        _rates(xp, a, b, cmds, load, P, ft)
        xp[j] = x[j]
        for i in range(n):
            lu[i, j] = -dt * (ft[i] - f[i]) / d
        lu[j, j] += 1.0
    # LU with partial pivoting, in place (Golub & Van Loan, Matrix Computations, alg. 3.4.1)
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(lu[i, k]) > abs(lu[p, k]):
                p = i
        piv[k] = p
        if not (abs(lu[p, k]) > 0.0) or not np.isfinite(lu[p, k]):
            return False
        if p != k:
            for j in range(n):
                lu[k, j], lu[p, j] = lu[p, j], lu[k, j]
        for i in range(k + 1, n):
            lu[i, k] /= lu[k, k]
            for j in range(k + 1, n):
                lu[i, j] -= lu[i, k] * lu[k, j]
    return True


@njit(cache=True)
def _lu_solve(lu, piv, b, n):
    """Solve (LU) z = b[:n] in place, with the pivots of :func:`_iteration_matrix`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    # sums in a local: b[i] in memory would be reloaded at every term (b may alias lu)
    for i in range(n):
        acc = b[i]
        for j in range(i):
            acc -= lu[i, j] * b[j]
        b[i] = acc
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= lu[i, j] * b[j]
        b[i] = acc / lu[i, i]


@njit(cache=True)
def _residual(xn, r, dt, f, g):
    """g = xn - r - dt f; returns its scaled max norm (as implicit._norm)."""
    norm = 0.0
    for i in range(xn.size):
        g[i] = xn[i] - r[i] - dt * f[i]
        norm = max(norm, abs(g[i]) / _RSCALE[i])
    return norm


#: ``key`` says what the LU factors in ``lu, piv`` were made for: [valid (1/0),
#: the coefficient c of I - c J, the four valve commands].
_KEY_VALID, _KEY_C, _KEY_CMDS = 0, 1, 2
#: ``counts``: substeps attempted, Newton iterations, Jacobians (factorisations).
_N_SUBSTEPS, _N_NEWTON, _N_JACOBIANS = 0, 1, 2
#: Rows of the scratch array of :func:`_newton` and :func:`_substep`.
_FT, _G, _GT, _DELTA, _TRIAL, _F0, _XG, _FG, _F1, _R, _GUESS = range(11)
_N_WORK = 11
#: A Newton iteration that leaves more than this fraction of the residual
#: has out-of-date factors: J is taken afresh at the next iterate. Fresh
#: factors cut it by 1e-3 and more; with factors kept over many substeps a
#: laxer bound (0.1, 0.5) lets slow linear convergence run on, which costs
#: more iterations than the Jacobians it saves (measured, realistic circuit).
_STALL = 0.02


@njit(cache=True)
def _factorise(x, c, a, b, cmds, load, P, f, lu, piv, key, counts, ft):
    """Factors of I - c J at x (f = rates(x)) into lu, piv, recorded in key; False if singular."""
    counts[_N_JACOBIANS] += 1
    ok = _iteration_matrix(x, c, a, b, cmds, load, P, f, lu, piv, ft)
    key[_KEY_VALID] = 1.0 if ok else 0.0
    key[_KEY_C] = c
    for k in range(4):
        key[_KEY_CMDS + k] = cmds[k]
    return ok


@njit(cache=True)
def _factors_fit(key, c, cmds):
    """Whether the stored factors were made for this c (to round-off) and these commands.

    A different c (a halved substep) makes a different matrix; different
    commands open or close valves, which changes J far more than the state's
    drift along a substep does.
    """
    if key[_KEY_VALID] != 1.0 or abs(key[_KEY_C] - c) > 1e-9 * c:
        return False
    for k in range(4):
        if key[_KEY_CMDS + k] != cmds[k]:
            return False
    return True


@njit(cache=True)
def _step_size(delta, x):
    """Size of the Newton correction delta in units of the tolerance at x (<= 1: converged)."""
    size = 0.0
    for i in range(x.size):
        size = max(size, abs(delta[i]) / (_ATOL[i] + RTOL * abs(x[i])))
    return size


@njit(cache=True)
def _newton(r, guess, dt, a, b, cmds, load, P, max_newton, xn, f, lu, piv, key, counts, work,
            f_guess, y_guess):
    """Solve xn - r - dt f(xn) = 0 by damped Newton (as implicit._newton); True if converged.

    On success ``f`` holds rates(xn) (see below), which the caller's
    quadrature needs.

    ``lu, piv`` hold the factors of I - dt J from an earlier point (TR-BDF2's
    two stages share the matrix, and so do the substeps of one length);
    they are refreshed at the current iterate whenever an iteration leaves
    more than :data:`_STALL` of the residual (simplified Newton stalling).
    ``work`` is scratch space (rows :data:`_FT` ... :data:`_TRIAL`).

    ``f_guess``, if not None, is rates(guess) with the prescribed rod at
    another position ``y_guess`` but the same velocity (the trapezoidal stage
    starts from the substep's start, where the caller has it): y enters only
    through the chamber's volume in dp_P/dt, so rescaling that one term saves
    a right-hand side.

    Converged: when the full Newton correction is within the tolerance
    (:func:`_step_size`; implicit._newton tests the step it took, damped or
    not). That correction is applied with f moved along the linear model
    rather than evaluated again (one right-hand side less per stage): on
    success ``f`` is rates(xn) to within the linearisation error of a step
    smaller than the tolerance.
    """
    n = xn.size
    ft, g, gt, delta, trial = work[_FT], work[_G], work[_GT], work[_DELTA], work[_TRIAL]
    xn[:] = guess
    if f_guess is None:
        _rates(xn, a, b, cmds, load, P, f)
    else:
        f[:] = f_guess
        f[0] *= _chamber_volume(y_guess, P) / _chamber_volume(a, P)
    norm = _residual(xn, r, dt, f, g)
    fresh = True
    for _ in range(max_newton):
        counts[_N_NEWTON] += 1
        if not fresh:
            if not _factorise(xn, dt, a, b, cmds, load, P, f, lu, piv, key, counts, ft):
                return False
            fresh = True
        for i in range(n):
            delta[i] = -g[i]
        _lu_solve(lu, piv, delta, n)
        for i in range(n):
            trial[i] = xn[i] + delta[i]
        if _step_size(delta, trial) <= 1.0:
            # the last correction, within the tolerance: take it, with f
            # moved along the same linear model, f + J delta = f + (delta + g) / dt
            # ((I - dt J) delta = -g). The stage equation then holds to
            # round-off, so the states stay the quadratures of f and the
            # volume balance closes, without evaluating f at the new point.
            for i in range(n):
                xn[i] = trial[i]
                f[i] += (delta[i] + g[i]) / dt
            return True
        # damped (Armijo) step: the orifice law makes full steps cycle
        lam = 1.0
        while True:
            _rates(trial, a, b, cmds, load, P, ft)
            norm_trial = _residual(trial, r, dt, ft, gt)
            if norm_trial <= (1.0 - 0.5 * lam) * norm or lam < 1.0 / 1024:
                break
            lam *= 0.5
            for i in range(n):
                trial[i] = xn[i] + lam * delta[i]
        if lam < 1.0 or norm_trial > _STALL * norm:
            fresh = False  # the matrix is out of date: refresh it at the next iterate
        xn[:] = trial
        f[:] = ft
        g[:] = gt
        norm = norm_trial
        if not np.all(np.isfinite(xn)):
            return False
    return False


@njit(cache=True)
def _stages(x, f0, c, a0, ag, bg, a1, b1, cmds, load, P, max_newton, xn, lu, piv, key,
            counts, work, predict):
    """TR-BDF2's two implicit stages from x (f0 = rates(x) with a0); True if both converged.

    The trapezoidal stage xg = x + c (f0 + f(xg)) starts from x (with a
    prescribed rod, from f0 rescaled to the stage's rod position). The BDF2
    stage xn = a xg - b x + c f(xn) starts, when ``predict``, from the line
    through x and xg extended to the end of the substep (the solution's drift
    carries on), else from xg as implicit._trbdf2_substep does.
    """
    gam = TRBDF2_GAMMA
    alpha = 1.0 / (gam * (2.0 - gam))
    beta = (1.0 - gam) ** 2 / (gam * (2.0 - gam))
    n = x.size
    xg, fg, f1, r, guess = work[_XG], work[_FG], work[_F1], work[_R], work[_GUESS]
    for i in range(n):
        r[i] = x[i] + c * f0[i]
    if P[_ROD] == 0.0:
        ok = _newton(r, x, c, ag, bg, cmds, load, P, max_newton, xg, fg, lu, piv, key, counts,
                     work, f0, a0)
    else:
        ok = _newton(r, x, c, ag, bg, cmds, load, P, max_newton, xg, fg, lu, piv, key, counts,
                     work, None, 0.0)
    if not ok:
        return False
    for i in range(n):
        r[i] = alpha * xg[i] - beta * x[i]
        guess[i] = x[i] + (xg[i] - x[i]) / gam if predict else xg[i]
    return _newton(r, guess, c, a1, b1, cmds, load, P, max_newton, xn, f1, lu, piv, key,
                   counts, work, None, 0.0)


@njit(cache=True)
def _substep(x, s0, s1, drive, h, cmds, load, P, max_newton, xn, incr, lu, piv, key, counts,
             reuse, work):
    """One TR-BDF2 substep (as implicit._trbdf2_substep); True if both Newton solves converged.

    ``drive`` is the step's (y, v at 0, y, v at h) for a prescribed rod, or
    (F at 0, F at h, -, -) for the plant. Both stages iterate with I - c J
    (TR-BDF2's shared matrix). The factors in ``lu, piv`` are kept from
    earlier substeps when ``reuse`` and they fit (:func:`_factors_fit`): the
    substep then costs no Jacobian unless Newton stalls. Should Newton fail,
    the substep is tried again exactly as implicit._trbdf2_substep does it (J
    at x, each stage starting from the last solution) before the caller
    halves it: kept factors or the BDF2 predictor never cause a halving the
    reference would not make.

    ``incr`` gets the three quadratures' increments.
    """
    gam = TRBDF2_GAMMA
    dd = gam / 2.0
    alpha = 1.0 / (gam * (2.0 - gam))
    beta = (1.0 - gam) ** 2 / (gam * (2.0 - gam))
    dt = s1 - s0
    sg = s0 + gam * dt
    c = dd * dt
    if P[_ROD] == 0.0:
        # the rod on its Hermite path; each stage gets the velocity its own formula
        # implies (secants), so the swept volume is exact (implicit.tr_bdf2)
        y0 = _hermite(s0, drive[0], drive[1], drive[2], drive[3], h)
        yg = _hermite(sg, drive[0], drive[1], drive[2], drive[3], h)
        y1 = _hermite(s1, drive[0], drive[1], drive[2], drive[3], h)
        a0, b0 = y0, (yg - y0) / (sg - s0)
        ag, bg = yg, b0
        a1, b1 = y1, (y1 - alpha * yg + beta * y0) / (dd * dt)
    else:
        # the force, linear between its values at the step's ends
        slope = (drive[1] - drive[0]) / h
        a0, ag, a1 = drive[0] + slope * s0, drive[0] + slope * sg, drive[0] + slope * s1
        b0 = bg = b1 = 0.0
    counts[_N_SUBSTEPS] += 1
    f0 = work[_F0]
    _rates(x, a0, b0, cmds, load, P, f0)
    if not (reuse and _factors_fit(key, c, cmds)):
        if not _factorise(x, c, a0, b0, cmds, load, P, f0, lu, piv, key, counts, work[_FT]):
            return False
    if not _stages(x, f0, c, a0, ag, bg, a1, b1, cmds, load, P, max_newton, xn, lu, piv, key,
                   counts, work, True):
        if not _factorise(x, c, a0, b0, cmds, load, P, f0, lu, piv, key, counts, work[_FT]):
            return False
        if not _stages(x, f0, c, a0, ag, bg, a1, b1, cmds, load, P, max_newton, xn, lu, piv,
                       key, counts, work, False):
            return False
    xg, fg, f1 = work[_XG], work[_FG], work[_F1]
    if P[_AIR] > 0.0:
        for i in range(3):
            # with entrained air, below the air model's floor (MINIMUM_PRESSURE; the oil
            # would cavitate, which is not modelled) lies a spurious root of the stage
            # equations that a long substep can fall into (the mixture is nearly
            # incompressible... and nearly all gas there): halve the substep
            if xg[i] < MINIMUM_PRESSURE or xn[i] < MINIMUM_PRESSURE:
                return False
    if P[_ROD] == 0.0:
        yq0, yqg, yq1 = a0, ag, a1
    else:
        yq0 = _chamber_side(x, P)[0]
        yqg = _chamber_side(xg, P)[0]
        yq1 = _chamber_side(xn, P)[0]
        if _chamber_volume(max(yq0, yqg, yq1), P) <= 0.0:
            return False
    p0, q0, c0 = _quadrature(x, yq0, f0, P)
    pg, qg, cg = _quadrature(xg, yqg, fg, P)
    p1, q1, c1 = _quadrature(xn, yq1, f1, P)
    # BDF2 combination of the trapezoidal stage (the quadrature starts at 0)
    incr[0] = alpha * c * (p0 + pg) + c * p1
    incr[1] = alpha * c * (q0 + qg) + c * q1
    incr[2] = alpha * c * (c0 + cg) + c * c1
    return True


@njit(cache=True)
def _workspace(n, max_halvings):
    """Scratch arrays of one call: LU factors and pivots, their key, counts, work, stacks."""
    key = np.zeros(2 + 4)
    return (np.empty((n, n)), np.zeros(n, dtype=np.int64), key,
            np.zeros(3, dtype=np.int64), np.empty((_N_WORK, n)), np.empty(n), np.empty(3),
            np.empty(2 * max_halvings + 2), np.empty(2 * max_halvings + 2),
            np.empty(2 * max_halvings + 2, dtype=np.int64))
