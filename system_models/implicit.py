"""Implicit integration of the hydraulic circuit over one step: the readable reference.

The orifices and the stiff oil give the circuit time constants near 1 us
(V / (beta dQ/dp) for an open valve and a 2.5 cm^3 chamber), far below a
communication step: only an L-stable implicit method can step it.
:func:`tr_bdf2` (second order, L-stable) with damped Newton on the analytic
Jacobian (:func:`system_models.circuit.jacobian`) and recursive halving of a
substep whose Newton iteration fails. It feeds the chamber the rod velocity
its own formula implies, so the volume the rod sweeps is exact, and returns
the flow and compression volumes as quadratures of the same method, so the
oil volume balance closes to the Newton tolerance.

The co-simulation runs the same method compiled (:mod:`system_models.kernel`,
held to this one by ``tests/test_kernel.py``); this module keeps it readable
and sets the tolerances both use.
"""
from __future__ import annotations

import numpy as np

from gmt.errors import RunError

from .chamber import chamber_volume
from .circuit import CircuitParameters, jacobian, rhs, valve_flows
from .cylinder import cavity_volumes
from .fluid import effective_bulk_modulus

#: Newton convergence: absolute tolerance per state (p_P, p_B, p_S [Pa],
#: V_A [m^3], x [m], v [m/s], openings [-]).
NEWTON_ATOL = np.array([1e-3, 1e-3, 1e-3, 1e-18, 1e-13, 1e-10, 1e-12, 1e-12, 1e-12, 1e-12])
NEWTON_RTOL = 1e-10
#: Scale of each state for the residual norm of the line search.
RESIDUAL_SCALE = np.array([1e3, 1e3, 1e3, 1e-12, 1e-9, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6])


def _norm(residual):
    return float(np.max(np.abs(residual) / RESIDUAL_SCALE))


class IntegrationError(RunError):
    """Newton's method did not converge within a substep."""


class CavitationError(IntegrationError):
    """The integration stopped where a pressure reached the oil's floor
    (:data:`~system_models.fluid.MINIMUM_PRESSURE`): the oil would cavitate there."""


#: The circuit's pressures (state indices 0-2) and their volumes' names.
PRESSURE_NAMES = ("pump chamber", "big cavity", "small cavity")


def integration_failure(x, time: float, step: float) -> IntegrationError:
    """The error for a run whose Newton failed at ``time`` [s] in a step of ``step`` [s]
    from circuit state ``x``.

    With entrained air the integrator refuses a stage below the air model's floor
    (:data:`~system_models.fluid.MINIMUM_PRESSURE`, where a real oil cavitates), so a
    volume sucked towards vacuum (e.g. a cavity under an assisting load that over-runs
    the pump) ends in a failed Newton with its pressure at that floor: a
    :class:`CavitationError` naming the volume. Otherwise the message suggests a
    shorter hydraulic step.
    """
    from .fluid import MINIMUM_PRESSURE
    k = int(np.argmin(x[:3]))
    if x[k] < 2.0 * MINIMUM_PRESSURE:
        return CavitationError(
            f"the {PRESSURE_NAMES[k]}'s pressure has fallen to {x[k]:.0f} Pa absolute at "
            f"t = {time:g} s, the oil's cavitation limit ({MINIMUM_PRESSURE:g} Pa): a real oil "
            f"would cavitate there, which the plant does not model (an assisting load that "
            f"over-runs the pump does this: the cylinder moves faster than the pump fills it)")
    return IntegrationError(f"the plant's Newton did not converge at t = {time:g} s (step "
                            f"{step:g} s); give a shorter hydraulic_step")


def _integrate(x0, h, substeps, substep, max_halvings):
    """Run ``substep(x, s0, s1) -> (x_new, quadrature increments) or None`` over h.

    A substep whose Newton iteration fails (None) is halved, recursively, at
    most ``max_halvings`` times. Returns the state, the three quadratures and
    the deepest halving used.
    """
    totals = np.zeros(3)
    deepest = 0

    def advance(x, s0, s1, left, depth):
        nonlocal totals, deepest
        result = substep(x, s0, s1)
        if result is None:
            if left == 0:
                raise IntegrationError(f"Newton did not converge on a {s1 - s0:g} s substep")
            mid = 0.5 * (s0 + s1)
            deepest = max(deepest, depth + 1)
            x = advance(x, s0, mid, left - 1, depth + 1)
            return advance(x, mid, s1, left - 1, depth + 1)
        xn, increments = result
        totals = totals + increments
        return xn

    dt = h / substeps
    x = np.array(x0, dtype=float)
    for j in range(substeps):
        x = advance(x, j * dt, (j + 1) * dt, max_halvings, 0)
    return x, float(totals[0]), float(totals[1]), float(totals[2]), deepest


def _newton(x, dt, inputs, params, max_newton, rhs_vector=None, guess=None):
    """Solve xn - dt f(xn) = r by damped Newton; None when it does not converge.

    ``r`` is ``rhs_vector`` (default ``x``: backward Euler); ``guess`` starts
    the iteration (default ``x``).
    """
    eye = np.eye(x.size)
    r = x if rhs_vector is None else rhs_vector
    x = r
    xn = np.array(x if guess is None else guess, dtype=float)
    g = xn - x - dt * rhs(0.0, xn, inputs, params)
    norm = _norm(g)
    for _ in range(max_newton):
        try:
            delta = np.linalg.solve(eye - dt * jacobian(xn, inputs, params), -g)
        except np.linalg.LinAlgError:
            return None
        # Damped Newton. On the orifice law Q ~ sign(dp) sqrt|dp| a full
        # Newton step sends dp to -dp with the same residual: it cycles for
        # ever. Each step must cut the residual in proportion to its length,
        # else it is halved (Armijo with a strict factor).
        lam = 1.0
        while True:
            trial = xn + lam * delta
            g_trial = trial - x - dt * rhs(0.0, trial, inputs, params)
            norm_trial = _norm(g_trial)
            if norm_trial <= (1.0 - 0.5 * lam) * norm or lam < 1.0 / 1024:
                break
            lam *= 0.5
        xn, g, norm = trial, g_trial, norm_trial
        if not np.all(np.isfinite(xn)):
            return None
        if np.all(np.abs(lam * delta) <= NEWTON_ATOL + NEWTON_RTOL * np.abs(xn)):
            return xn
    return None


#: TR-BDF2 (Bank, Coughran, Fichtner, Grosse, Rose & Smith 1985, IEEE Trans.
#: Electron Devices 32; Hosea & Shampine 1996): a trapezoidal stage to
#: t + gamma h, then BDF2 to t + h. gamma = 2 - sqrt(2) makes both stages use
#: the same matrix I - d h J, d = gamma / 2, and the method L-stable.
TRBDF2_GAMMA = 2.0 - np.sqrt(2.0)
TRBDF2_D = TRBDF2_GAMMA / 2.0
_A = 1.0 / (TRBDF2_GAMMA * (2.0 - TRBDF2_GAMMA))
_B = (1.0 - TRBDF2_GAMMA) ** 2 / (TRBDF2_GAMMA * (2.0 - TRBDF2_GAMMA))


def tr_bdf2(x0, h, inputs_at, params: CircuitParameters, substeps: int = 1,
            max_newton: int = 60, max_halvings: int = 10):
    """Advance the circuit by h with TR-BDF2: second order and L-stable.

    Backward Euler's first-order error on the valve and oil transients cost
    about 2 % of the delivered flow at a 20 us step (realistic circuit,
    100 Hz); TR-BDF2 removes it at twice the work of one backward-Euler step.

    Parameters
    ----------
    x0 : array
        State at the start (see :data:`system_models.circuit.STATE_NAMES`).
    h : float
        Step, [s].
    params : CircuitParameters
    substeps : int
        Substeps per step.
    max_newton : int
        Newton iterations per substep before that substep is halved.
    max_halvings : int
        How often a substep may be halved (a valve snapping open across a
        large pressure difference can need it) before giving up.
    inputs_at : callable
        (s, velocity) -> CircuitInputs at time s into the step with the rod's
        velocity as given. The caller's rod position y(s) is read from
        ``inputs_at(s, 0.0).rod_displacement``; each stage is given the rod
        velocity its own formula implies (the secant over the trapezoidal
        stage, the BDF2 difference over the second), so the volume the rod
        sweeps is exact and the volume balance closes to round-off.

    Returns
    -------
    (array, float, float, float, int)
        State at h; integral of p_P [Pa s]; net volume into the big cavity
        (V1 in, V2 out) [m^3]; oil volume taken up by compression in the
        chamber and both cavities, sum(V / beta dp) [m^3]; the most halvings
        any substep needed (0 when none).

    Raises
    ------
    IntegrationError
        Newton failed even on the smallest substep.
    """
    return _integrate(x0, h, substeps,
                      lambda x, s0, s1: _trbdf2_substep(x, s0, s1, inputs_at, params, max_newton),
                      max_halvings)


def _quadrature_terms(x, inputs, params, dx=None):
    """(p_P, Q_V1 - Q_V2, net inflow of the three compressible volumes) at x.

    ``dx`` is rhs(x) when the caller already has it.
    """
    q = valve_flows(x, params)
    if dx is None:
        dx = rhs(0.0, x, inputs, params)
    fl = params.fluid
    vb, vs = cavity_volumes(params.cylinder, x[4])
    vp = chamber_volume(params.chamber, inputs.rod_displacement)
    absorbed = sum(vol / effective_bulk_modulus(fl, x[i]) * dx[i]
                   for i, vol in ((0, vp), (1, vb), (2, vs)))
    return np.array([x[0], q.v1 - q.v2, absorbed])


def _trbdf2_substep(x, s0, s1, inputs_at, params, max_newton):
    """One TR-BDF2 substep: (x_new, quadrature increments), or None if Newton fails."""
    dt = s1 - s0
    sg = s0 + TRBDF2_GAMMA * dt
    y0 = inputs_at(s0, 0.0).rod_displacement
    yg = inputs_at(sg, 0.0).rod_displacement
    y1 = inputs_at(s1, 0.0).rod_displacement
    v_tr = (yg - y0) / (sg - s0)
    v_bdf = (y1 - _A * yg + _B * y0) / (TRBDF2_D * dt)
    in0, ing, in1 = inputs_at(s0, v_tr), inputs_at(sg, v_tr), inputs_at(s1, v_bdf)
    c = TRBDF2_D * dt
    f0 = rhs(0.0, x, in0, params)
    xg = _newton(x, c, ing, params, max_newton, rhs_vector=x + c * f0)
    if xg is None:
        return None
    xn = _newton(x, c, in1, params, max_newton, rhs_vector=_A * xg - _B * x, guess=xg)
    if xn is None:
        return None
    stage1 = c * (_quadrature_terms(x, in0, params, f0) + _quadrature_terms(xg, ing, params))
    # BDF2 combination of the trapezoidal stage (the quadrature starts at 0)
    return xn, _A * stage1 + c * _quadrature_terms(xn, in1, params)
