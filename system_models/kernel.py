"""The co-simulation's hot loop, compiled: one TR-BDF2 step of the circuit.

What and why
------------
Profiling (``benchmarks/cosim_profile.py``, pyinstrument) puts ~95 % of a
co-simulation's time in the hydraulics: each communication step solves the
interface force in 2-3 iterations, each a TR-BDF2 step of the 10-state
circuit -- two damped-Newton solves, each needing the right-hand side a few
times and its Jacobian. In Python every one of those is hundreds of tiny
numpy and attribute operations (~4 ms per communication step). The same
arithmetic on plain floats, compiled by numba, takes microseconds.

What is compiled is the *numerical method* only: the assembly of the
circuit's equations (the same as :func:`system_models.circuit.rhs`), damped
Newton, TR-BDF2 and the halving of a failing substep (the same as
:mod:`system_models.implicit`). The *physics* is not rewritten: the kernel
calls the components' plain-number functions (``mixture_bulk_modulus``,
``orifice_flow``, ``opening_area``, ``gas_spring_pressure``,
``piston_acceleration_of``), which the readable modules use themselves and
``numba.extending.register_jitable`` lets numba compile. The Jacobian is by
forward differences (ten evaluations of compiled arithmetic cost less than
one call of the analytic Python Jacobian). ``tests/test_kernel.py`` checks
the kernel's right-hand side against :func:`circuit.rhs` to round-off and its
steps against :func:`implicit.tr_bdf2` to the Newton tolerance.

Parameters travel as one float array (:func:`pack`), states as in
:data:`system_models.circuit.STATE_NAMES`.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numba import njit

from .accumulator import gas_spring_pressure
from .circuit import CircuitParameters
from .cylinder import piston_acceleration_of
from .fluid import mixture_bulk_modulus
from .implicit import NEWTON_ATOL, NEWTON_RTOL, RESIDUAL_SCALE, TRBDF2_GAMMA
from .valves import opening_area, orifice_flow

# indices into the packed parameter array (see :func:`pack`)
_RHO, _BETA, _AIR, _PREF, _NAIR = 0, 1, 2, 3, 4
_V0, _AD, _YREF = 5, 6, 7
_AB, _AS, _VDB, _VDS, _STROKE, _MASS, _FRIC, _KSTOP, _CSTOP = 8, 9, 10, 11, 12, 13, 14, 15, 16
_P0, _VGAS, _NACC, _KPORT = 17, 18, 19, 20
_VALVE = 21  # then per valve: area, C_d, transition pressure, leakage, tau (0: not first order)
_NPACK = _VALVE + 4 * 5

#: Size of each state for the forward-difference Jacobian (Pa, m^3, m, m/s, -).
_FD_SCALE = np.array([1e5, 1e5, 1e5, 1e-6, 1e-3, 1e-3, 1.0, 1.0, 1.0, 1.0])

#: Status codes of :func:`circuit_step`.
OK, NEWTON_FAILED, CHAMBER_EMPTIED = 0, 1, 2


@lru_cache(maxsize=64)
def pack(params: CircuitParameters) -> np.ndarray:
    """The circuit's parameters as the kernel's float array (SI); cached per circuit."""
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
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out


@njit(cache=True)
def _beta(p, P):
    return mixture_bulk_modulus(p, P[_BETA], P[_AIR], P[_PREF], P[_NAIR])


@njit(cache=True)
def _flows(x, P, q):
    """Valve flows V1..V4 into q (as :func:`circuit.valve_flows`)."""
    p_a = gas_spring_pressure(x[3], P[_P0], P[_VGAS], P[_NACC], P[_KPORT])
    for k in range(4):
        j = _VALVE + 5 * k
        if k == 0:
            dp = x[0] - x[1]
        elif k == 1:
            dp = x[1] - p_a
        elif k == 2:
            dp = x[0] - x[2]
        else:
            dp = x[2] - p_a
        q[k] = orifice_flow(opening_area(x[6 + k], P[j], P[j + 3]), dp, P[_RHO], P[j + 1],
                            P[j + 2])


@njit(cache=True)
def _rhs(x, y, v, cmds, load, P, out):
    """dx/dt into out (as :func:`circuit.rhs`); y, v the rod's position and velocity."""
    q = np.empty(4)
    _flows(x, P, q)
    pos, vel = x[4], x[5]
    vb = P[_VDB] + P[_AB] * pos
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - pos)
    vp = P[_V0] - P[_AD] * (y - P[_YREF])
    out[0] = _beta(x[0], P) / vp * (P[_AD] * v - q[0] - q[2])
    out[1] = _beta(x[1], P) / vb * (q[0] - q[1] - P[_AB] * vel)
    out[2] = _beta(x[2], P) / vs * (q[2] - q[3] + P[_AS] * vel)
    out[3] = q[1] + q[3]
    out[4] = vel
    out[5] = piston_acceleration_of(x[1], x[2], pos, vel, load, P[_AB], P[_AS], P[_FRIC],
                                    P[_MASS], P[_STROKE], P[_KSTOP], P[_CSTOP])
    for k in range(4):
        tau = P[_VALVE + 5 * k + 4]
        out[6 + k] = (cmds[k] - x[6 + k]) / tau if tau > 0.0 else 0.0


def _packed(params) -> np.ndarray:
    return params if isinstance(params, np.ndarray) else pack(params)


def flows(x, params) -> np.ndarray:
    """Valve flows V1..V4 at state x, compiled (as :func:`circuit.valve_flows`), [m^3/s].

    ``params``: a CircuitParameters or its :func:`pack`.
    """
    q = np.empty(4)
    _flows(np.asarray(x, dtype=float), _packed(params), q)
    return q


def rhs(x, rod_displacement, rod_velocity, commands, load, params: CircuitParameters):
    """Python entry to the compiled right-hand side (for tests), dx/dt."""
    out = np.empty(10)
    _rhs(np.asarray(x, dtype=float), float(rod_displacement), float(rod_velocity),
         np.asarray(commands, dtype=float), float(load), pack(params), out)
    return out


@njit(cache=True)
def _quadrature(x, y, f, P, out):
    """(p_P, Q_V1 - Q_V2, oil absorbed by compression per second) at x, with f = rhs(x)."""
    q = np.empty(4)
    _flows(x, P, q)
    vp = P[_V0] - P[_AD] * (y - P[_YREF])
    vb = P[_VDB] + P[_AB] * x[4]
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - x[4])
    out[0] = x[0]
    out[1] = q[0] - q[1]
    out[2] = (vp / _beta(x[0], P) * f[0] + vb / _beta(x[1], P) * f[1]
              + vs / _beta(x[2], P) * f[2])


@njit(cache=True)
def _iteration_matrix(x, dt, y, v, cmds, load, P, f, lu, piv):
    """LU factors of I - dt J at x, J by forward differences; f = rhs(x) given. False if singular."""
    n = 10
    ft = np.empty(n)
    xp = x.copy()
    for j in range(n):
        d = 1e-7 * max(abs(x[j]), _FD_SCALE[j])
        xp[j] = x[j] + d
        _rhs(xp, y, v, cmds, load, P, ft)
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
def _lu_solve(lu, piv, b):
    """Solve (LU) z = b in place in b, with the pivots of :func:`_iteration_matrix`."""
    n = b.size
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        for j in range(i):
            b[i] -= lu[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= lu[i, j] * b[j]
        b[i] /= lu[i, i]


@njit(cache=True)
def _residual(xn, r, dt, f, g):
    """g = xn - r - dt f; returns its scaled max norm (as implicit._norm)."""
    norm = 0.0
    for i in range(10):
        g[i] = xn[i] - r[i] - dt * f[i]
        norm = max(norm, abs(g[i]) / RESIDUAL_SCALE[i])
    return norm


@njit(cache=True)
def _newton(r, guess, dt, y, v, cmds, load, P, max_newton, xn, f, lu, piv, fresh):
    """Solve xn - r - dt f(xn) = 0 by damped Newton (as implicit._newton); True if converged.

    On success ``f`` holds rhs(xn), which the caller's quadrature needs.

    ``lu, piv`` hold the factors of I - dt J from an earlier point (TR-BDF2's
    two stages share the matrix); they are refreshed here when ``fresh`` is
    False at the start, and whenever an iteration fails to halve the
    residual (a simplified Newton iteration that stalls).
    """
    n = 10
    ft = np.empty(n)
    g = np.empty(n)
    gt = np.empty(n)
    delta = np.empty(n)
    trial = np.empty(n)
    xn[:] = guess
    _rhs(xn, y, v, cmds, load, P, f)
    norm = _residual(xn, r, dt, f, g)
    for _ in range(max_newton):
        if not fresh:
            if not _iteration_matrix(xn, dt, y, v, cmds, load, P, f, lu, piv):
                return False
            fresh = True
        for i in range(n):
            delta[i] = -g[i]
        _lu_solve(lu, piv, delta)
        # damped (Armijo) step: the orifice law makes full steps cycle
        lam = 1.0
        while True:
            for i in range(n):
                trial[i] = xn[i] + lam * delta[i]
            _rhs(trial, y, v, cmds, load, P, ft)
            norm_trial = _residual(trial, r, dt, ft, gt)
            if norm_trial <= (1.0 - 0.5 * lam) * norm or lam < 1.0 / 1024:
                break
            lam *= 0.5
        if lam < 1.0 or norm_trial > 0.5 * norm:
            fresh = False  # the matrix is out of date: refresh it at the next iterate
        xn[:] = trial
        f[:] = ft
        g[:] = gt
        norm = norm_trial
        if not np.all(np.isfinite(xn)):
            return False
        done = True
        for i in range(n):
            if abs(lam * delta[i]) > NEWTON_ATOL[i] + NEWTON_RTOL * abs(xn[i]):
                done = False
                break
        if done:
            return True
    return False


@njit(cache=True)
def _hermite(s, y0, v0, y1, v1, h):
    """Rod position at s into the step on the cubic through (y0, v0), (y1, v1)."""
    dy = y1 - y0
    r = s / h
    return (y0 + v0 * s + (3.0 * dy - h * (2.0 * v0 + v1)) * r * r
            + (h * (v0 + v1) - 2.0 * dy) * r * r * r)


@njit(cache=True)
def _substep(x, s0, s1, rod, h, cmds, load, P, max_newton, xn, incr):
    """One TR-BDF2 substep (as implicit._trbdf2_substep); True if both Newton solves converged."""
    gam = TRBDF2_GAMMA
    dd = gam / 2.0
    a = 1.0 / (gam * (2.0 - gam))
    b = (1.0 - gam) ** 2 / (gam * (2.0 - gam))
    dt = s1 - s0
    sg = s0 + gam * dt
    y0 = _hermite(s0, rod[0], rod[1], rod[2], rod[3], h)
    yg = _hermite(sg, rod[0], rod[1], rod[2], rod[3], h)
    y1 = _hermite(s1, rod[0], rod[1], rod[2], rod[3], h)
    v_tr = (yg - y0) / (sg - s0)
    v_bdf = (y1 - a * yg + b * y0) / (dd * dt)
    c = dd * dt
    f0 = np.empty(10)
    _rhs(x, y0, v_tr, cmds, load, P, f0)
    xg = np.empty(10)
    fg = np.empty(10)
    f1 = np.empty(10)
    lu = np.empty((10, 10))
    piv = np.empty(10, dtype=np.int64)
    # both stages iterate with I - c J (TR-BDF2's shared matrix), J taken at
    # the start of the substep and refreshed only where Newton stalls
    if not _iteration_matrix(x, c, y0, v_tr, cmds, load, P, f0, lu, piv):
        return False
    if not _newton(x + c * f0, x, c, yg, v_tr, cmds, load, P, max_newton, xg, fg, lu, piv,
                   True):
        return False
    if not _newton(a * xg - b * x, xg, c, y1, v_bdf, cmds, load, P, max_newton, xn, f1, lu,
                   piv, True):
        return False
    t0 = np.empty(3)
    tg = np.empty(3)
    t1 = np.empty(3)
    _quadrature(x, y0, f0, P, t0)
    _quadrature(xg, yg, fg, P, tg)
    _quadrature(xn, y1, f1, P, t1)
    for i in range(3):
        incr[i] = a * c * (t0[i] + tg[i]) + c * t1[i]
    return True


@njit(cache=True)
def _step(x0, rod, h, s_begin, s_end, substeps, cmds, load, P, max_newton, max_halvings,
          x_end, totals):
    """Integrate from s_begin to s_end of the step [0, h]; returns (status, deepest halving)."""
    # the chamber must hold oil wherever the rod goes within the segment
    ymax = -np.inf
    for k in range(17):
        s = s_begin + (s_end - s_begin) * k / 16.0
        ymax = max(ymax, _hermite(s, rod[0], rod[1], rod[2], rod[3], h))
    if P[_V0] - P[_AD] * (ymax - P[_YREF]) <= 0.0:
        return CHAMBER_EMPTIED, 0
    totals[:] = 0.0
    x = x0.copy()
    xn = np.empty(10)
    incr = np.empty(3)
    deepest = 0
    dt = (s_end - s_begin) / substeps
    # explicit stack of (s0, s1, depth) replaces implicit._integrate's recursion
    stack_s0 = np.empty(2 * max_halvings + 2)
    stack_s1 = np.empty(2 * max_halvings + 2)
    stack_d = np.empty(2 * max_halvings + 2, dtype=np.int64)
    for j in range(substeps):
        top = 0
        stack_s0[0], stack_s1[0], stack_d[0] = s_begin + j * dt, s_begin + (j + 1) * dt, 0
        while top >= 0:
            s0, s1, depth = stack_s0[top], stack_s1[top], stack_d[top]
            top -= 1
            if _substep(x, s0, s1, rod, h, cmds, load, P, max_newton, xn, incr):
                x[:] = xn
                totals += incr
                continue
            if depth == max_halvings:
                return NEWTON_FAILED, deepest
            mid = 0.5 * (s0 + s1)
            deepest = max(deepest, depth + 1)
            # second half below the first: the first half is taken next
            top += 1
            stack_s0[top], stack_s1[top], stack_d[top] = mid, s1, depth + 1
            top += 1
            stack_s0[top], stack_s1[top], stack_d[top] = s0, mid, depth + 1
    x_end[:] = x
    return OK, deepest


def circuit_step(x0, rod0, rod1, h, commands, load, params: CircuitParameters,
                 substeps=1, max_newton=60, max_halvings=10, segment=None):
    """Advance the circuit over one communication step with TR-BDF2, compiled.

    The same method as :func:`system_models.implicit.tr_bdf2` with the rod on
    the cubic Hermite trajectory through ``rod0 = (y, v)`` at 0 and ``rod1``
    at h (as the co-simulation master builds it).

    Parameters
    ----------
    x0 : array of 10
        State at the start (:data:`circuit.STATE_NAMES`), [SI].
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
    segment : (float, float), optional
        Integrate only from s0 to s1 within the step (the rod still on the
        step's Hermite cubic), in ``substeps`` substeps; default (0, h).

    Returns
    -------
    (int, array, float, float, float, int)
        Status (:data:`OK`, :data:`NEWTON_FAILED`, :data:`CHAMBER_EMPTIED`);
        the state at h; the integral of p_P [Pa s]; the net volume into the
        big cavity [m^3]; the oil taken up by compression [m^3]; the deepest
        halving used.
    """
    rod = np.array([rod0[0], rod0[1], rod1[0], rod1[1]], dtype=float)
    x_end = np.empty(10)
    totals = np.zeros(3)
    s0, s1 = (0.0, float(h)) if segment is None else (float(segment[0]), float(segment[1]))
    status, deepest = _step(np.asarray(x0, dtype=float), rod, float(h), s0, s1, int(substeps),
                            np.asarray(commands, dtype=float), float(load), _packed(params),
                            int(max_newton), int(max_halvings), x_end, totals)
    return status, x_end, totals[0], totals[1], totals[2], deepest
