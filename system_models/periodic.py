"""Periodic steady state of the EHA (transducer + hydraulic circuit), without time stepping.

The flow study (:mod:`smeha.flowstudy`) marches the co-simulation
(:mod:`system_models.cosim`) through eight pumping cycles to read off the
mean cylinder flow of a periodic steady state. This module solves for that
steady state directly. The unknowns are the states at every step of one
period. The equations are the discrete equations the co-simulation steps
through, plus periodicity (the state at t = T is the state at t = 0). Damped
Newton on the sparse Jacobian solves them all at once.

What is kept, and why
---------------------
A time-stepped record of the realistic circuit (100 Hz, 150 N load) shows
which dynamics matter within a cycle:

* the rod, eq 27 with the chamber's force: m y'' + c y' + K y =
  F_magnetostrictive - A_d p_P. The chamber pressure swings between the two
  cavities' pressures (0.1-0.3 MPa, so 130-380 N on A_d and 7-19 um of rod
  against K = 1.963e7 N/m), comparable to the stroke;
* the pump chamber's pressure p_P (continuity, :mod:`.chamber`);
* both cavity pressures p_B, p_S and the piston velocity w (continuity and
  :func:`.cylinder.piston_acceleration`). These are *not* quasi-steady. While
  the big cavity is shut (the expanding half of a "down" cycle), the 1 kg
  piston rings on its oil at ~550 Hz, and p_B swings 1.1-2.1 MPa about its
  mean of 1.6 MPa. While the big cavity is joined to the chamber, the piston
  feels the rod's stiffness through (A_B / A_d)^2, a ~180 Hz mode near the
  pumping frequency. The phase of that ringing at the valve switches decides
  how much oil the chamber takes back;
* the accumulator's pressure ripple (3-4 kPa peak to peak; it feeds the
  cavity joined to it), on the gas spring linearised about its mean pressure
  (the ripple moves 0.14 % of the gas volume, so the error is a few Pa).

What is dropped: two slow drifts that keep the state from being exactly
periodic.

* The piston position x. It advances at q / A_B (4.5 mm/s at 1.4e-6 m^3/s:
  0.35 mm over the study's eight 100 Hz cycles, 1 % of the big cavity's
  volume). Here the cavity volumes are frozen at ``piston_position``
  (default mid-stroke, where the co-simulation starts), with the piston kept
  off its end stops.
* The accumulator's oil inventory. Going down, the accumulator supplies the
  rod's volume, (A_B - A_S) x, and its pressure falls by ~0.2 kPa per 100 Hz
  cycle. Here that mean outflow is removed from the accumulator's continuity
  (the unknown ``accumulator_drift``), so its pressure is periodic about a
  mean set by the circuit's oil charge, below.

The accumulator's mean pressure: the oil charge
-----------------------------------------------
The circuit is closed, so its oil charge, not a free parameter, sets the mean
accumulator pressure. Starting from the co-simulation's initial state (every
volume at :func:`.circuit.initial_state`'s pressure p_0, the rod at rest at its
bias displacement y_0, the piston at x_0), continuity (the bookkeeping of
:func:`.cosim.volume_balance`) keeps

    -A_d (y - y_0) + (A_B - A_S)(x - x_0) + (V_A - V_A(p_0))
        + sum_i V_i int_{p_0}^{p_i} dp / beta_e(p) = 0

over the chamber and both cavities. Its mean over the period closes the
system. The chamber's pressure alone pushes the rod back ~96 um
(1.9 kN / K), and the accumulator refills the chamber: the mean pressure
settles ~7 kPa below p_0 (the time-stepped study's averaging window sits a
further 1-3 kPa lower, after the drift above). Held at p_0 instead, the flow
would come out ~1 % higher, through p_B - p_S = (F_load + p_S (A_S - A_B)) / A_B.
``accumulator_pressure`` fixes the mean pressure instead.

Harmonic balance of the rod
---------------------------
The transducer's current does not depend on the chamber force (the
compensator is open-loop), and eq 27 is linear in that force. So in the
periodic steady state y = y_free - G * (A_d p_P): the free response minus the
response of eq 29's G(s) = 1 / (m s^2 + c s + K) to the chamber force,
harmonic by harmonic. On the co-simulation's sampled model, G is the
zero-order-hold transfer function G_d(z) at z = exp(j k w h)
(:func:`rod_periodic_response`). The solver uses that form for its first
guess. It enforces the same relation in the time domain, as the step
recursion y_{n+1} = a11 y_n + a12 v_n + b1 F_n
(:func:`gmt.mechanics.zoh_matrices`), which keeps the Jacobian sparse.

Discretisation: the displacement port's, on a grid
---------------------------------------------------
So that the fast path and a time-stepped run answer the same question, the
equations are those the co-simulation's displacement port takes
(:mod:`.cosim`, ``coupling="displacement"``) with the valve controller
sampling at the grid step. The grid has N = round(T / h) steps of h = T / N:
the requested step (default :data:`GRID_STEP`), adjusted so a period holds
whole steps.

* The transducer is stepped over the grid as the co-simulation steps it
  (:func:`periodic_drive`): the digital compensator samples u(t_n), the
  continuous uncompensated drive holds u(t_n + h/2); its current, and so its
  magnetostrictive force, depend on u alone.
* The rod's step holds the force at A_d p_P(t_{n+1}), the displacement
  port's implicit interface (cosim docstring, step 5).
* The controller switches at grid points, from u(t_{n+1}) - u(t_n)
  (:func:`.controller.pump_phase`; a :class:`.controller.SampledValveController`
  sampling at h). Each valve acts a dead time later, rounded up to whole steps.
* The circuit takes one TR-BDF2 step per grid step (:func:`.implicit.tr_bdf2`:
  a trapezoidal stage to t_n + gamma h, then BDF2). The rod moves along the
  cubic Hermite path through (y, v) at both ends, and each stage gets the rod
  velocity its own formula implies. The volume into the big cavity uses the
  same quadrature.

The fast path is then the periodic limit of that time-stepped run, less the
two drifts above and whatever transient is left in the run's averaging
window (``tests/test_periodic.py``, ``benchmarks/flow_fastpath.py``); the
force port (the co-simulation's default) converges to the same flow.

Unknowns and equations
----------------------
Per step n there are twelve unknowns (:data:`UNKNOWNS`): y_n and v_n (the rod
at t_n); s_n = (p_P, p_B, p_S, p_A, w) at t_n; and g_n, the same five at the
TR-BDF2 stage t_n + gamma h. Per step there are twelve equations: two for the
rod's step; five for the trapezoidal stage,
g_n - c f(g_n) = s_n + c f(s_n); and five for the BDF2 stage,
s_{n+1} - c f(s_{n+1}) = A g_n - B s_n. Here c = d h, and n + 1 is taken
modulo N: that wrap is the periodicity. One more unknown, the accumulator's
mean outflow, pairs with one more equation: the oil charge above, or the
fixed mean pressure. The Jacobian is block-bidiagonal with one corner block,
one dense row and one dense column. SuperLU
(:func:`scipy.sparse.linalg.splu`) factorises it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sparse
from scipy.sparse.linalg import splu

import gmt
from gmt.errors import ParameterError, check_range
from gmt.mechanics import zoh_matrices

from .accumulator import accumulator_pressure, oil_volume_at
from .chamber import chamber_volume
from .circuit import CircuitParameters, initial_state
from .controller import pump_phase, valve_commands
from .defaults import GRID_STEP
from .cylinder import cavity_volumes, piston_acceleration
from .flowcheck import FlowCheck
from .fluid import effective_bulk_modulus
from .implicit import TRBDF2_D, TRBDF2_GAMMA
from .valves import open_area, orifice_flow, orifice_flow_derivative

#: TR-BDF2's combination coefficients (:mod:`.implicit`): x_{n+1} - c f(x_{n+1})
#: = A x_g - B x_n, with c = d h.
_A = 1.0 / (TRBDF2_GAMMA * (2.0 - TRBDF2_GAMMA))
_B = (1.0 - TRBDF2_GAMMA) ** 2 / (TRBDF2_GAMMA * (2.0 - TRBDF2_GAMMA))

#: Unknowns per step, in this order (the stage's five at t_n + gamma h).
UNKNOWNS = ("rod_displacement", "rod_velocity", "p_pump", "p_big", "p_small",
            "p_accumulator", "piston_velocity", "stage_p_pump", "stage_p_big",
            "stage_p_small", "stage_p_accumulator", "stage_piston_velocity")
_NV = len(UNKNOWNS)
_NS = 5  # circuit states (p_P, p_B, p_S, p_A, w)
_S, _G = 2, 2 + _NS  # offsets of s_n and g_n in a step's unknowns (and of the stages' rows)

#: Newton stops when every update is below this, per unknown
#: ([m, m/s, Pa, Pa, Pa, Pa, m/s] and the stage's five), and the
#: accumulator's mean outflow [m^3/s]. The tolerances match the
#: co-simulation's own Newton (:data:`.implicit.NEWTON_ATOL`).
NEWTON_ATOL = np.array([1e-13, 1e-9] + [1e-3] * 4 + [1e-10] + [1e-3] * 4 + [1e-10])
DRIFT_ATOL = 1e-15
NEWTON_RTOL = 1e-10
#: Scale of each equation's residual for the line search (its unknown's units;
#: the oil charge's in m^3).
RESIDUAL_SCALE = np.array([1e-9, 1e-6] + [1e3] * 4 + [1e-6] + [1e3] * 4 + [1e-6])
CHARGE_SCALE = 1e-12

#: Periods the transducer is stepped to reach its periodic drive: the
#: compensator's memory reaches three samples back, eq 31's branch one.
_DRIVE_PERIODS = 3

#: Gauss-Legendre rule for the compressed volume int dp / beta_e(p).
_GAUSS = np.polynomial.legendre.leggauss(6)


class PeriodicSolveError(RuntimeError):
    """Newton's method found no periodic steady state."""


@dataclass(frozen=True)
class PeriodicSettings:
    """Settings of one periodic-steady-state solve (SI).

    Attributes
    ----------
    step : float
        Requested grid step h, [s] (default :data:`GRID_STEP`). The grid uses
        T / round(T / h).
    direction : {"down", "up"}
        Commanded cylinder direction (Figure 2).
    load_force : float
        External load on the cylinder, opposing "down", [N].
    accumulator_pressure : float or None
        Mean accumulator pressure, [Pa]. None: set by the oil charge of the
        co-simulation's starting state (module docstring).
    piston_position : float or None
        x at which the cavity volumes are frozen, [m], strictly inside the
        stroke. None: mid-stroke (:func:`.circuit.initial_state`).
    max_iterations : int
        Newton iterations before giving up.
    """

    step: float = GRID_STEP
    direction: str = "down"
    load_force: float = 0.0
    accumulator_pressure: float | None = None
    piston_position: float | None = None
    max_iterations: int = 60

    def __post_init__(self):
        check_range("step", self.step, 0.0, 1.0, unit="s")
        check_range("load_force", self.load_force, -1e7, 1e7, unit="N")
        if self.accumulator_pressure is not None:
            check_range("accumulator_pressure", self.accumulator_pressure, 0.0, 1e9, unit="Pa")
        if self.direction not in ("down", "up"):
            raise ParameterError(f"direction = {self.direction!r} is not one of ('down', 'up')")
        if not (isinstance(self.max_iterations, int) and self.max_iterations >= 1):
            raise ParameterError(
                f"max_iterations = {self.max_iterations!r} is outside the allowed range [1, inf)")


@dataclass(frozen=True)
class PeriodicSolution:
    """One period of the steady state, on the grid t_n = n h, n = 0..N-1 (SI).

    Per-step arrays hold either the state at t_n, or (``control``,
    ``current``, ``magnetostrictive_force``, ``valves_compressing``,
    ``volume_into_big``) what acts over [t_n, t_n + h), as the
    co-simulation's record does.
    """

    frequency: float  #: f, [Hz]
    step: float  #: h = 1 / (f N), [s]
    direction: str  #: "down" or "up"
    time: np.ndarray  #: t_n, [s]
    control: np.ndarray  #: u held over the step, u(t_n + h/2), [V]
    current: np.ndarray  #: coil current, [A]
    magnetostrictive_force: np.ndarray  #: A_r E^H lambda, eq 28, [N]
    rod_displacement: np.ndarray  #: y, [m]
    rod_velocity: np.ndarray  #: dy/dt, [m/s]
    p_pump: np.ndarray  #: [Pa]
    p_big: np.ndarray  #: [Pa]
    p_small: np.ndarray  #: [Pa]
    p_accumulator: np.ndarray  #: [Pa]
    piston_velocity: np.ndarray  #: [m/s]
    valves_compressing: np.ndarray  #: 1 while the valves act on the compressing stage, [-]
    volume_into_big: np.ndarray  #: net volume into B over the step (V1 in, V2 out), [m^3]
    accumulator_drift: float  #: mean oil flow into the accumulator (the dropped drift), [m^3/s]
    iterations: int  #: Newton iterations taken

    @property
    def period(self) -> float:
        """T, [s]."""
        return self.step * self.time.size

    @property
    def flow(self) -> float:
        """Mean cylinder flow, [m^3/s]: into B going down, out of it going up."""
        sign = 1.0 if self.direction == "down" else -1.0
        return sign * float(np.sum(self.volume_into_big)) / self.period

    @property
    def dy(self) -> float:
        """Rod displacement from the start to the end of compression, [m] (eq 39).

        Taken between the valve switching instants, as
        :func:`.flowcheck.flow_check` takes it: from y at the first step the
        valves act on the compressing stage, to y at the first step they act
        on the expanding one.
        """
        c = self.valves_compressing > 0.5
        change = np.nonzero(c != np.roll(c, 1))[0]
        starts, ends = change[c[change]], change[~c[change]]
        if starts.size == 0:
            raise PeriodicSolveError("the valves never switch: no compression stroke")
        n = c.size
        y = self.rod_displacement
        ends_after = [ends[np.argmin((ends - s) % n)] for s in starts]
        return float(np.mean(y[ends_after] - y[starts]))

    def flow_check(self, piston_area: float) -> FlowCheck:
        """Mean flow against eq 39, f A_d dy, as :func:`.flowcheck.flow_check` reports it.

        ``cycles`` is 1 (the steady state is exactly periodic) and ``window``
        is the period.
        """
        return FlowCheck(self.flow, self.frequency * piston_area * self.dy, self.dy, 1,
                         (0.0, self.period))


def grid(frequency: float, step: float) -> tuple[int, float]:
    """(N, h): whole steps per period, N = round(1 / (f step)) >= 8, and h = 1 / (f N), [s]."""
    check_range("frequency", frequency, 0.0, 1e6, unit="Hz")
    n = max(8, int(round(1.0 / (frequency * step))))
    return n, 1.0 / (frequency * n)


def periodic_drive(transducer: gmt.Transducer, control, n: int, step: float):
    """The transducer's drive over one period in steady state.

    Parameters
    ----------
    transducer : gmt.Transducer
        Its amplifier and compensator give the current; it is reset first.
    control : callable
        u(t), [V], periodic with period n * step.
    n : int
        Steps per period.
    step : float
        h, [s].

    Returns
    -------
    (array, array, array)
        The u held over each step [V] -- u(t_n) for the digital compensator,
        which samples it there; u(t_n + h/2) for the continuous uncompensated
        drive (as the co-simulation's displacement port holds them) -- the
        coil current [A] and the magnetostrictive force (eq 28) [N] over each
        step. The transducer itself is stepped over :data:`_DRIVE_PERIODS`
        periods and the last is kept: the compensator's memory, its sampling
        and eq 31's branch settle as in the co-simulation. A compensator
        period that does not divide the pump period (70 Hz at 10 kHz) samples
        at other phases each period; the last period is then one of them.
    """
    sampled = transducer.compensator is not None
    u = np.array([control((k if sampled else k + 0.5) * step) for k in range(n)])
    transducer.reset()
    current, force = np.empty(n), np.empty(n)
    for _ in range(_DRIVE_PERIODS):
        for k in range(n):
            out = transducer.step(float(u[k]), step)
            current[k], force[k] = out.current, out.magnetics.force
    return u, current, force


def valve_schedule(control, circuit: CircuitParameters, direction: str, n: int, step: float):
    """Valve commands and openings over one period on the step grid.

    The controller's phase over [t_k, t_k + h) follows u(t_{k+1}) - u(t_k)
    (:func:`.controller.pump_phase`). Valve j acts on the command issued
    ceil(d_j / h) steps earlier when it has a dead time d_j (the
    co-simulation's command history); ideal and first-order valves act at
    once. A first-order valve's opening then lags its command,
    tau do/dt = command - o (:func:`.valves.opening_rate`), integrated by
    TR-BDF2 as the co-simulation integrates it, on its own periodic orbit.

    Returns
    -------
    (array, array, array, array)
        ``acting`` (n, 4): the commands in force over each step (1 open,
        0 shut); then the openings (n, 4) at each step's start, at its
        TR-BDF2 stage and at its end, [-].
    """
    u = [control(k * step) for k in range(n + 1)]
    phases = np.empty(n, dtype=bool)
    compressing = True
    for _ in range(2):  # a second sweep, so a tie at t = 0 inherits the phase of t = T
        for k in range(n):
            compressing = pump_phase(u[k + 1], u[k], compressing)
            phases[k] = compressing
    commands = np.where(phases[:, None], np.array(valve_commands(direction, True), float),
                        np.array(valve_commands(direction, False), float))
    acting = np.empty_like(commands)
    start, stage, end = (np.empty_like(commands) for _ in range(3))
    for j, valve in enumerate(circuit.valves):
        delay = valve.opening_time if valve.response == "delay" else 0.0
        acting[:, j] = np.roll(commands[:, j], int(math.ceil(delay / step - 1e-9)))
        if valve.response == "first_order":
            start[:, j], stage[:, j], end[:, j] = _first_order_openings(
                acting[:, j], valve.opening_time, step)
        else:
            start[:, j] = stage[:, j] = end[:, j] = acting[:, j]
    return acting, start, stage, end


def _first_order_openings(command, tau, h):
    """Periodic TR-BDF2 orbit of tau do/dt = command - o: (start, stage, end) of each step."""
    c = TRBDF2_D * h / tau
    # trapezoid: o_g (1 + c) = o_n (1 - c) + 2 c cmd;  BDF2: o_1 (1 + c) = A o_g - B o_n + c cmd
    stage_gain, stage_in = (1.0 - c) / (1.0 + c), 2.0 * c / (1.0 + c)
    gain = (_A * stage_gain - _B) / (1.0 + c)
    drive = (_A * stage_in + c) / (1.0 + c) * command
    n = command.size

    def sweep(first):
        o = np.empty(n + 1)
        o[0] = first
        for k in range(n):
            o[k + 1] = gain * o[k] + drive[k]
        return o

    # o_N = gain^N o_0 + (o_N from 0), so the periodic start is that over 1 - gain^N
    o = sweep(sweep(0.0)[n] / (1.0 - gain ** n))
    start = o[:n]
    return start, stage_gain * start + stage_in * command, o[1:]


def rod_periodic_response(force, params: gmt.TransducerParameters, step: float):
    """Periodic (y, v) at t_n of eq 27 stepped with a force held over each step.

    Harmonic balance on the zero-order-hold model. With F_n held over
    [t_n, t_{n+1}), z Y = a11 Y + a12 V + b1 F and z V = a21 Y + a22 V + b2 F
    at each harmonic z = exp(j 2 pi k / N) of the period, so Y = G_d(z) F,
    with G_d the sampled eq 29 (:func:`gmt.mechanics.frequency_response` with
    a step gives the same).

    Parameters
    ----------
    force : array
        Net force on the rod over each step, F_magnetostrictive - F_ext, [N].
    params : gmt.TransducerParameters
    step : float
        h, [s].

    Returns
    -------
    (array, array)
        y [m] and v [m/s] at t_n.
    """
    a11, a12, a21, a22, b1, b2 = zoh_matrices(params.mass, params.damping, params.stiffness,
                                              step)
    f = np.fft.fft(np.asarray(force, dtype=float))
    z = np.exp(2j * np.pi * np.fft.fftfreq(f.size))
    det = (z - a11) * (z - a22) - a12 * a21
    y = ((z - a22) * b1 + a12 * b2) / det * f
    v = ((z - a11) * b2 + a21 * b1) / det * f
    return np.fft.ifft(y).real, np.fft.ifft(v).real


# -- the circuit's equations on arrays ------------------------------------------------------
def _valve_flows(p_p, p_b, p_s, p_a, openings, circuit: CircuitParameters):
    """Q_V1..Q_V4 and their slopes dQ/d(dp), [m^3/s], [m^3/(s Pa)], on arrays.

    :func:`.circuit.valve_flows` with the accumulator's pressure given
    per point; positive P->B, B->A, P->S, S->A (:data:`.valves.BRIDGE`).
    """
    rho = circuit.fluid.density
    drops = (p_p - p_b, p_b - p_a, p_p - p_s, p_s - p_a)
    q, dq = [], []
    for k, v in enumerate(circuit.valves):
        area = open_area(v, openings[:, k])
        q.append(orifice_flow(area, drops[k], rho, v.discharge_coefficient,
                              v.transition_pressure))
        dq.append(orifice_flow_derivative(area, drops[k], rho, v.discharge_coefficient,
                                          v.transition_pressure))
    return q, dq


def _bulk_and_slope(fluid, p):
    """beta_e(p) and d(beta_e)/dp by a one-sided difference, as circuit.jacobian takes it."""
    beta = effective_bulk_modulus(fluid, p)
    dp = p * 1e-6 + 1.0
    return beta, (effective_bulk_modulus(fluid, p + dp) - beta) / dp


@dataclass(frozen=True)
class _Plant:
    """What the circuit's equations need, fixed for one solve (SI)."""

    circuit: CircuitParameters
    piston_position: float  # [m]
    volume_big: float  # [m^3]
    volume_small: float  # [m^3]
    chamber_volume_at_zero: float  # V_P at y = 0, [m^3]
    load: float  # [N]
    start_pressure: float  # p_0 of the oil charge, [Pa]
    start_rod: float  # y_0, [m]
    start_piston: float  # x_0, [m]
    fixed_pressure: float | None  # mean p_A when fixed, [Pa]

    def chamber_volumes(self, rod_y):
        """V_P = V(0) - A_d y (:func:`.chamber.chamber_volume` is affine in y); NaN if emptied."""
        v = self.chamber_volume_at_zero - self.circuit.chamber.piston_area * rod_y
        return np.where(v > 0.0, v, np.nan)

    def gas_spring(self, mean_pressure):
        """Stored oil at the mean pressure, [m^3], and its slope dV_A/dp_A, [m^3/Pa]."""
        acc = self.circuit.accumulator
        p = float(mean_pressure)
        if not (np.isfinite(p) and p > 0.0):
            return math.nan, math.nan
        dp = 1e-6 * p
        slope = (oil_volume_at(acc, p + dp) - oil_volume_at(acc, p - dp)) / (2.0 * dp)
        return oil_volume_at(acc, p), slope


def _circuit(s, rod_y, rod_v, openings, drift, stiffness, plant: _Plant):
    """Rates of s = (p_P, p_B, p_S, p_A, w) at many points, with their derivatives.

    The assembly of :func:`.circuit.rhs` (continuity in the chamber, both
    cavities and the accumulator; the piston's Newton law) on arrays. The
    flows, bulk modulus and piston law are the components' own functions.
    The accumulator is the gas spring linearised about its mean,
    dp_A/dt = kappa (Q_V2 + Q_V4 - drift), with kappa = dp_A/dV_A.

    Returns
    -------
    (f, jac, df_dy, df_dv, df_ddrift, into_big)
        f (M, 5), the rates; jac (M, 5, 5) = df/ds; df_dy, df_dv (M,), the
        chamber rate's derivatives in rod displacement and rod velocity (the
        other rates do not depend on the rod); df_ddrift, the accumulator
        rate's derivative in the drift (-kappa); into_big (M,), the flow
        Q_V1 - Q_V2 [m^3/s]. A rod that empties the chamber gives NaN rates.
    """
    c = plant.circuit
    fl, cyl, ch = c.fluid, c.cylinder, c.chamber
    p_p, p_b, p_s, p_a, w = s.T
    (q1, q2, q3, q4), (d1, d2, d3, d4) = _valve_flows(p_p, p_b, p_s, p_a, openings, c)
    vol_p = plant.chamber_volumes(rod_y)
    net_p = ch.piston_area * rod_v - q1 - q3
    net_b = q1 - q2 - cyl.big_area * w
    net_s = q3 - q4 + cyl.small_area * w
    (bp, dbp), (bb, dbb), (bs, dbs) = (_bulk_and_slope(fl, p) for p in (p_p, p_b, p_s))
    kp, kb, ks = bp / vol_p, bb / plant.volume_big, bs / plant.volume_small
    f = np.column_stack((kp * net_p, kb * net_b, ks * net_s, stiffness * (q2 + q4 - drift),
                         piston_acceleration(cyl, p_b, p_s, plant.piston_position, w,
                                             plant.load)))
    jac = np.zeros((s.shape[0], _NS, _NS))
    jac[:, 0, 0] = dbp / vol_p * net_p - kp * (d1 + d3)
    jac[:, 0, 1] = kp * d1
    jac[:, 0, 2] = kp * d3
    jac[:, 1, 0] = kb * d1
    jac[:, 1, 1] = dbb / plant.volume_big * net_b - kb * (d1 + d2)
    jac[:, 1, 3] = kb * d2
    jac[:, 1, 4] = -kb * cyl.big_area
    jac[:, 2, 0] = ks * d3
    jac[:, 2, 2] = dbs / plant.volume_small * net_s - ks * (d3 + d4)
    jac[:, 2, 3] = ks * d4
    jac[:, 2, 4] = ks * cyl.small_area
    jac[:, 3, 1] = stiffness * d2
    jac[:, 3, 2] = stiffness * d4
    jac[:, 3, 3] = -stiffness * (d2 + d4)
    jac[:, 4, 1] = cyl.big_area / cyl.mass
    jac[:, 4, 2] = -cyl.small_area / cyl.mass
    jac[:, 4, 4] = -cyl.friction / cyl.mass
    df_dy = kp * net_p * ch.piston_area / vol_p  # d(1/V_P)/dy = A_d / V_P^2
    df_dv = kp * ch.piston_area
    return f, jac, df_dy, df_dv, -stiffness, q1 - q2


def _compressed(fluid, p, p0):
    """int_{p0}^{p} dp' / beta_e(p') and its derivative 1 / beta_e(p), [1], [1/Pa]."""
    x, w = _GAUSS
    mid, half = 0.5 * (p + p0), 0.5 * (p - p0)
    nodes = mid[..., None] + half[..., None] * x
    integral = half * np.sum(w / effective_bulk_modulus(fluid, nodes), axis=-1)
    return integral, 1.0 / effective_bulk_modulus(fluid, p)


class _System:
    """The 12 N + 1 periodic equations (module docstring): residual and Jacobian."""

    def __init__(self, plant: _Plant, force, openings, params: gmt.TransducerParameters,
                 step: float):
        self.plant = plant
        self.force = force
        self.open0, self.open_g, self.open1 = openings
        self.h = step
        self.n = force.size
        self.size = _NV * self.n + 1
        self.area = plant.circuit.chamber.piston_area
        self.zoh = zoh_matrices(params.mass, params.damping, params.stiffness, step)
        self.c = TRBDF2_D * step
        r = TRBDF2_GAMMA
        # cubic Hermite at s = gamma h: y_g = hy0 y_n + hv0 v_n + hy1 y_{n+1} + hv1 v_{n+1}
        self.hermite = (1.0 - 3 * r * r + 2 * r ** 3, step * (r - 2 * r * r + r ** 3),
                        3 * r * r - 2 * r ** 3, step * (r ** 3 - r * r))
        cyl = plant.circuit.cylinder
        self._rod_volume = (cyl.big_area - cyl.small_area) * (plant.piston_position
                                                              - plant.start_piston)
        self._start_oil, _ = plant.gas_spring(plant.start_pressure)
        self.scale = np.concatenate((np.tile(RESIDUAL_SCALE, self.n), [CHARGE_SCALE]))
        self.atol = np.concatenate((np.tile(NEWTON_ATOL, self.n), [DRIFT_ATOL]))
        self._pattern()

    def unpack(self, z):
        return z[:-1].reshape(self.n, _NV), z[-1]

    def evaluate(self, z, jacobian=True):
        """(residual, Jacobian data or None, volume into B per step)."""
        zz, drift = self.unpack(z)
        y, v, s, g = zz[:, 0], zz[:, 1], zz[:, _S:_G], zz[:, _G:]
        s1 = np.roll(s, -1, axis=0)
        y1, v1 = np.roll(y, -1), np.roll(v, -1)
        hy0, hv0, hy1, hv1 = self.hermite
        yg = hy0 * y + hv0 * v + hy1 * y1 + hv1 * v1
        v_tr = (yg - y) / (TRBDF2_GAMMA * self.h)  # secant over the trapezoidal stage
        v_bdf = (y1 - _A * yg + _B * y) / (TRBDF2_D * self.h)  # the BDF2 stage's velocity
        mean_pa = float(np.mean(s[:, 3]))
        oil, slope = self.plant.gas_spring(mean_pa)
        stiffness = 1.0 / slope
        a11, a12, a21, a22, b1, b2 = self.zoh
        c = self.c
        f0, j0, fy0, fv0, fd, q0 = _circuit(s, y, v_tr, self.open0, drift, stiffness, self.plant)
        fg, jg, fyg, fvg, _, qg = _circuit(g, yg, v_tr, self.open_g, drift, stiffness,
                                           self.plant)
        f1, j1, fy1, fv1, _, q1 = _circuit(s1, y1, v_bdf, self.open1, drift, stiffness,
                                           self.plant)
        net = self.force - self.area * s1[:, 0]
        res = np.empty((self.n, _NV))
        res[:, 0] = y1 - a11 * y - a12 * v - b1 * net
        res[:, 1] = v1 - a21 * y - a22 * v - b2 * net
        res[:, _S:_G] = g - c * fg - s - c * f0
        res[:, _G:] = s1 - c * f1 - _A * g + _B * s
        charge, dcharge = self._charge(y, s, oil, slope)
        residual = np.concatenate((res.ravel(), [charge]))
        volume = _A * c * (q0 + qg) + c * q1  # the co-simulation's TR-BDF2 quadrature
        if not jacobian:
            return residual, None, volume
        data = self._jacobian_data(j0, jg, j1, (fy0, fv0), (fyg, fvg), (fy1, fv1), fd,
                                   dcharge)
        return residual, data, volume

    def _charge(self, y, s, oil, slope):
        """The closing equation, [m^3], and its derivatives in y_n and p_P..p_A at t_n.

        The oil charge (module docstring) as the period's mean; or, with the
        mean pressure fixed, V_A(mean p_A) - V_A(fixed).
        """
        n, plant = self.n, self.plant
        d_pa = np.full(n, slope / n)
        if plant.fixed_pressure is not None:
            target, _ = plant.gas_spring(plant.fixed_pressure)
            zero = np.zeros(n)
            return oil - target, (zero, zero, zero, zero, d_pa)
        fl = plant.circuit.fluid
        p0 = plant.start_pressure
        vol_p = plant.chamber_volumes(y)
        (cp, ip), (cb, ib), (cs, i_s) = (_compressed(fl, s[:, k], p0) for k in range(3))
        stored = (-self.area * (y - plant.start_rod) + vol_p * cp + plant.volume_big * cb
                  + plant.volume_small * cs)
        charge = float(np.mean(stored)) + self._rod_volume + oil - self._start_oil
        return charge, ((-self.area - self.area * cp) / n, vol_p * ip / n,
                        plant.volume_big * ib / n, plant.volume_small * i_s / n, d_pa)

    # -- Jacobian: a fixed pattern, values in the same order --------------------------------
    def _pattern(self):
        n = self.n
        base = _NV * np.arange(n)
        nxt = _NV * ((np.arange(n) + 1) % n)
        last = self.size - 1
        rows, cols = [], []

        def add(row, col):
            rows.append(np.broadcast_to(row, (n,)))
            cols.append(np.broadcast_to(col, (n,)))

        for r in (0, 1):  # rod rows: y_{n+1} or v_{n+1}, y_n, v_n, p_P(n+1)
            add(base + r, nxt + r)
            add(base + r, base)
            add(base + r, base + 1)
            add(base + r, nxt + _S)
        for i in range(_NS):  # stage rows: 5x5 blocks
            for j in range(_NS):
                add(base + _S + i, base + _G + j)  # trapezoidal stage on g_n
                add(base + _S + i, base + _S + j)  # ... on s_n
                add(base + _G + i, nxt + _S + j)  # BDF2 stage on s_{n+1}
            add(base + _G + i, base + _G + i)  # ... on g_n (diagonal)
            add(base + _G + i, base + _S + i)  # ... on s_n (diagonal)
        for r in (_S, _G):  # the chamber rows on the rod: y_n, v_n, y_{n+1}, v_{n+1}
            add(base + r, base)
            add(base + r, base + 1)
            add(base + r, nxt)
            add(base + r, nxt + 1)
        add(base + _S + 3, last)  # the accumulator rows on the drift
        add(base + _G + 3, last)
        for col in (0, _S, _S + 1, _S + 2, _S + 3):  # the charge on y_n, p_P..p_A
            add(last, base + col)
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        # no two entries share a place (N >= 8): CSC by one fixed permutation
        self._order = np.lexsort((rows, cols))
        self._indices = rows[self._order]
        self._indptr = np.concatenate(([0], np.cumsum(np.bincount(cols, minlength=self.size))))

    def _jacobian_data(self, j0, jg, j1, rod0, rodg, rod1, fd, dcharge):
        n, c, h = self.n, self.c, self.h
        a11, a12, a21, a22, b1, b2 = self.zoh
        ones = np.ones(n)
        data = []
        for ay, av, bb in ((a11, a12, b1), (a21, a22, b2)):
            data += [ones, -ay * ones, -av * ones, bb * self.area * ones]
        eye = np.eye(_NS)
        for i in range(_NS):
            for j in range(_NS):
                data.append(eye[i, j] - c * jg[:, i, j])
                data.append(-eye[i, j] - c * j0[:, i, j])
                data.append(eye[i, j] - c * j1[:, i, j])
            data.append(-_A * ones)
            data.append(_B * ones)
        hy0, hv0, hy1, hv1 = self.hermite
        gh, dh = TRBDF2_GAMMA * h, TRBDF2_D * h
        (fy0, fv0), (fyg, fvg), (fy1, fv1) = rod0, rodg, rod1
        fv_tr = fvg + fv0  # both trapezoidal points take the secant velocity
        # trapezoidal stage: y_n directly (chamber volume at t_n), and through y_g and v_tr
        data += [-c * (fyg * hy0 + fv_tr * (hy0 - 1.0) / gh + fy0),
                 -c * (fyg * hv0 + fv_tr * hv0 / gh),
                 -c * (fyg * hy1 + fv_tr * hy1 / gh),
                 -c * (fyg * hv1 + fv_tr * hv1 / gh)]
        # BDF2 stage: y_{n+1} directly, and through v_bdf = (y_1 - A y_g + B y_n) / (d h)
        data += [-c * fv1 * (_B - _A * hy0) / dh,
                 -c * fv1 * (-_A * hv0) / dh,
                 -c * (fy1 + fv1 * (1.0 - _A * hy1) / dh),
                 -c * fv1 * (-_A * hv1) / dh]
        data += [-2.0 * c * fd * ones, -c * fd * ones]
        data += list(dcharge)
        return np.concatenate(data)

    def matrix(self, data):
        """The Jacobian as a CSC matrix, from :meth:`evaluate`'s data."""
        return sparse.csc_matrix((data[self._order], self._indices, self._indptr),
                                 shape=(self.size, self.size))

    def factorise(self, data):
        """LU of the Jacobian. The natural order keeps the fill to the band and the
        periodic wrap; minimum-degree orders choke on the dense row and column."""
        return splu(self.matrix(data), permc_spec="NATURAL")


def _newton(system: _System, z, max_iterations):
    """Damped Newton on the periodic equations: (z, volume into B per step, iterations).

    Armijo on the scaled max-norm of the residual, as :func:`.implicit._newton`
    does (on the orifice law, a full step can swap the sign of a pressure drop
    and cycle). Once a full step has cut the residual a hundredfold, the
    factorised Jacobian is kept for the next steps (chord steps) while each
    of them cuts the residual fourfold or more; otherwise it is refactorised.
    """
    res, data, _ = system.evaluate(z)
    norm = float(np.max(np.abs(res) / system.scale))
    lu = None
    for it in range(1, max_iterations + 1):
        fresh = lu is None
        if fresh:
            try:
                lu = system.factorise(data)
            except RuntimeError as err:  # an exactly singular factor
                raise PeriodicSolveError(f"singular Jacobian at Newton iteration {it}") from err
        delta = lu.solve(-res)
        lam = 1.0
        while True:
            trial = z + lam * delta
            res_t, data_t, _ = system.evaluate(trial)
            norm_t = float(np.max(np.abs(res_t) / system.scale))
            if not fresh or norm_t <= (1.0 - 0.5 * lam) * norm or lam < 1.0 / 1024:
                break
            lam *= 0.5
        if not fresh and not norm_t <= 0.25 * norm:
            lu = None  # the chord step did not contract: refactorise here
            continue
        if not np.isfinite(norm_t):
            raise PeriodicSolveError(
                f"Newton left the physical range at iteration {it}: a rod displacement that "
                f"empties the pump chamber, or a non-finite pressure")
        if fresh and not (lam == 1.0 and norm_t <= 0.01 * norm):
            lu = None
        z, res, data, norm = trial, res_t, data_t, norm_t
        if np.all(np.abs(lam * delta) <= system.atol + NEWTON_RTOL * np.abs(z)):
            _, _, volume = system.evaluate(z, jacobian=False)
            return z, volume, it
    raise PeriodicSolveError(
        f"Newton did not converge in {max_iterations} iterations (scaled residual {norm:.3g})")


def periodic_steady_state(transducer: gmt.Transducer, control, frequency: float,
                          circuit: CircuitParameters,
                          settings: PeriodicSettings | None = None) -> PeriodicSolution:
    """Solve for the periodic steady state of the coupled transducer and circuit.

    Parameters
    ----------
    transducer : gmt.Transducer
        The transducer with its drive (amplifier, compensator). Its parameters
        and its current are used; it is not stepped.
    control : callable
        u(t), [V], periodic at ``frequency``.
    frequency : float
        Pumping frequency f, [Hz].
    circuit : CircuitParameters
    settings : PeriodicSettings, optional

    Returns
    -------
    PeriodicSolution

    Raises
    ------
    ParameterError
        A piston position outside the stroke, or a transducer with a model
        variant (:class:`gmt.ModelVariant`).
    PeriodicSolveError
        Newton found no steady state.

    Examples
    --------
    The ideal circuit at 100 Hz, uncompensated: eq 40 holds, q = f A_d dy.

    >>> import gmt, math
    >>> from system_models import presets
    >>> unit = gmt.Transducer(excitation=gmt.Excitation(100.0, 1.0))
    >>> sol = periodic_steady_state(unit, lambda t: math.cos(200 * math.pi * t), 100.0,
    ...                             presets.ideal_circuit())
    >>> round(sol.flow_check(1256e-6).ratio, 2)
    1.0
    """
    settings = settings or PeriodicSettings()
    system, z, (n, h, u, current, force, acting) = _setup(transducer, control, frequency,
                                                        circuit, settings)
    z, volume, iterations = _newton(system, z, settings.max_iterations)
    zz, drift = system.unpack(z)
    watch = 0 if settings.direction == "down" else 2  # V1 going down, V3 up (cosim record)
    col = {name: zz[:, k].copy() for k, name in enumerate(UNKNOWNS)}
    return PeriodicSolution(
        frequency=float(frequency), step=h, direction=settings.direction,
        time=h * np.arange(n), control=u, current=current, magnetostrictive_force=force,
        rod_displacement=col["rod_displacement"], rod_velocity=col["rod_velocity"],
        p_pump=col["p_pump"], p_big=col["p_big"], p_small=col["p_small"],
        p_accumulator=col["p_accumulator"], piston_velocity=col["piston_velocity"],
        valves_compressing=acting[:, watch].copy(), volume_into_big=volume,
        accumulator_drift=float(drift), iterations=iterations)


def _setup(transducer, control, frequency, circuit: CircuitParameters,
           settings: PeriodicSettings):
    """The equations and the first guess: (system, z, (N, h, u, current, force, acting))."""
    variant = getattr(transducer, "variant", None)
    if variant is not None and not variant.is_paper:
        raise ParameterError(
            f"variant = {variant.name!r}: the periodic solver takes the paper's transducer "
            f"model only (its force set by the current alone, eq 27 as it stands); "
            f"time-step the study for a model variant")
    n, h = grid(frequency, settings.step)
    cyl = circuit.cylinder
    start = initial_state(circuit)
    x0 = float(start[4]) if settings.piston_position is None else settings.piston_position
    check_range("piston_position", x0, 0.0, cyl.stroke, unit="m")
    vol_b, vol_s = cavity_volumes(cyl, x0)
    plant = _Plant(circuit, float(x0), float(vol_b), float(vol_s),
                   float(chamber_volume(circuit.chamber, 0.0)), float(settings.load_force),
                   start_pressure=float(accumulator_pressure(circuit.accumulator, start[3])),
                   start_rod=gmt.bias_displacement(transducer.params),
                   start_piston=float(start[4]), fixed_pressure=settings.accumulator_pressure)
    u, current, force = periodic_drive(transducer, control, n, h)
    acting, *openings = valve_schedule(control, circuit, settings.direction, n, h)
    system = _System(plant, force, openings, transducer.params, h)
    z = _first_guess(plant, acting, force, transducer.params, h, settings.direction)
    return system, z, (n, h, u, current, force, acting)


def _first_guess(plant: _Plant, acting, force, params, h, direction):
    """Cavities at the load balance, the chamber at the cavity its open valve joins,
    the rod by harmonic balance.

    The cavity that stays joined to the accumulator (S going down, B going
    up) sits at p_A; the other balances the load on the piston at rest,
    p_B A_B - p_S A_S = F_load (:func:`.cylinder.piston_acceleration`).
    """
    cyl = plant.circuit.cylinder
    p_a = plant.start_pressure if plant.fixed_pressure is None else plant.fixed_pressure
    load = plant.load
    if direction == "down":
        p_s, p_b = p_a, (load + p_a * cyl.small_area) / cyl.big_area
    else:
        p_b, p_s = p_a, (p_a * cyl.big_area - load) / cyl.small_area
    p_p = np.where(acting[:, 0] >= acting[:, 2], p_b, p_s)
    area = plant.circuit.chamber.piston_area
    y, v = rod_periodic_response(force - area * np.roll(p_p, -1), params, h)
    z = np.zeros((force.size, _NV))
    z[:, 0], z[:, 1], z[:, _S], z[:, _S + 1], z[:, _S + 2], z[:, _S + 3] = y, v, p_p, p_b, p_s, p_a
    z[:, _G:] = z[:, _S:_G]
    return np.concatenate((z.ravel(), [0.0]))

