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

Cost per substep (measured on recorded co-simulation calls): a right-hand
side ~0.17 us (the physics' powers and roots), a Jacobian with its LU ~2 us,
a solve with the factors ~0.13 us. Hence the Newton matrix I - c J is kept
while the substep length and the valve commands stay the same -- over a
call's substeps, and with a :class:`Workspace` across calls -- and formed
afresh only where Newton stalls; the BDF2 stage starts from a linear
extrapolation; the last Newton correction is applied without another
right-hand side; and nothing is allocated per substep.

Optionally (``rtol``), the substep lengths follow Hosea & Shampine's error
estimate of TR-BDF2 instead of being fixed (:func:`circuit_step`).

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
def _valve_flow(k, x, p_a, P):
    """Flow through valve V(k+1) at state x, accumulator pressure p_a (as circuit.valve_flows)."""
    j = _VALVE + 5 * k
    if k == 0:
        dp = x[0] - x[1]
    elif k == 1:
        dp = x[1] - p_a
    elif k == 2:
        dp = x[0] - x[2]
    else:
        dp = x[2] - p_a
    return orifice_flow(opening_area(x[6 + k], P[j], P[j + 3]), dp, P[_RHO], P[j + 1], P[j + 2])


@njit(cache=True)
def _accumulator_pressure(x, P):
    return gas_spring_pressure(x[3], P[_P0], P[_VGAS], P[_NACC], P[_KPORT])


@njit(cache=True)
def _chamber_volume(y, P):
    """Pump chamber volume at rod displacement y (as :func:`chamber.chamber_volume`), [m^3]."""
    return P[_V0] - P[_AD] * (y - P[_YREF])


@njit(cache=True)
def _flows(x, P, q):
    """Valve flows V1..V4 into q (as :func:`circuit.valve_flows`)."""
    p_a = _accumulator_pressure(x, P)
    for k in range(4):
        q[k] = _valve_flow(k, x, p_a, P)


@njit(cache=True)
def _rhs(x, y, v, cmds, load, P, out):
    """dx/dt into out (as :func:`circuit.rhs`); y, v the rod's position and velocity.

    The flows are plain scalars: this runs ~10 times per substep, and an
    array for them would be a heap allocation each time.
    """
    p_a = _accumulator_pressure(x, P)
    q0 = _valve_flow(0, x, p_a, P)
    q1 = _valve_flow(1, x, p_a, P)
    q2 = _valve_flow(2, x, p_a, P)
    q3 = _valve_flow(3, x, p_a, P)
    pos, vel = x[4], x[5]
    vb = P[_VDB] + P[_AB] * pos
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - pos)
    vp = _chamber_volume(y, P)
    out[0] = _beta(x[0], P) / vp * (P[_AD] * v - q0 - q2)
    out[1] = _beta(x[1], P) / vb * (q0 - q1 - P[_AB] * vel)
    out[2] = _beta(x[2], P) / vs * (q2 - q3 + P[_AS] * vel)
    out[3] = q1 + q3
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
def _quadrature(x, y, f, P):
    """(p_P, Q_V1 - Q_V2, oil absorbed by compression per second) at x, with f = rhs(x)."""
    p_a = _accumulator_pressure(x, P)
    vp = _chamber_volume(y, P)
    vb = P[_VDB] + P[_AB] * x[4]
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - x[4])
    absorbed = (vp / _beta(x[0], P) * f[0] + vb / _beta(x[1], P) * f[1]
                + vs / _beta(x[2], P) * f[2])
    return x[0], _valve_flow(0, x, p_a, P) - _valve_flow(1, x, p_a, P), absorbed


@njit(cache=True)
def _iteration_matrix(x, dt, y, v, cmds, load, P, f, lu, piv, ft):
    """LU factors of I - dt J at x, J by forward differences; f = rhs(x) given. False if singular.

    ``ft`` is scratch space of 10.
    """
    n = 10
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
    n = 10
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
    for i in range(10):
        g[i] = xn[i] - r[i] - dt * f[i]
        norm = max(norm, abs(g[i]) / RESIDUAL_SCALE[i])
    return norm


#: What :class:`Workspace` keeps between substeps and calls. ``factors_key``
#: says what the LU factors in ``lu, piv`` were made for: [valid (1/0), the
#: coefficient c of I - c J, the four valve commands].
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
def _factorise(x, c, y, v, cmds, load, P, f, lu, piv, key, counts, ft):
    """Factors of I - c J at x (f = rhs(x)) into lu, piv, recorded in key; False if singular."""
    counts[_N_JACOBIANS] += 1
    ok = _iteration_matrix(x, c, y, v, cmds, load, P, f, lu, piv, ft)
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
    for i in range(10):
        size = max(size, abs(delta[i]) / (NEWTON_ATOL[i] + NEWTON_RTOL * abs(x[i])))
    return size


@njit(cache=True)
def _newton(r, guess, dt, y, v, cmds, load, P, max_newton, xn, f, lu, piv, key, counts, work,
            f_guess, y_guess):
    """Solve xn - r - dt f(xn) = 0 by damped Newton (as implicit._newton); True if converged.

    On success ``f`` holds rhs(xn) (see below), which the caller's
    quadrature needs.

    ``lu, piv`` hold the factors of I - dt J from an earlier point (TR-BDF2's
    two stages share the matrix, and so do the substeps of one length);
    they are refreshed at the current iterate whenever an iteration leaves
    more than :data:`_STALL` of the residual (simplified Newton stalling).
    ``work`` is scratch space (rows :data:`_FT` ... :data:`_TRIAL`).

    ``f_guess``, if not None, is rhs(guess) at another rod position
    ``y_guess`` but the same velocity v (the trapezoidal stage starts from
    the substep's start, where the caller has it at y(s0)): y enters rhs only
    through the chamber's volume in dp_P/dt, so rescaling that one term
    saves a right-hand side.

    Converged: when the full Newton correction is within the tolerance
    (:func:`_step_size`; implicit._newton tests the step it took, damped or
    not). That correction is applied with f moved along the linear model
    rather than evaluated again (one right-hand side less per stage): on
    success ``f`` is rhs(xn) to within the linearisation error of a step
    smaller than the tolerance.
    """
    n = 10
    ft, g, gt, delta, trial = work[_FT], work[_G], work[_GT], work[_DELTA], work[_TRIAL]
    xn[:] = guess
    if f_guess is None:
        _rhs(xn, y, v, cmds, load, P, f)
    else:
        f[:] = f_guess
        f[0] *= _chamber_volume(y_guess, P) / _chamber_volume(y, P)
    norm = _residual(xn, r, dt, f, g)
    fresh = True
    for _ in range(max_newton):
        counts[_N_NEWTON] += 1
        if not fresh:
            if not _factorise(xn, dt, y, v, cmds, load, P, f, lu, piv, key, counts, ft):
                return False
            fresh = True
        for i in range(n):
            delta[i] = -g[i]
        _lu_solve(lu, piv, delta)
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
            _rhs(trial, y, v, cmds, load, P, ft)
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
def _hermite(s, y0, v0, y1, v1, h):
    """Rod position at s into the step on the cubic through (y0, v0), (y1, v1)."""
    dy = y1 - y0
    r = s / h
    return (y0 + v0 * s + (3.0 * dy - h * (2.0 * v0 + v1)) * r * r
            + (h * (v0 + v1) - 2.0 * dy) * r * r * r)


@njit(cache=True)
def _stages(x, f0, c, y0, yg, v_tr, y1, v_bdf, cmds, load, P, max_newton, xn, lu, piv, key,
            counts, work, predict):
    """TR-BDF2's two implicit stages from x (f0 = rhs(x) at y0); True if both converged.

    The trapezoidal stage xg = x + c (f0 + f(xg)) starts from x. The BDF2
    stage xn = a xg - b x + c f(xn) starts, when ``predict``, from the line
    through x and xg extended to the end of the substep (the solution's
    drift carries on), else from xg as implicit._trbdf2_substep does.
    """
    gam = TRBDF2_GAMMA
    a = 1.0 / (gam * (2.0 - gam))
    b = (1.0 - gam) ** 2 / (gam * (2.0 - gam))
    xg, fg, f1, r, guess = work[_XG], work[_FG], work[_F1], work[_R], work[_GUESS]
    for i in range(10):
        r[i] = x[i] + c * f0[i]
    if not _newton(r, x, c, yg, v_tr, cmds, load, P, max_newton, xg, fg, lu, piv, key, counts,
                   work, f0, y0):
        return False
    for i in range(10):
        r[i] = a * xg[i] - b * x[i]
        guess[i] = x[i] + (xg[i] - x[i]) / gam if predict else xg[i]
    return _newton(r, guess, c, y1, v_bdf, cmds, load, P, max_newton, xn, f1, lu, piv, key,
                   counts, work, None, 0.0)


@njit(cache=True)
def _hermite_rate(s, y0, v0, y1, v1, h):
    """Rod velocity at s into the step: the derivative of :func:`_hermite`."""
    dy = y1 - y0
    r = s / h
    return (v0 + 2.0 * (3.0 * dy - h * (2.0 * v0 + v1)) * r / h
            + 3.0 * (h * (v0 + v1) - 2.0 * dy) * r * r / h)


#: Hosea & Shampine's (1996) error estimate of TR-BDF2: the difference to
#: the third-order formula through the same three stages, in units of
#: dt (f_n, f_gamma, f_n+1): with w = sqrt(2)/4 and d = gamma/2,
#: ((1 - w)/3 - w, (3w + 1)/3 - w, d/3 - d).
_W = np.sqrt(2.0) / 4.0
_E0, _EG, _E1 = (1.0 - 4.0 * _W) / 3.0, 1.0 / 3.0, -2.0 / 3.0 * (TRBDF2_GAMMA / 2.0)


@njit(cache=True)
def _error_estimate(x, xn, s0, s1, rod, h, v_tr, v_bdf, P, lu, piv, work, rtol):
    """Scaled local error of the substep just taken (<= 1: within ``rtol``).

    Hosea & Shampine (Applied Numerical Mathematics 20, 1996): the embedded
    estimate h (e0 f_n + eg f_gamma + e1 f_n+1), filtered by (I - d h J)^-1
    (Shampine's device for stiff problems: the raw difference overrates the
    error of components that decay fast) with the factors Newton used.
    The stages' f carry the rod velocity each stage's formula implies
    (secants, see implicit.tr_bdf2); the estimate takes the rod's own
    velocity there, which enters f only through the chamber's p_P equation.
    The norm: max over states of |error| / (rtol max(|x|, |x_new|, typical
    size)), the typical sizes being those of the difference Jacobian.
    """
    gam = TRBDF2_GAMMA
    dt = s1 - s0
    sg = s0 + gam * dt
    f0, fg, f1, e = work[_F0], work[_FG], work[_F1], work[_DELTA]
    xg = work[_XG]
    for i in range(10):
        e[i] = dt * (_E0 * f0[i] + _EG * fg[i] + _E1 * f1[i])
    # the chamber's equation at the rod's own velocity
    for s, xs, v_used, w in ((s0, x, v_tr, _E0), (sg, xg, v_tr, _EG), (s1, xn, v_bdf, _E1)):
        y = _hermite(s, rod[0], rod[1], rod[2], rod[3], h)
        v = _hermite_rate(s, rod[0], rod[1], rod[2], rod[3], h)
        e[0] += dt * w * _beta(xs[0], P) / _chamber_volume(y, P) * P[_AD] * (v - v_used)
    _lu_solve(lu, piv, e)
    norm = 0.0
    for i in range(10):
        size = max(abs(x[i]), abs(xn[i]), _FD_SCALE[i])
        norm = max(norm, abs(e[i]) / (rtol * size))
    return norm


@njit(cache=True)
def _substep(x, s0, s1, rod, h, cmds, load, P, max_newton, xn, incr, lu, piv, key, counts,
             reuse, work, rtol):
    """One TR-BDF2 substep (as implicit._trbdf2_substep); True if both Newton solves converged.

    Both stages iterate with I - c J (TR-BDF2's shared matrix). The factors
    in ``lu, piv`` are kept from earlier substeps when ``reuse`` and they fit
    (:func:`_factors_fit`): the substep then costs no Jacobian unless Newton
    stalls. Should Newton fail, the substep is tried again exactly as
    implicit._trbdf2_substep does it (J at x, each stage starting from the
    last solution) before the caller halves it: kept factors or the BDF2
    predictor never cause a halving the reference would not make.

    ``incr`` gets the three quadratures' increments and, when ``rtol`` > 0,
    the scaled local error (:func:`_error_estimate`) in incr[3].
    """
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
    counts[_N_SUBSTEPS] += 1
    f0 = work[_F0]
    _rhs(x, y0, v_tr, cmds, load, P, f0)
    if not (reuse and _factors_fit(key, c, cmds)):
        if not _factorise(x, c, y0, v_tr, cmds, load, P, f0, lu, piv, key, counts, work[_FT]):
            return False
    if not _stages(x, f0, c, y0, yg, v_tr, y1, v_bdf, cmds, load, P, max_newton, xn, lu, piv,
                   key, counts, work, True):
        if not _factorise(x, c, y0, v_tr, cmds, load, P, f0, lu, piv, key, counts, work[_FT]):
            return False
        if not _stages(x, f0, c, y0, yg, v_tr, y1, v_bdf, cmds, load, P, max_newton, xn, lu,
                       piv, key, counts, work, False):
            return False
    xg, fg, f1 = work[_XG], work[_FG], work[_F1]
    p0, q0, c0 = _quadrature(x, y0, f0, P)
    pg, qg, cg = _quadrature(xg, yg, fg, P)
    p1, q1, c1 = _quadrature(xn, y1, f1, P)
    # BDF2 combination of the trapezoidal stage (the quadrature starts at 0)
    incr[0] = a * c * (p0 + pg) + c * p1
    incr[1] = a * c * (q0 + qg) + c * q1
    incr[2] = a * c * (c0 + cg) + c * c1
    incr[3] = 0.0
    if rtol > 0.0:
        incr[3] = _error_estimate(x, xn, s0, s1, rod, h, v_tr, v_bdf, P, lu, piv, work, rtol)
    return True


@njit(cache=True)
def _chamber_holds_oil(rod, h, s_begin, s_end, P):
    """Whether the chamber keeps a positive volume wherever the rod goes in [s_begin, s_end]."""
    ymax = -np.inf
    for k in range(17):
        s = s_begin + (s_end - s_begin) * k / 16.0
        ymax = max(ymax, _hermite(s, rod[0], rod[1], rod[2], rod[3], h))
    return _chamber_volume(ymax, P) > 0.0


@njit(cache=True)
def _step(x0, inputs, h, s_begin, s_end, substeps, grid, load, P, max_newton, max_halvings,
          out, lu, piv, key, counts, reuse):
    """Integrate from s_begin to s_end of the step [0, h]; returns (status, deepest halving).

    ``inputs`` = (y, v at 0, y, v at h, the four commands). The substeps:
    ``substeps`` equal ones, or, if ``grid`` is not empty, from each of its
    entries to the next (its first s_begin, its last s_end). The state at
    the end goes to out[:10], the three quadratures to out[10:13].
    """
    rod = inputs[:4]
    cmds = inputs[4:8]
    if not _chamber_holds_oil(rod, h, s_begin, s_end, P):
        return CHAMBER_EMPTIED, 0
    totals = np.zeros(3)
    x = x0.copy()
    xn = np.empty(10)
    incr = np.empty(4)
    work = np.empty((_N_WORK, 10))
    deepest = 0
    n = substeps if grid.size == 0 else grid.size - 1
    dt = (s_end - s_begin) / n
    # explicit stack of (s0, s1, depth) replaces implicit._integrate's recursion
    stack_s0 = np.empty(2 * max_halvings + 2)
    stack_s1 = np.empty(2 * max_halvings + 2)
    stack_d = np.empty(2 * max_halvings + 2, dtype=np.int64)
    for j in range(n):
        top = 0
        if grid.size == 0:
            stack_s0[0], stack_s1[0] = s_begin + j * dt, s_begin + (j + 1) * dt
        else:
            stack_s0[0], stack_s1[0] = grid[j], grid[j + 1]
        stack_d[0] = 0
        while top >= 0:
            s0, s1, depth = stack_s0[top], stack_s1[top], stack_d[top]
            top -= 1
            if _substep(x, s0, s1, rod, h, cmds, load, P, max_newton, xn, incr, lu, piv, key,
                        counts, reuse, work, 0.0):
                x[:] = xn
                totals += incr[:3]
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
    out[:10] = x
    out[10:] = totals
    return OK, deepest


#: Step-size control: dt_new = dt * SAFETY * err^(-1/3) (a local error of
#: order 3), within [SHRINK_MIN, GROW_MAX] times dt; a substep that would
#: grow by less than GROW_MIN keeps its length (a new length means a new
#: Newton matrix, ~2 us).
_SAFETY, _SHRINK_MIN, _GROW_MIN, _GROW_MAX = 0.9, 0.2, 1.5, 4.0


@njit(cache=True)
def _step_controlled(x0, inputs, h, s_begin, s_end, dt_start, rtol, load, P, max_newton,
                     max_halvings, out, lu, piv, key, counts, reuse, grid, control):
    """As :func:`_step`, with substep lengths chosen for the local error ``rtol``.

    Starts with substeps of ``dt_start``. A substep is repeated shorter when
    its error (:func:`_error_estimate`) exceeds 1 or when Newton fails (then
    halved); lengths are always remainder / an integer, so that while the
    proposal holds every substep has the same length and Newton keeps its
    matrix. Writes the boundaries taken into ``grid`` and returns (status,
    number of boundaries, deepest halving for Newton); control[0] gets the
    length the last substep's error proposes for the next call, control[1]
    the substeps rejected for their error.
    """
    rod = inputs[:4]
    cmds = inputs[4:8]
    if not _chamber_holds_oil(rod, h, s_begin, s_end, P):
        return CHAMBER_EMPTIED, 0, 0
    totals = np.zeros(3)
    x = x0.copy()
    xn = np.empty(10)
    incr = np.empty(4)
    work = np.empty((_N_WORK, 10))
    dt_min = (s_end - s_begin) / 2.0 ** max_halvings
    deepest = 0
    failures = 0  # successive Newton failures
    s = s_begin
    grid[0] = s
    n_grid = 1
    dt_try = min(dt_start, s_end - s_begin)
    while s_end - s > 1e-12 * (s_end - s_begin):
        left = s_end - s
        n = max(1, int(np.ceil(left / dt_try - 1e-9)))
        s1 = s_end if n == 1 else s + left / n
        dt = s1 - s
        if not _substep(x, s, s1, rod, h, cmds, load, P, max_newton, xn, incr, lu, piv, key,
                        counts, reuse, work, rtol):
            failures += 1
            deepest = max(deepest, failures)
            if dt <= dt_min or failures > max_halvings:
                return NEWTON_FAILED, n_grid, deepest
            dt_try = 0.5 * dt
            continue
        failures = 0
        err = incr[3]
        factor = _SAFETY * (max(err, 1e-12) ** (-1.0 / 3.0))
        if err > 1.0 and dt > dt_min:
            control[1] += 1
            dt_try = max(dt * max(factor, _SHRINK_MIN), dt_min)
            continue
        x[:] = xn
        totals += incr[:3]
        s = s1
        if n_grid == grid.size:
            return NEWTON_FAILED, n_grid, deepest  # more substeps than the grid holds
        grid[n_grid] = s
        n_grid += 1
        # dt_try >= dt (dt fits the remainder): keep it unless the error asks
        # to shrink, or to grow by enough to be worth a new matrix
        proposal = dt * min(factor, _GROW_MAX)
        if proposal < dt or proposal > _GROW_MIN * dt_try:
            dt_try = proposal
        control[0] = dt_try
    grid[n_grid - 1] = s_end
    out[:10] = x
    out[10:] = totals
    return OK, n_grid, deepest


class Workspace:
    """What :func:`circuit_step` may keep from one call to the next: LU factors, counters.

    Every substep of TR-BDF2 solves two implicit stages with the matrix
    I - c J (c = (1 - 1/sqrt 2) times the substep). Building it is the
    substep's largest single cost (ten extra right-hand sides for J by
    differences, and an LU), yet over a few substeps of equal length J moves
    little: Newton converges with the old factors, and refreshes them itself
    where it stalls. One workspace carries the factors across the substeps of
    a call -- and, passed to successive calls, across calls (the co-simulation's
    interface iterations and communication steps). The results then depend on
    which factors were kept only within Newton's tolerance.

    With error control (``circuit_step(..., rtol=...)``) it also keeps the
    substep length the last call proposes, and the substeps a call chose, so
    that a call repeating the same start (an interface iteration) takes the
    same substeps (see :func:`circuit_step`).

    Parameters
    ----------
    reuse_factors : bool
        False takes a fresh Jacobian at the start of every substep (the
        kernel's behaviour before factors were kept; for comparisons).

    Attributes
    ----------
    counts : int array of 3
        Running totals: substeps attempted (halved and rejected ones
        included), Newton iterations (both stages), Jacobians formed and
        factorised.
    control : float array of 2
        Error control: the substep length proposed for the next call [s]
        (0: none yet); the running count of substeps rejected for their error.
    """

    def __init__(self, reuse_factors: bool = True):
        self.reuse_factors = bool(reuse_factors)
        self.lu = np.zeros((10, 10))
        self.piv = np.zeros(10, dtype=np.int64)
        self.factors_key = np.zeros(2 + 4)  # see _KEY_VALID; invalid at first
        self.counts = np.zeros(3, dtype=np.int64)
        self.control = np.zeros(2)
        self.grid = np.empty(0)  # substep boundaries of the last controlled call
        self.grid_key = None  # (x0, segment, h) of that call

    def forget(self):
        """Drop the kept factors and substeps (the next call starts afresh)."""
        self.factors_key[_KEY_VALID] = 0.0
        self.grid_key = None
        self.control[0] = 0.0


def circuit_step(x0, rod0, rod1, h, commands, load, params: CircuitParameters,
                 substeps=1, max_newton=60, max_halvings=10, segment=None, workspace=None,
                 rtol=None):
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
    workspace : Workspace, optional
        Keeps the Newton matrix's factors for the next call (and counts the
        work done). Without it each call starts from a fresh Jacobian and
        keeps its factors over its own substeps only; a call's result is then
        a function of its arguments alone.
    rtol : float, optional
        Error control (default off: ``substeps`` equal substeps). The
        substep lengths are chosen so that each substep's local error
        (Hosea & Shampine's estimate) stays within rtol relative to each
        state (or to its typical size, when smaller); ``substeps`` then only
        sets the first call's starting length, the workspace's proposal the
        later ones'. A call with the same x0, segment and h as the
        workspace's last controlled call takes that call's substeps again,
        without control: the interface iterations of one communication
        step see one discretisation, so the interface residual varies
        smoothly with the force. A substep rejected for its error does not
        count as a halving; a Newton failure does.

    Returns
    -------
    (int, array, float, float, float, int)
        Status (:data:`OK`, :data:`NEWTON_FAILED`, :data:`CHAMBER_EMPTIED`);
        the state at h; the integral of p_P [Pa s]; the net volume into the
        big cavity [m^3]; the oil taken up by compression [m^3]; the deepest
        halving used.
    """
    if workspace is None:
        ws = _ONE_CALL
        ws.forget()
    else:
        ws = workspace
    inputs = np.array([rod0[0], rod0[1], rod1[0], rod1[1], commands[0], commands[1],
                       commands[2], commands[3]], dtype=float)
    x0 = np.asarray(x0, dtype=float)
    out = np.empty(13)
    s0, s1 = (0.0, float(h)) if segment is None else (float(segment[0]), float(segment[1]))
    common = (float(load), _packed(params), int(max_newton), int(max_halvings), out, ws.lu,
              ws.piv, ws.factors_key, ws.counts, ws.reuse_factors)
    if rtol is None:
        status, deepest = _step(x0, inputs, float(h), s0, s1, int(substeps), _NO_GRID, *common)
        return status, out[:10], out[10], out[11], out[12], deepest
    key = (x0.tobytes(), s0, s1, float(h))
    if ws.grid_key == key:
        status, deepest = _step(x0, inputs, float(h), s0, s1, ws.grid.size - 1, ws.grid,
                                *common)
        return status, out[:10], out[10], out[11], out[12], deepest
    size = 2 ** int(max_halvings) + 2
    if ws.grid.size < size:
        ws.grid = np.empty(size)
    dt_start = ws.control[0] if ws.control[0] > 0.0 else (s1 - s0) / int(substeps)
    status, n_grid, deepest = _step_controlled(x0, inputs, float(h), s0, s1, dt_start,
                                               float(rtol), *common, ws.grid, ws.control)
    if status == OK:
        ws.grid = ws.grid[:n_grid].copy()
        ws.grid_key = key
    return status, out[:10], out[10], out[11], out[12], deepest


#: The workspace of calls that bring none: its factors are dropped at the
#: start of each call, so that the call's result depends on its arguments
#: alone (one object rather than a new one per call: ~1 us less per call).
_ONE_CALL = Workspace()
_NO_GRID = np.empty(0)
