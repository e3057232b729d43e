"""The co-simulation's hot loop, compiled: TR-BDF2 steps of the circuit and of the plant.

What and why
------------
Each communication step integrates the stiff hydraulics: TR-BDF2 (two
damped-Newton solves a substep, each needing the right-hand side a few times
and its Jacobian). In Python every one of those is hundreds of tiny numpy and
attribute operations (~4 ms per step); the same arithmetic on plain floats,
compiled by numba, takes microseconds.

What is compiled is the *numerical method* only: the assembly of the
equations (the same as :func:`system_models.circuit.rhs` and
:func:`system_models.plant.rhs`), damped Newton, TR-BDF2 and the halving of
a failing substep (the same as :mod:`system_models.implicit`). The *physics*
is not rewritten: the kernel calls the components' plain-number functions
(``mixture_bulk_modulus``, ``orifice_flow``, ``opening_area``,
``gas_spring_pressure``, ``piston_acceleration_of``, ``rod_rates``), which
the readable modules use themselves and ``numba.extending.register_jitable``
lets numba compile. The Jacobian is by forward differences (a dozen
evaluations of compiled arithmetic cost less than one call of an analytic
Python Jacobian). ``tests/test_kernel.py`` checks the right-hand sides
against the readable ones to round-off, the circuit's step against
:func:`implicit.tr_bdf2` to the Newton tolerance and the plant's steps
against scipy's Radau (different numerics) to TR-BDF2's own error.

Two ways the rod enters (:mod:`system_models.cosim`'s two couplings):

* **prescribed** (displacement port, :func:`circuit_step`): the 10 circuit
  states (:data:`system_models.circuit.STATE_NAMES`), the rod moving on the
  cubic Hermite path through (y, v) at both ends of the step;
* **integrated** (force port, :func:`plant_run`): the plant's states, the
  circuit's and then the rod's (:mod:`system_models.rod`: 2 or 4), the
  magnetostrictive force given at both ends of each step and interpolated
  linearly (equal ends: held).

Cost per substep (measured on recorded co-simulation calls): a right-hand
side ~0.17 us (the physics' powers and roots), a Jacobian with its LU ~2 us,
a solve with the factors ~0.13 us. Hence the Newton matrix I - c J is kept
while the substep length and the valve commands stay the same -- over a
call's substeps and steps -- and formed afresh only where Newton stalls; the
BDF2 stage starts from a linear extrapolation; the last Newton correction is
applied without another right-hand side; and nothing is allocated per
substep.

Parameters travel as one float array (:func:`pack`).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
from numba import njit

from .accumulator import gas_spring_pressure
from .circuit import CircuitParameters
from .cylinder import piston_acceleration_of
from .fluid import MINIMUM_PRESSURE, mixture_bulk_modulus
from .implicit import NEWTON_ATOL, RESIDUAL_SCALE, TRBDF2_GAMMA
from .rod import RodParameters, rod_rates
from .valves import opening_area, orifice_flow

# indices into the packed parameter array (see :func:`pack`)
_RHO, _BETA, _AIR, _PREF, _NAIR = 0, 1, 2, 3, 4
_V0, _AD, _YREF = 5, 6, 7
_AB, _AS, _VDB, _VDS, _STROKE, _MASS, _FRIC, _KSTOP, _CSTOP = 8, 9, 10, 11, 12, 13, 14, 15, 16
_P0, _VGAS, _NACC, _KPORT = 17, 18, 19, 20
_VALVE = 21  # then per valve: area, C_d, transition pressure, leakage, tau (0: not first order)
_ROD = _VALVE + 4 * 5  # then: rod states (0: prescribed rod), m, c, K, m_2, k_j, c_j
_NPACK = _ROD + 7

#: Circuit states.
NC = 10
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


@lru_cache(maxsize=64)
def pack(params: CircuitParameters, rod: RodParameters | None = None) -> np.ndarray:
    """The parameters as the kernel's float array (SI); cached per circuit and rod.

    ``rod`` None: the circuit alone (the rod prescribed, :func:`circuit_step`);
    given: the plant (:func:`plant_run`).
    """
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
    if rod is None:
        values += [0.0] * 7
    else:
        values += [float(rod.size), rod.mass, rod.damping, rod.stiffness, rod.output_mass,
                   rod.joint_stiffness, rod.joint_damping]
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out


def state_size(packed: np.ndarray) -> int:
    """Number of states the packed parameters describe (10 + the rod's)."""
    return NC + int(packed[_ROD])


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
def _chamber_side(x, P):
    """(y, v) of the rod's end in the chamber, for the plant's states (one or two masses)."""
    if P[_ROD] == 4.0:
        return x[12], x[13]
    return x[10], x[11]


@njit(cache=True)
def _flows(x, P, q):
    """Valve flows V1..V4 into q (as :func:`circuit.valve_flows`)."""
    p_a = _accumulator_pressure(x, P)
    for k in range(4):
        q[k] = _valve_flow(k, x, p_a, P)


@njit(cache=True)
def _circuit_rates(x, y, v, cmds, load, P, out):
    """The circuit's dx/dt into out[:10] (as :func:`circuit.rhs`); y, v the rod's position
    and velocity.

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


@njit(cache=True)
def _rates(x, a, b, cmds, load, P, out):
    """dx/dt into out. Prescribed rod: a = y, b = v. Plant: a = the force F [N] (b unused)."""
    nrod = P[_ROD]
    if nrod == 0.0:
        _circuit_rates(x, a, b, cmds, load, P, out)
        return
    y, v = _chamber_side(x, P)
    _circuit_rates(x, y, v, cmds, load, P, out)
    two = nrod == 4.0
    d = rod_rates(x[10], x[11], x[12] if two else 0.0, x[13] if two else 0.0, a,
                  P[_AD] * x[0], P[_ROD + 1], P[_ROD + 2], P[_ROD + 3], P[_ROD + 4],
                  P[_ROD + 5], P[_ROD + 6])
    out[10], out[11] = d[0], d[1]
    if two:
        out[12], out[13] = d[2], d[3]


def _packed(params) -> np.ndarray:
    return params if isinstance(params, np.ndarray) else pack(params)


def flows(x, params) -> np.ndarray:
    """Valve flows V1..V4 at state x, compiled (as :func:`circuit.valve_flows`), [m^3/s].

    ``params``: a CircuitParameters or a :func:`pack`.
    """
    q = np.empty(4)
    _flows(np.asarray(x, dtype=float), _packed(params), q)
    return q


def accumulator_pressure(x, params) -> float:
    """Accumulator pressure at state x, compiled (as :func:`accumulator.accumulator_pressure`)."""
    return _accumulator_pressure(np.asarray(x, dtype=float), _packed(params))


def rates(x, a, b, commands, load, packed) -> np.ndarray:
    """Python entry to the compiled right-hand side (for tests): dx/dt.

    ``packed`` from :func:`pack`; with a rod, ``a`` is the force [N] and ``b``
    is ignored, else they are the rod's y [m] and v [m/s].
    """
    x = np.asarray(x, dtype=float)
    out = np.empty(x.size)
    _rates(x, float(a), float(b), np.asarray(commands, dtype=float), float(load), packed, out)
    return out


@njit(cache=True)
def _quadrature(x, y, f, P):
    """(p_P, Q_V1 - Q_V2, oil absorbed by compression per second) at x, with f = rates(x)."""
    p_a = _accumulator_pressure(x, P)
    vp = _chamber_volume(y, P)
    vb = P[_VDB] + P[_AB] * x[4]
    vs = P[_VDS] + P[_AS] * (P[_STROKE] - x[4])
    absorbed = (vp / _beta(x[0], P) * f[0] + vb / _beta(x[1], P) * f[1]
                + vs / _beta(x[2], P) * f[2])
    return x[0], _valve_flow(0, x, p_a, P) - _valve_flow(1, x, p_a, P), absorbed


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
def _hermite(s, y0, v0, y1, v1, h):
    """Rod position at s into the step on the cubic through (y0, v0), (y1, v1)."""
    dy = y1 - y0
    r = s / h
    return (y0 + v0 * s + (3.0 * dy - h * (2.0 * v0 + v1)) * r * r
            + (h * (v0 + v1) - 2.0 * dy) * r * r * r)


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
def _chamber_holds_oil(drive, h, P):
    """Whether the chamber keeps a positive volume wherever a prescribed rod goes in [0, h]."""
    ymax = -np.inf
    for k in range(17):
        ymax = max(ymax, _hermite(h * k / 16.0, drive[0], drive[1], drive[2], drive[3], h))
    return _chamber_volume(ymax, P) > 0.0


@njit(cache=True)
def _hold_valves(x, cmds, P):
    """Valves without their own dynamics (ideal, dead time) take their command at once."""
    for k in range(4):
        if P[_VALVE + 5 * k + 4] == 0.0:
            x[6 + k] = cmds[k]


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


@njit(cache=True)
def _workspace(n, max_halvings):
    """Scratch arrays of one call: LU factors and pivots, their key, counts, work, stacks."""
    key = np.zeros(2 + 4)
    return (np.empty((n, n)), np.zeros(n, dtype=np.int64), key,
            np.zeros(3, dtype=np.int64), np.empty((_N_WORK, n)), np.empty(n), np.empty(3),
            np.empty(2 * max_halvings + 2), np.empty(2 * max_halvings + 2),
            np.empty(2 * max_halvings + 2, dtype=np.int64))


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


def compiled() -> bool:
    """Whether numba's on-disk cache holds the kernel's compiled code (else the first call
    compiles it, ~20 s on this project's machine, and caches it next to this file)."""
    try:
        folder = Path(_plant_run._cache.cache_path)  # numba's FunctionCache
    except AttributeError:  # another numba: assume not
        return False
    line = _plant_run.py_func.__code__.co_firstlineno
    return any(folder.glob(f"{Path(__file__).stem}._plant_run-{line}.py*.nbi"))


def ensure_compiled(say=None) -> None:
    """Compile the kernel's entry points now if numba's cache does not hold them, telling
    ``say`` (a callable taking a message) first: a run, or worker processes spawned after
    this, then load the compiled code instead of each compiling it."""
    if compiled():
        return
    if say is not None:
        say("compiling the hydraulic kernel (numba; the first run only, ~20 s, then cached)")
    circuit = CircuitParameters()
    packed = pack(circuit, RodParameters())
    x = np.concatenate((np.full(3, 1.5e6), [1e-5, 0.025, 0.0, 0.0, 0.0, 0.0, 0.0],
                        [7e-5, 0.0]))
    plant_run(x, [1e-5], [[1400.0, 1400.0]], [[1.0, 0.0, 0.0, 1.0]], 0.0, packed)
    circuit_step(x[:10], (7e-5, 0.0), (7e-5, 0.0), 1e-5, (1.0, 0.0, 0.0, 1.0), 0.0, circuit)
    flows(x, packed)
    accumulator_pressure(x, packed)

