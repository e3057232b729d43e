"""The position controller's design model, its PI law and python-control's predictions.

* **plant** (:class:`PlantModel`): in each direction the period-averaged piston velocity is
  a line in the drive amplitude, v = v_0 + g a (a the amplitude as a fraction of the
  limit), identified from open-loop co-simulations (:func:`smeha.studies.position.identify`).
* **PI law** (:func:`pi_step`): the velocity wanted, v* = K_p e + K_i sum(e T), is turned
  into a direction and an amplitude through the lines' inverse (:meth:`PlantModel.command`);
  the integral stands while the drive is at its limit (anti-windup). One step of this law
  drives both the prediction (:func:`predict_step`) and the closed loop
  (:class:`Controller`), so the two decide saturation alike.
* **design** (:func:`design`): the loop the design sees is the pumping's sample-and-hold of
  an integrator, P(z) = T / (z - 1); python-control gives its margins, bandwidth, load-step
  response and, through :func:`predict_step` as a sampled ``control.nlsys``, the step with
  the velocity limits (Franklin, Powell & Workman, *Digital Control of Dynamic Systems*,
  3rd ed., 1998, ch. 7 for the sampled loop).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

import gmt

from . import positionoptions as options
from .positionloop import TIME_TOLERANCE, Decision

__all__ = ["PlantModel", "Design", "pi_step", "predict_step", "design", "Controller",
           "step_metrics", "LOOP_GAIN", "INTEGRAL_RATIO", "SMALLEST_FRACTION"]

#: Loop gain K_p T of the design: the closed-loop pole at z = 1 - K_p T = 0.7, a
#: monotone first-order approach with a time constant of 2.8 periods.
LOOP_GAIN = 0.3
#: Integral gain over proportional gain times T, K_i T / K_p: the integral's zero at
#: z = 1 - 0.05, a twentieth of the loop's speed (phase margin ~80 deg).
INTEGRAL_RATIO = 0.05
#: The least amplitude the inverse commands, as a fraction of the limit: a velocity
#: between the two lines' offsets is reached by neither, and the nearer line's least
#: drive keeps the valves cycling.
SMALLEST_FRACTION = 1e-3


@dataclass(frozen=True, kw_only=True)
class PlantModel:
    """Identified velocity lines of each direction, SI (module docstring).

    Down: v = v0_down + g_down a; up: v = v0_up - g_up a (v < 0: x falls), a in (0, 1]
    of the amplitude limit; a = 0 holds. ``droop_down``/``droop_up``: dv/dF [m/s/N].
    ``points``: (direction, fraction, velocity) of each identification run.
    """

    frequency: float  #: the pump's, [Hz]
    v0_down: float  #: [m/s]
    g_down: float  #: [m/s] per unit amplitude fraction
    v0_up: float  #: [m/s]
    g_up: float  #: [m/s] per unit amplitude fraction
    droop_down: float  #: [m/s/N]
    droop_up: float  #: [m/s/N]
    points: tuple = ()

    @property
    def v_max_down(self) -> float:
        """The velocity at full drive down, [m/s]."""
        return self.v0_down + self.g_down

    @property
    def v_max_up(self) -> float:
        """The velocity at full drive up, [m/s] (negative when it lifts)."""
        return self.v0_up - self.g_up

    def velocity(self, direction: str, fraction: float) -> float:
        """The line's velocity at ``fraction`` of the limit in ``direction``, [m/s]."""
        if direction == "down":
            return self.v0_down + self.g_down * fraction
        return self.v0_up - self.g_up * fraction

    def command(self, velocity: float) -> tuple[str, float, bool]:
        """Direction, amplitude fraction and saturation that give ``velocity`` [m/s]."""
        if velocity >= self.v0_down or velocity > 0.5 * (self.v0_down + self.v0_up):
            a = (velocity - self.v0_down) / self.g_down
            return "down", min(max(a, SMALLEST_FRACTION), 1.0), a > 1.0
        a = (self.v0_up - velocity) / self.g_up
        return "up", min(max(a, SMALLEST_FRACTION), 1.0), a > 1.0

    def as_dict(self) -> dict:
        d = asdict(self)
        d["points"] = [list(p) for p in self.points]
        return d


@dataclass(frozen=True, kw_only=True)
class Design:
    """The controller and python-control's predictions for it (SI)."""

    kp: float  #: [1/s]: v* per metre of error
    ki: float  #: [1/s^2]
    period: float  #: T, [s]
    phase_margin_deg: float
    gain_margin: float
    crossover_Hz: float
    bandwidth_Hz: float  #: closed-loop -3 dB, linear
    rise_time_linear_s: float  #: 10-90 %, unsaturated
    overshoot_linear: float  #: fraction
    predicted_rise_time_s: float  #: 10-90 % of the study's step with the velocity limits
    predicted_settling_time_s: float  #: 2 % band, with the velocity limits (NaN: not within)
    predicted_overshoot: float  #: fraction, with the velocity limits
    #: peak deflection per newton of a load step while holding, from the droop alone
    #: (a velocity step dv/dF entering the loop), [m/N]; down's droop
    predicted_load_peak_m_per_N: float = math.nan

    def as_dict(self) -> dict:
        return asdict(self)


def pi_step(model: PlantModel, kp: float, ki: float, period: float, integral: float,
            error: float) -> tuple[Decision, float]:
    """One sample of the PI law: the decision for ``error`` [m] and the next integral
    [m/s] (it stands while the drive saturates: anti-windup). The amplitude of the
    decision is a fraction of the limit."""
    direction, fraction, saturated = model.command(kp * error + integral)
    if not saturated:
        integral += ki * period * error
    return Decision(direction, fraction, saturated), integral


def predict_step(model: PlantModel, kp: float, ki: float, period: float, target: float,
                 periods: int):
    """The sampled loop of :func:`pi_step` on the identified lines (x(k+1) = x(k) + T v),
    simulated by python-control (``nlsys``); returns (t, x) [s, m]."""
    import control as ct

    def update(t, state, u, params):
        x, integral = state
        decision, integral = pi_step(model, kp, ki, period, integral, u[0] - x)
        return [x + period * model.velocity(decision.direction, decision.amplitude), integral]

    sys = ct.nlsys(update, lambda t, s, u, p: s[0:1], inputs=1, outputs=1, states=2,
                   dt=period)
    t = period * np.arange(periods + 1)
    resp = ct.input_output_response(sys, t, np.full_like(t, target), X0=[0.0, 0.0])
    return t, np.asarray(resp.outputs).ravel()


def _open_loop(kp, ki, period):
    import control as ct
    plant = ct.tf([period], [1.0, -1.0], period)
    ctrl = ct.tf([kp + ki * period, -kp], [1.0, -1.0], period) if ki else ct.tf([kp], [1.0],
                                                                              period)
    return ct.minreal(ctrl * plant, verbose=False)


def _bandwidth(closed, period) -> float:
    """-3 dB frequency of a sampled closed loop below the Nyquist frequency, [Hz]."""
    w = np.linspace(1e-3, math.pi / period, 20000)
    mag = np.abs(closed(np.exp(1j * w * period)))
    below = np.flatnonzero(mag < 1.0 / math.sqrt(2.0))
    return float(w[below[0]] / (2.0 * math.pi)) if below.size else math.inf


def _load_peak(loop, period) -> float:
    """Peak of x for a unit velocity step entering at the plant's input, x = P/(1 + C P) d."""
    import control as ct
    plant = ct.tf([period], [1.0, -1.0], period)
    disturbed = ct.feedback(plant, ct.minreal(loop / plant, verbose=False))
    dist = ct.step_response(disturbed, T=period * np.arange(400))
    return float(np.max(np.abs(np.asarray(dist.outputs).ravel())))


def design(model: PlantModel, target: float = options.TARGET.default * options.TARGET.si,
           periods: int = 1) -> Design:
    """Gains, margins and the predicted step and bandwidth (module docstring), for a
    controller sampled every ``periods`` pump periods: the sample-and-hold of the loop is
    then T = periods / f (the plant P(z) = T / (z - 1) at that T, the gains K_p and K_i
    scaled with it, so the loop in z is the same and its frequencies scale as 1/T).
    ``model`` must move both ways (:func:`smeha.studies.position.check_plant`)."""
    import warnings

    import control as ct
    gmt.errors.check_range("periods", periods, 1, 1000, unit="", low_open=False)
    if not (model.v_max_down > 0.0 > model.v_max_up):
        raise gmt.ParameterError(f"the plant must move both ways: full drive gives "
                                 f"{model.v_max_down:g} m/s down and {model.v_max_up:g} m/s up")
    period = int(periods) / model.frequency
    kp = LOOP_GAIN / period
    ki = INTEGRAL_RATIO * kp / period
    loop = _open_loop(kp, ki, period)
    with warnings.catch_warnings():  # the integrators' pole on the unit circle
        warnings.simplefilter("ignore", RuntimeWarning)
        _, pm, _, wc = ct.margin(loop)
    closed = ct.feedback(loop, 1)
    info = ct.step_info(closed)
    speed = model.v_max_down if target > 0 else -model.v_max_up
    t, x = predict_step(model, kp, ki, period, target,
                        int(4 * abs(target) / speed / period) + 200)
    m = step_metrics(t, x, target)
    return Design(kp=kp, ki=ki, period=period, phase_margin_deg=float(pm),
                  gain_margin=1.0 / abs(complex(loop(-1.0))),  # phase crossover at Nyquist
                  crossover_Hz=float(wc) / (2 * math.pi),
                  bandwidth_Hz=_bandwidth(closed, period),
                  rise_time_linear_s=float(info["RiseTime"]),
                  overshoot_linear=float(info["Overshoot"]) / 100.0,
                  predicted_rise_time_s=m["rise_time_s"],
                  predicted_settling_time_s=m["settling_time_s"],
                  predicted_overshoot=m["overshoot_fraction"],
                  predicted_load_peak_m_per_N=_load_peak(loop, period) * abs(model.droop_down))


class Controller:
    """The PI position controller of the design (:func:`pi_step`), sampled every
    ``gains.period``.

    For the first ``settle`` periods it holds (amplitude 0) while the load settles on the
    oil; then the command is ``relative(t - start)`` about the position reached then
    (``origin``), ``start`` = settle T.
    """

    def __init__(self, model: PlantModel, gains: Design, limit: float, relative,
                 settle: int = 0):
        self.model, self.gains, self.limit, self.relative = model, gains, limit, relative
        self.settle = settle
        self.start = settle / model.frequency  # the pump's periods
        self.origin = None
        self.integral = 0.0
        self.direction = "down"
        #: pump periods a decision holds (the design's sample period over the pump's)
        self.every = max(int(round(gains.period * model.frequency)), 1)
        self.last = Decision(self.direction, 0.0)

    def reference(self, t) -> float:
        """The position command r(t), [m] (NaN while settling)."""
        if self.origin is None or t < self.start - TIME_TOLERANCE:
            return math.nan
        return self.origin + self.relative(t - self.start)

    def __call__(self, k, t, x) -> Decision:
        if k < self.settle:
            return Decision(self.direction, 0.0)
        if (k - self.settle) % self.every:  # between the controller's samples: held
            return self.last
        if self.origin is None:
            self.origin = x
        g = self.gains
        step, self.integral = pi_step(self.model, g.kp, g.ki, g.period, self.integral,
                                      self.reference(t) - x)
        self.direction = step.direction
        self.last = Decision(step.direction, step.amplitude * self.limit, step.saturated)
        return self.last


def step_metrics(t, x, target, band: float = 0.02) -> dict:
    """Rise time (10-90 %), overshoot, settling time (``band`` of the step) of x(t) - x(0)
    towards ``target``, and the final error, SI. A level not reached gives NaN (the
    report says which: "not settled within the duration")."""
    t, y = np.asarray(t, float), (np.asarray(x, float) - x[0]) / target

    def first(level):
        i = np.flatnonzero(y >= level)
        return float(t[i[0]]) if i.size else math.nan
    outside = np.flatnonzero(np.abs(y - 1.0) > band)
    settle = float(t[outside[-1] + 1]) if outside.size and outside[-1] + 1 < t.size else (
        math.nan if outside.size else float(t[0]))
    return {"rise_time_s": first(0.9) - first(0.1),
            "overshoot_fraction": max(float(y.max()) - 1.0, 0.0),
            "settling_time_s": settle, "settled": math.isfinite(settle),
            "final_error_m": float(abs(target * (1.0 - y[-1])))}
