"""The cylinder's position in closed loop through the transducer FMU (``smeha position``).

The pump runs at a fixed frequency f. A position controller, sampled once a pump period
T = 1/f (:mod:`smeha.studies.positionloop`) or every N-th one (``controller_rate`` = f/N:
its decision then holds N periods, and the design's T is N/f), sets the cylinder's
direction (Figure 2's stages 1-2 or 3-4) and the drive amplitude (the current amplitude uncompensated, the
demanded stroke compensated) from the position error, up to an amplitude limit (the
paper's drive: I_m = 1 A uncompensated, the Figure 10 control amplitude compensated), so
that a long step runs at the flow table's point.

Design (:func:`identify`, :func:`design`), in python-control:

* **identified plant**: the cylinder is an integrator of the piston velocity. Open-loop
  runs of the same co-simulation at a few amplitudes give, in each direction, the
  period-averaged velocity against the amplitude; it is a straight line,
  v = v_0 + g a (a the amplitude as a fraction of the limit), with an offset v_0 < 0 that
  is the load's: each time the valves switch, the load's pressure pushes oil back
  through the compliant pump chamber (the rod's stiffness K over A_d^2), so the load
  drives the cylinder back at ~0.09 mm/s per N (down, realistic circuit, 100 Hz,
  compensated). The droop dv/dF comes from a run at a second load. An amplitude of 0
  stops the valves and holds the piston on the oil.
* **controller**: the velocity wanted, v* = K_p e + K_i sum(e T) (PI, the integral
  clamped while the drive saturates: anti-windup), is turned into a direction and an
  amplitude through the identified lines (their inverse), so that the loop the design
  sees is the pumping's sample-and-hold of an integrator, P(z) = T / (z - 1) (the
  piston moves during each period's compression and stands during its expansion: the
  sampled position is exact at the period's start; the valves' 0.2 ms dead time is 2 %
  of the period, left out). Inside a hold band (5 um) the drive stops.
* **prediction**: python-control's margins and closed-loop bandwidth of that loop, and its
  step response with the velocity limits (a nonlinear, sampled ``control.nlsys``): a
  long step runs at the largest velocity v_0 + g, so the rise time is mostly
  0.8 step / v_max.

The co-simulation then verifies them: a position step, sine tracking at several
frequencies (the measured closed-loop -3 dB bandwidth), and a load step.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

import gmt
from system_models import presets
from system_models.cosim import CosimSettings, DirectTransducer, FmuTransducer
from system_models.defaults import DEFAULT_STEP, HYDRAULIC_STEP, VALVE_CONTROLLER_PERIOD
from system_models.fluid import MINIMUM_PRESSURE

from . import flow
from .positioncommands import FREQUENCY_HZ, LOAD_STEP_N, TARGET_MM
from .positionloop import Decision, LoopRecord, run_loop

__all__ = ["PositionSettings", "PlantModel", "Design", "PositionResult", "identify", "design",
           "run_study", "step_metrics", "MODES", "SCENARIOS", "open_backend", "Controller",
           "run_step", "run_sine", "run_load_step", "default_sine_frequencies",
           "flow_table_velocity", "format_report"]

MODES = flow.MODES
SCENARIOS = ("step", "sine", "load")
#: Amplitudes (fractions of the limit) of the identification runs, and its periods.
IDENTIFY_FRACTIONS = (0.1, 0.5, 1.0)
IDENTIFY_PERIODS = 16
#: Periods an identification run discards before averaging (the chamber's first fill).
IDENTIFY_SKIP = 4
#: Load added for the droop's identification run, [N].
DROOP_LOAD = 50.0
#: Loop gain K_p T of the design: the closed-loop pole at z = 1 - K_p T = 0.7, a
#: monotone first-order approach with a time constant of 2.8 periods.
LOOP_GAIN = 0.3
#: Integral gain over proportional gain times T, K_i T / K_p: the integral's zero at
#: z = 1 - 0.05, a twentieth of the loop's speed (phase margin ~80 deg).
INTEGRAL_RATIO = 0.05
#: The controller stops the drive within this distance of the command, [m]: 0, it never
#: does. A hold puts the valves at rest, and the first period after one pumps the load's
#: pressure back into the chamber (~50 um at 150 N): holding near the command makes a limit
#: cycle of hold and pump; the integral and the lines' offsets hold the position instead.
HOLD_BAND = 0.0
#: Periods the runs hold (amplitude 0) before the command starts: the load settles on the
#: oil from the circuit's rest state (its first period moves the piston ~0.4 mm at 150 N).
SETTLE_PERIODS = 5
#: Default step [m], load step [N] and pump frequency [Hz] (smeha.studies.positioncommands).
TARGET = TARGET_MM * 1e-3
LOAD_STEP = LOAD_STEP_N
FREQUENCY = FREQUENCY_HZ
#: The piston this close to an end stop is flagged, [m].
END_STOP_MARGIN = 0.5e-3


@dataclass(frozen=True)
class PositionSettings:
    """One position study (every default defined here once; checked on construction)."""

    mode: str = "compensated"
    target: float = TARGET  #: the step, [m]; > 0 moves "down" (x grows)
    frequency: float = FREQUENCY  #: pump frequency, [Hz]
    load: float | None = None  #: [N] on the cylinder, opposing "down"; None: the circuit's
    duration: float | None = None  #: simulated time of the step, [s]; None: from the design
    circuit: str = "realistic"
    variant: gmt.ModelVariant | None = None
    backend: str = "fmu"
    step: float = DEFAULT_STEP
    load_step: float = LOAD_STEP  #: the load scenario's step of load, [N]
    sine_amplitude: float = 0.1e-3  #: the sine scenario's amplitude, [m]
    #: the controller's sample rate, [Hz]: the pump frequency over a whole number N (the
    #: drive changes at a period's start, so the controller decides every N-th one and its
    #: decision holds N periods); None: the pump frequency, once a period
    controller_rate: float | None = None

    def __post_init__(self):
        check = gmt.errors.check_range
        if self.mode not in MODES:
            raise gmt.ParameterError(f"mode = {self.mode!r} is not one of {MODES}")
        if self.circuit not in flow.CIRCUITS:
            raise gmt.ParameterError(f"circuit = {self.circuit!r} is not one of "
                                     f"{flow.CIRCUITS}")
        check("target", self.target, -20e-3, 20e-3, unit="m")
        if self.target == 0.0:
            raise gmt.ParameterError("target = 0 m: a step needs a distance")
        check("frequency", self.frequency, 0.0, 1000.0, unit="Hz", high_open=False)
        if self.load is not None:
            check("load", self.load, -1e4, 1e4, unit="N")
        if self.duration is not None:
            check("duration", self.duration, 0.0, 60.0, unit="s", high_open=False)
        check("step", self.step, 0.0, 1e-3, unit="s", high_open=False)
        check("load_step", self.load_step, -1e4, 1e4, unit="N")
        check("sine_amplitude", self.sine_amplitude, 0.0, 10e-3, unit="m", high_open=False)
        if self.backend not in ("fmu", "direct"):
            raise gmt.ParameterError(f"backend = {self.backend!r} is not one of "
                                     "('fmu', 'direct')")
        if self.controller_rate is not None:
            check("controller_rate", self.controller_rate, 0.0, self.frequency, unit="Hz",
                  high_open=False)
            n = self.frequency / self.controller_rate
            if abs(n - round(n)) > 1e-6 * n:
                raise gmt.ParameterError(
                    f"controller_rate = {self.controller_rate:g} Hz does not divide the pump "
                    f"frequency {self.frequency:g} Hz: the drive changes at a pump period's "
                    f"start, so the controller samples every N-th period (e.g. "
                    f"{self.frequency / max(math.floor(n), 1):g} or "
                    f"{self.frequency / math.ceil(n):g} Hz)")

    @property
    def controller_periods(self) -> int:
        """N: pump periods a controller sample holds (1: once a period)."""
        if self.controller_rate is None:
            return 1
        return int(round(self.frequency / self.controller_rate))

    @property
    def load_force(self) -> float:
        return presets.default_load(self.circuit) if self.load is None else float(self.load)

    @property
    def amplitude_limit(self) -> float:
        """The drive's limit: a [V] of Figure 10 compensated, I_m = 1 A uncompensated."""
        if self.mode == "compensated":
            return flow.control_amplitude(self.frequency)
        return flow.CURRENT_AMPLITUDE


def open_backend(settings: PositionSettings, fmu_path=None):
    """The transducer at rest, its operating point following the drive (follow_drive)."""
    drive = gmt.DriveParameters(compensated=settings.mode == "compensated")
    if settings.backend == "direct":
        return DirectTransducer(gmt.TransducerParameters(),
                                gmt.Excitation(settings.frequency, flow.CURRENT_AMPLITUDE,
                                               follow_drive=settings.variant is None),
                                drive, settings.variant)
    start = {"frequency": settings.frequency, "current_amplitude": flow.CURRENT_AMPLITUDE,
             "compensated": drive.compensated, "follow_drive": settings.variant is None,
             **flow.variant_start_values(settings.variant)}
    return FmuTransducer(fmu_path or flow.default_fmu_path(), start)


def _cosim_settings(settings: PositionSettings) -> CosimSettings:
    return CosimSettings(step=settings.step, controller_period=VALVE_CONTROLLER_PERIOD,
                         hydraulic_step=HYDRAULIC_STEP)


def _loop(settings, fmu_path, periods, decide, command=lambda t: 0.0, load=None):
    backend = open_backend(settings, fmu_path)
    force = settings.load_force
    try:
        return run_loop(backend, settings.mode, presets.circuit(settings.circuit),
                        settings.frequency, periods, decide, command,
                        load or (lambda t: force), _cosim_settings(settings))
    finally:
        backend.close()


# -- the identified plant ---------------------------------------------------------------
@dataclass(frozen=True)
class PlantModel:
    """Identified velocity lines of each direction, SI (module docstring).

    Down: v = v0_down + g_down a; up: v = v0_up - g_up a (v < 0: x falls), a in (0, 1]
    of the amplitude limit; a = 0 holds. ``droop_down``/``droop_up``: dv/dF [m/s/N].
    ``points``: (direction, fraction, velocity) of each identification run.
    """

    frequency: float
    v0_down: float
    g_down: float
    v0_up: float
    g_up: float
    droop_down: float
    droop_up: float
    points: tuple = ()

    @property
    def v_max_down(self) -> float:
        return self.v0_down + self.g_down

    @property
    def v_max_up(self) -> float:
        """The largest speed up, as a negative velocity [m/s]."""
        return self.v0_up - self.g_up

    def command(self, velocity: float) -> tuple[str, float, bool]:
        """Direction, amplitude fraction and saturation that give ``velocity`` [m/s]."""
        if velocity >= self.v0_down or velocity > 0.5 * (self.v0_down + self.v0_up):
            a = (velocity - self.v0_down) / self.g_down
            return "down", min(max(a, 1e-3), 1.0), a > 1.0
        a = (self.v0_up - velocity) / self.g_up
        return "up", min(max(a, 1e-3), 1.0), a > 1.0

    def as_dict(self) -> dict:
        d = asdict(self)
        d["points"] = [list(p) for p in self.points]
        return d


def _velocity(record: LoopRecord) -> float:
    """Mean piston velocity over the settled periods of an open-loop run, [m/s]."""
    x = record.periods["position"]
    return float((x[-1] - x[IDENTIFY_SKIP]) / (len(x) - 1 - IDENTIFY_SKIP) * record.frequency)


def identify(settings: PositionSettings, fmu_path=None) -> PlantModel:
    """Open-loop runs at :data:`IDENTIFY_FRACTIONS` of the limit in each direction, and
    at full drive with :data:`DROOP_LOAD` more load: the lines of :class:`PlantModel`."""
    limit = settings.amplitude_limit
    points, lines, droops = [], {}, {}
    for direction in ("down", "up"):
        v = []
        for frac in IDENTIFY_FRACTIONS:
            rec = _loop(settings, fmu_path, IDENTIFY_PERIODS + 1,
                        lambda k, t, x, d=direction, a=frac * limit: Decision(d, a))
            v.append(_velocity(rec))
            points.append((direction, frac, v[-1]))
        slope, offset = np.polyfit(IDENTIFY_FRACTIONS, v, 1)
        lines[direction] = (float(offset), float(slope))
        heavier = settings.load_force + DROOP_LOAD
        rec = _loop(settings, fmu_path, IDENTIFY_PERIODS + 1,
                    lambda k, t, x, d=direction: Decision(d, limit), load=lambda t: heavier)
        droops[direction] = (_velocity(rec) - v[-1]) / DROOP_LOAD
    (v0d, gd), (v0u, gu) = lines["down"], lines["up"]
    return PlantModel(settings.frequency, v0d, gd, v0u, -gu, droops["down"], droops["up"],
                      tuple(points))


# -- the design -------------------------------------------------------------------------
@dataclass(frozen=True)
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
    predicted_settling_time_s: float  #: 2 % band, with the velocity limits
    predicted_overshoot: float  #: fraction, with the velocity limits
    #: peak deflection per newton of a load step while holding, from the droop alone
    #: (a velocity step dv/dF entering the loop), [m/N]; down's droop
    predicted_load_peak_m_per_N: float = math.nan

    def as_dict(self) -> dict:
        return asdict(self)


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


def _saturated_step(model: PlantModel, kp, ki, period, target, periods):
    """The sampled loop with the velocity limits, simulated by python-control (nlsys)."""
    import control as ct
    vmax, vmin = model.v_max_down, model.v_max_up

    def update(t, state, u, params):
        x, integral = state
        e = u[0] - x
        v = kp * e + integral
        sat = v > vmax or v < vmin
        v = min(max(v, vmin), vmax)
        return [x + period * v, integral if sat else integral + ki * period * e]

    sys = ct.nlsys(update, lambda t, s, u, p: s[0:1], inputs=1, outputs=1, states=2,
                   dt=period)
    t = period * np.arange(periods + 1)
    resp = ct.input_output_response(sys, t, np.full_like(t, target), X0=[0.0, 0.0])
    return t, np.asarray(resp.outputs).ravel()


def design(model: PlantModel, target: float = TARGET, periods: int = 1) -> Design:
    """Gains, margins and the predicted step and bandwidth (module docstring), for a
    controller sampled every ``periods`` pump periods: the sample-and-hold of the loop is
    then T = periods / f (the plant P(z) = T / (z - 1) at that T, the gains K_p and K_i
    scaled with it, so the loop in z is the same and its frequencies scale as 1/T)."""
    import warnings

    import control as ct
    gmt.errors.check_range("periods", periods, 1, 1000, unit="", low_open=False)
    period = int(periods) / model.frequency
    kp = LOOP_GAIN / period
    ki = INTEGRAL_RATIO * kp / period
    loop = _open_loop(kp, ki, period)
    with warnings.catch_warnings():  # the integrators' pole on the unit circle
        warnings.simplefilter("ignore", RuntimeWarning)
        _, pm, _, wc = ct.margin(loop)
    gm = 1.0 / abs(complex(loop(-1.0)))  # phase crossover at the Nyquist frequency
    closed = ct.feedback(loop, 1)
    info = ct.step_info(closed)
    speed = model.v_max_down if target > 0 else -model.v_max_up
    periods = int(4 * abs(target) / speed / period) + 200
    t, x = _saturated_step(model, kp, ki, period, target, periods)
    m = step_metrics(t, x, target)
    # a load step: the droop's velocity dv/dF at the plant's input, x = P / (1 + C P) d
    plant = ct.tf([period], [1.0, -1.0], period)
    disturbed = ct.feedback(plant, ct.minreal(loop / plant, verbose=False))
    dist = ct.step_response(disturbed, T=period * np.arange(400))
    peak = float(np.max(np.abs(np.asarray(dist.outputs).ravel())))
    return Design(kp, ki, period, float(pm), float(gm), float(wc) / (2 * math.pi),
                  _bandwidth(closed, period), float(info["RiseTime"]),
                  float(info["Overshoot"]) / 100.0, m["rise_time_s"], m["settling_time_s"],
                  m["overshoot_fraction"], peak * abs(model.droop_down))


# -- the controller ---------------------------------------------------------------------
class Controller:
    """The PI position controller of the design, sampled once a period (module docstring).

    For the first ``settle`` periods it holds (amplitude 0) while the load settles on the
    oil; then the command is ``relative(t - start)`` about the position reached then
    (``origin``), ``start`` = settle T.
    """

    def __init__(self, model: PlantModel, gains: Design, limit: float, relative,
                 settle: int = 0, hold_band: float = HOLD_BAND):
        self.model, self.gains, self.limit, self.relative = model, gains, limit, relative
        self.settle, self.hold_band = settle, hold_band
        self.start = settle / model.frequency  # the pump's periods
        self.origin = None
        self.integral = 0.0
        self.direction = "down"
        #: pump periods a decision holds (the design's sample period over the pump's)
        self.every = max(int(round(gains.period * model.frequency)), 1)
        self.last = Decision(self.direction, 0.0)

    def reference(self, t) -> float:
        """The position command r(t), [m] (NaN while settling)."""
        if self.origin is None or t < self.start - 1e-12:
            return math.nan
        return self.origin + self.relative(t - self.start)

    def __call__(self, k, t, x) -> Decision:
        if k < self.settle:
            return Decision(self.direction, 0.0)
        if (k - self.settle) % self.every:  # between the controller's samples: held
            return self.last
        self.last = self._decide(t, x)
        return self.last

    def _decide(self, t, x) -> Decision:
        """One sample of the PI law (module docstring)."""
        if self.origin is None:
            self.origin = x
        e = self.reference(t) - x
        if abs(e) <= self.hold_band:
            return Decision(self.direction, 0.0)
        v = self.gains.kp * e + self.integral
        direction, frac, saturated = self.model.command(v)
        if not saturated:  # anti-windup: the integral stands while the drive is at its limit
            self.integral += self.gains.ki * self.gains.period * e
        self.direction = direction
        return Decision(direction, frac * self.limit, saturated)


# -- metrics ----------------------------------------------------------------------------
def step_metrics(t, x, target, band: float = 0.02) -> dict:
    """Rise time (10-90 %), overshoot, settling time (``band`` of the step) of x(t) - x(0)
    towards ``target``, and the final error, SI."""
    t, y = np.asarray(t, float), (np.asarray(x, float) - x[0]) / target
    def first(level):
        i = np.flatnonzero(y >= level)
        return float(t[i[0]]) if i.size else math.nan
    outside = np.flatnonzero(np.abs(y - 1.0) > band)
    settle = float(t[outside[-1] + 1]) if outside.size and outside[-1] + 1 < t.size else (
        math.nan if outside.size else float(t[0]))
    return {"rise_time_s": first(0.9) - first(0.1),
            "overshoot_fraction": max(float(y.max()) - 1.0, 0.0),
            "settling_time_s": settle,
            "final_error_m": float(abs(target * (1.0 - y[-1])))}


@dataclass
class PositionResult:
    """One scenario's run: its figures (``figures``), flags and the record."""

    scenario: str
    mode: str
    figures: dict
    flags: list = field(default_factory=list)
    record: LoopRecord | None = None

    def as_dict(self) -> dict:
        return {"scenario": self.scenario, "mode": self.mode, **self.figures,
                "flags": list(self.flags)}


def _flags(record: LoopRecord, circuit) -> list:
    """End stops, cavitation, direction reversals mid-stroke: never silent."""
    rows, per = record.rows, record.periods
    out = []
    x = rows["piston_position"]
    stroke = circuit.cylinder.stroke
    if x.min() < END_STOP_MARGIN or x.max() > stroke - END_STOP_MARGIN:
        out.append(f"end stop: the piston came within {END_STOP_MARGIN * 1e3:g} mm of an end "
                   f"of its {stroke * 1e3:g} mm stroke ({x.min() * 1e3:.2f} to "
                   f"{x.max() * 1e3:.2f} mm)")
    p_min, volume = flow.lowest_pressure(rows)
    if p_min < MINIMUM_PRESSURE:
        out.append(f"cavitation: the {volume}'s pressure fell to {p_min / 1e6:.2f} MPa "
                   "absolute, below what oil holds; the co-simulation assumes the tension")
    outside = int(per["outside"].sum())
    if outside:
        out.append(f"design point: the coil current departed from the model's operating point "
                   f"at the end of {outside} of {len(per)} periods (gmt.design_point; the "
                   "model follows the drive's frequency and amplitude, follow_drive, but a "
                   "compensated small demand from the stroke's bottom is an offset current, "
                   "and a changing amplitude no sinusoid)")
    pumping = per["amplitude"] > 0.0
    d = per["direction"][pumping]
    reversals = int(np.sum(d[1:] != d[:-1]))
    if reversals:
        out.append(f"direction reversed {reversals} time(s) while pumping (the controller "
                   "correcting an overshoot or tracking)")
    return out


def _run(settings, model, gains, relative, duration, fmu_path, load=None):
    """One closed-loop run: settle, then ``relative`` about the settled position for
    ``duration``; returns (record, controller, rows after the start)."""
    period = 1.0 / settings.frequency
    periods = SETTLE_PERIODS + int(math.ceil(duration / period - 1e-9))
    ctrl = Controller(model, gains, settings.amplitude_limit, relative, SETTLE_PERIODS)
    rec = _loop(settings, fmu_path, periods, ctrl, ctrl.reference, load)
    after = rec.rows["time"] >= ctrl.start - 1e-12
    return rec, ctrl, after


def _velocities(record, start) -> np.ndarray:
    """Period-averaged piston velocities from ``start`` on, [m/s] (the flow table's flows
    are period means, so these compare with them)."""
    per = record.periods
    x = per["position"][per["time"] >= start - 1e-12]
    return np.diff(x) * record.frequency


def run_step(settings, model, gains, fmu_path=None) -> PositionResult:
    """A step of ``settings.target`` from rest: rise time (10-90 %), overshoot, settling
    time (2 %), the final error at the run's end, the largest period-averaged speed."""
    duration = settings.duration or max(2.0 * gains.predicted_settling_time_s, 0.3)
    rec, ctrl, after = _run(settings, model, gains, lambda t: settings.target, duration,
                            fmu_path)
    t, x = rec.rows["time"][after] - ctrl.start, rec.rows["piston_position"][after]
    m = step_metrics(t, x, settings.target)
    v = _velocities(rec, ctrl.start)
    m.update(max_velocity_m_s=float(np.max(np.abs(v))) if v.size else 0.0,
             predicted_rise_time_s=gains.predicted_rise_time_s,
             predicted_settling_time_s=gains.predicted_settling_time_s,
             wall_s=rec.wall_s, cpu_s=rec.cpu_s, simulated_s=float(rec.rows["time"][-1]),
             saturated_periods=int(rec.periods["saturated"].sum()))
    return PositionResult("step", settings.mode, m,
                          _flags(rec, presets.circuit(settings.circuit)), rec)


def run_sine(settings, model, gains, frequencies, fmu_path=None) -> PositionResult:
    """Sine tracking at each frequency: the fundamental's gain and phase of x against the
    command over the last two cycles; the -3 dB bandwidth interpolated on a log scale."""
    amp = settings.sine_amplitude
    rows, wall, simulated, flags = [], 0.0, 0.0, []
    for fs in frequencies:
        w = 2 * math.pi * fs
        rec, ctrl, after = _run(settings, model, gains, lambda t, w=w: amp * math.sin(w * t),
                                max(4.0 / fs, 0.3), fmu_path)
        t = rec.rows["time"][after] - ctrl.start
        x = rec.rows["piston_position"][after] - ctrl.origin
        keep = t >= t[-1] - 2.0 / fs
        basis = np.exp(-1j * w * t[keep])
        ratio = np.sum(x[keep] * basis) / np.sum(amp * np.sin(w * t[keep]) * basis)
        rows.append({"frequency_Hz": fs, "gain": float(abs(ratio)),
                     "phase_deg": float(np.degrees(np.angle(ratio)))})
        wall += rec.wall_s
        simulated += float(rec.rows["time"][-1])
        seen = {f.split(":")[0] for f in flags}  # one flag of a kind over the frequencies
        flags += [f for f in _flags(rec, presets.circuit(settings.circuit))
                  if f.split(":")[0] not in seen]
    gains_db = np.array([20 * math.log10(r["gain"]) for r in rows])
    bw = math.nan
    below = np.flatnonzero(gains_db < -3.0)
    if below.size and below[0] > 0:
        i = below[0]
        f1, f2, g1, g2 = frequencies[i - 1], frequencies[i], gains_db[i - 1], gains_db[i]
        bw = float(math.exp(math.log(f1) + math.log(f2 / f1) * (-3.0 - g1) / (g2 - g1)))
    figures = {"bandwidth_Hz": bw, "predicted_bandwidth_Hz": gains.bandwidth_Hz,
               "sine_amplitude_m": amp, "tracking": rows, "wall_s": wall,
               "simulated_s": simulated}
    return PositionResult("sine", settings.mode, figures, flags, None)


#: The load scenario: the load steps this long after the command starts, [s].
LOAD_STEP_AT = 0.05


def run_load_step(settings, model, gains, fmu_path=None) -> PositionResult:
    """Hold the settled position, then add ``load_step`` N: the largest deflection, the
    stiffness (load step over that deflection), the recovery time (back within a tenth
    of the peak) and the error at the end."""
    duration = settings.duration or 0.5
    base, extra = settings.load_force, settings.load_step
    at = SETTLE_PERIODS / settings.frequency + LOAD_STEP_AT
    rec, ctrl, after = _run(settings, model, gains, lambda t: 0.0, duration, fmu_path,
                            load=lambda t: base + (extra if t >= at - 1e-12 else 0.0))
    t, x = rec.rows["time"], rec.rows["piston_position"] - ctrl.origin
    late = t >= at - 1e-12
    dev = x[late]
    peak = float(dev[np.argmax(np.abs(dev))])
    out = np.flatnonzero(np.abs(dev) > 0.1 * abs(peak))
    if out.size and out[-1] == dev.size - 1:
        recovery = math.nan  # not back within the run
    else:
        recovery = float(t[late][out[-1]] - at) if out.size else 0.0
    figures = {"load_step_N": extra, "peak_deflection_m": peak,
               "predicted_peak_deflection_m": -math.copysign(
                   gains.predicted_load_peak_m_per_N * abs(extra), extra),
               "stiffness_N_per_m": float(abs(extra / peak)) if peak else math.inf,
               "recovery_time_s": recovery, "final_error_m": float(abs(x[-1])),
               "wall_s": rec.wall_s, "simulated_s": float(t[-1])}
    flags = _flags(rec, presets.circuit(settings.circuit))
    tail = rec.periods["saturated"][-max(len(rec.periods) // 5, 1):]
    if tail.all():
        flags.append(f"the drive is at its limit after the load step: {base + extra:g} N is "
                     "about all the pump holds at this frequency and mode (its load line's "
                     "stall), so the position is not recovered")
    return PositionResult("load", settings.mode, figures, flags, rec)


def run_study(settings: PositionSettings, scenarios=("step",), sine_frequencies=None,
              fmu_path=None) -> dict:
    """Identify, design, then run each scenario; returns {"model", "design", "results"}."""
    model = identify(settings, fmu_path)
    gains = design(model, settings.target, settings.controller_periods)
    results = []
    for scenario in scenarios:
        if scenario == "step":
            results.append(run_step(settings, model, gains, fmu_path))
        elif scenario == "sine":
            fs = sine_frequencies or default_sine_frequencies(gains)
            results.append(run_sine(settings, model, gains, fs, fmu_path))
        elif scenario == "load":
            results.append(run_load_step(settings, model, gains, fmu_path))
        else:
            raise gmt.ParameterError(f"scenario = {scenario!r} is not one of {SCENARIOS}")
    return {"model": model, "design": gains, "results": results}


def default_sine_frequencies(gains: Design) -> list:
    """Half an octave apart around the predicted bandwidth, up to a fifth of the pump
    frequency (the controller's sample rate)."""
    top = 0.2 / gains.period
    fs = [gains.bandwidth_Hz * r for r in (0.25, 0.5, 0.71, 1.0, 1.41, 2.0)]
    return [round(f, 2) for f in fs if f <= top]


def flow_table_velocity(settings: PositionSettings, fmu_path=None) -> float:
    """The flow table's flow at the study's point (``smeha flow``: the same frequency,
    mode, circuit and load, direction down) over the big cavity's area, [m/s]."""
    case = flow.Case(settings.frequency, settings.mode, circuit=settings.circuit,
                     load=settings.load_force, backend=settings.backend,
                     variant=settings.variant, step=settings.step)
    row = flow.run_case(case, fmu_path)[2]
    area = presets.circuit(settings.circuit).cylinder
    return row["flow_sim_m3_s"] / (math.pi * area.bore_diameter ** 2 / 4.0)


#: The largest departure of the step's top speed from the flow table's, as a fraction:
#: the issue's bound (what the position study must reproduce of the flow study).
VELOCITY_TOLERANCE = 0.15


def _pct(x):
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.1f} %"


def _num(x, fmt):
    return "-" if x is None or not math.isfinite(x) else format(x, fmt)


def format_report(out: dict, settings: PositionSettings) -> str:
    """The terminal report of ``smeha position``: per mode the identified lines, the
    design, then one table of the scenarios (measured beside predicted)."""
    lines = [f"Position control through the transducer FMU: {settings.frequency:g} Hz pump, "
             f"{settings.circuit} circuit, {settings.load_force:g} N load (opposing down)"]
    for mode, study in out.items():
        m, d = study["model"], study["design"]
        lines += [
            f"{mode}: identified v = v0 + g a (a: amplitude / limit, period means): "
            f"down v0 {m.v0_down * 1e3:+.2f} mm/s, g {m.g_down * 1e3:.2f} mm/s; up v0 "
            f"{m.v0_up * 1e3:+.2f} mm/s, g {m.g_up * 1e3:.2f} mm/s; droop dv/dF "
            f"{m.droop_down * 1e6:.1f} (down) / {m.droop_up * 1e6:.1f} (up) um/s per N",
            f"  design (python-control): K_p {d.kp:.1f} 1/s, K_i {d.ki:.1f} 1/s^2 (T = "
            f"{d.period * 1e3:g} ms); phase margin {d.phase_margin_deg:.0f} deg, gain margin "
            f"{d.gain_margin:.2f}, crossover {d.crossover_Hz:.2f} Hz, closed-loop bandwidth "
            f"{d.bandwidth_Hz:.2f} Hz; step {settings.target * 1e3:g} mm with the velocity "
            f"limits: rise {d.predicted_rise_time_s:.3f} s, settling "
            f"{d.predicted_settling_time_s:.3f} s, overshoot {_pct(d.predicted_overshoot)}"]
    head = (f"{'mode':<13}  {'rise [s]':>8}  {'(pred)':>7}  {'overshoot':>9}  {'settle [s]':>10}"
            f"  {'(pred)':>7}  {'final err [um]':>14}  {'v max [mm/s]':>12}  "
            f"{'flow/A_B':>8}  {'wall [s]':>8}  {'CPU [s]':>7}  {'sim [s]':>7}  "
            f"{'x real time (CPU)':>17}")
    lines += ["", f"Position step {settings.target * 1e3:g} mm (v max: the fastest period mean; "
              "flow/A_B: smeha flow's flow at this point over the big cavity's area; real "
              "time: simulated over wall time, and over the process's CPU time, the FMU "
              "running in-process)", head]
    notes = []
    for mode, study in out.items():
        step = study["results"][0].figures
        qa = study["flow_velocity_m_s"]
        lines.append(
            f"{mode:<13}  {step['rise_time_s']:>8.3f}  {step['predicted_rise_time_s']:>7.3f}  "
            f"{_pct(step['overshoot_fraction']):>9}  {_num(step['settling_time_s'], '.3f'):>10}"
            f"  {step['predicted_settling_time_s']:>7.3f}  {step['final_error_m'] * 1e6:>14.1f}"
            f"  {step['max_velocity_m_s'] * 1e3:>12.2f}  {qa * 1e3:>8.2f}  "
            f"{step['wall_s']:>8.2f}  {step['cpu_s']:>7.2f}  {step['simulated_s']:>7.2f}  "
            f"{step['simulated_s'] / step['wall_s']:>8.2f} "
            f"({step['simulated_s'] / step['cpu_s']:.2f})")
        if abs(step["max_velocity_m_s"] / abs(qa) - 1.0) > VELOCITY_TOLERANCE:
            notes.append(f"{mode}: the top speed departs from the flow table's by more than "
                         f"{100 * VELOCITY_TOLERANCE:g} %")
        for res in study["results"]:
            notes += [f"{mode} {res.scenario}: {f}" for f in res.flags]
    if len(out) == 2:
        rise = {m: s["results"][0].figures["rise_time_s"] for m, s in out.items()}
        gain = rise["uncompensated"] / rise["compensated"]
        lines.append(f"compensation: the step rises {gain:.2f}x faster compensated")
    for mode, study in out.items():
        for res in study["results"][1:]:
            f = res.figures
            if res.scenario == "sine":
                lines += ["", f"{mode}: sine tracking, {f['sine_amplitude_m'] * 1e3:g} mm "
                          f"(gain and phase of the position's fundamental against the command)"]
                lines += [f"  {r['frequency_Hz']:>7.2f} Hz  gain {r['gain']:.3f} "
                          f"({20 * math.log10(r['gain']):+.1f} dB)  phase {r['phase_deg']:+.0f} deg"
                          for r in f["tracking"]]
                lines.append(f"  -3 dB bandwidth {_num(f['bandwidth_Hz'], '.2f')} Hz "
                             f"(predicted {f['predicted_bandwidth_Hz']:.2f} Hz)")
            elif res.scenario == "load":
                lines += ["", f"{mode}: load step {f['load_step_N']:+g} N while holding: "
                          f"peak deflection {f['peak_deflection_m'] * 1e6:+.1f} um (droop "
                          f"alone, predicted: {f['predicted_peak_deflection_m'] * 1e6:+.1f} "
                          "um; the oil and the rod's compliance add to it), stiffness "
                          f"{f['stiffness_N_per_m'] / 1e6:.2f} N/um, "
                          + (f"back within a tenth of it after {f['recovery_time_s']:.3f} s"
                             if math.isfinite(f["recovery_time_s"]) else
                             "not back within a tenth of it in the run")
                          + f", error at the end {f['final_error_m'] * 1e6:.1f} um"]
    if notes:
        lines += ["", "(!) " + "\n(!) ".join(notes)]
    return "\n".join(lines)
