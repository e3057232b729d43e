"""The cylinder's position in closed loop through the transducer FMU (``smeha position``).

The pump runs at a fixed frequency f. A position controller, sampled once a pump period
T = 1/f (:mod:`smeha.studies.positionloop`) or every N-th one (``controller_rate`` = f/N:
its decision then holds N periods, and the design's T is N/f), sets the cylinder's
direction (Figure 2's stages 1-2 or 3-4) and the drive amplitude (the current amplitude
uncompensated, the demanded stroke compensated) from the position error, up to an
amplitude limit (the paper's drive: I_m = 1 A uncompensated, the Figure 10 control
amplitude compensated), so that a long step runs at the flow table's point.

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
  The loop needs both directions: a load past the pump's stall load in one of them
  (:mod:`smeha.studies.positionlimits`: the hand calculation decides before any run,
  the identified lines near the limit) and a pump that runs backwards (the flow study's
  ``flow_reversed``) are refused in one line naming the limit (:class:`OutsideEnvelope`).
* **controller** (:mod:`smeha.studies.positiondesign`): the velocity wanted,
  v* = K_p e + K_i sum(e T) (PI, the integral clamped while the drive saturates:
  anti-windup), is turned into a direction and an amplitude through the identified
  lines (their inverse), so that the loop the design sees is the pumping's
  sample-and-hold of an integrator, P(z) = T / (z - 1) (the piston moves during each
  period's compression and stands during its expansion: the sampled position is exact
  at the period's start; the valves' 0.2 ms dead time is 2 % of the period, left out).
* **prediction**: python-control's margins and closed-loop bandwidth of that loop, and its
  step response with the velocity limits (a nonlinear, sampled ``control.nlsys``): a
  long step runs at the largest velocity v_0 + g, so the rise time is mostly
  0.8 step / v_max.

The co-simulation then verifies them: a position step, sine tracking at several
frequencies (the measured closed-loop -3 dB bandwidth), and a load step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import gmt
from system_models import presets
from system_models.cosim import CosimSettings, DirectTransducer, FmuTransducer
from system_models.defaults import (DEFAULT_CYCLES, DEFAULT_STEP, HYDRAULIC_STEP,
                                     VALVE_CONTROLLER_PERIOD)
from system_models.fluid import MINIMUM_PRESSURE

from . import flow
from . import positionoptions as options
from .positionlimits import PumpLimits, pump_limits
from .positiondesign import (INTEGRAL_RATIO, LOOP_GAIN, Controller, Design, PlantModel,
                             design, pi_step, predict_step, step_metrics)
from .positionloop import TIME_TOLERANCE, Decision, LoopRecord, run_loop

__all__ = ["PositionSettings", "PlantModel", "Design", "PositionResult", "identify", "design",
           "run_study", "step_metrics", "MODES", "SCENARIOS", "open_backend", "Controller",
           "pi_step", "predict_step", "run_step", "run_sine", "run_load_step",
           "default_sine_frequencies", "flow_table_velocity", "full_drive_velocity",
           "step_duration",
           "OutsideEnvelope", "check_load", "check_plant", "estimate_wall_time",
           "identification_time"]

MODES = flow.MODES
SCENARIOS = ("step", "sine", "load")
#: Amplitudes (fractions of the limit) of the identification runs, and its periods.
IDENTIFY_FRACTIONS = (0.1, 0.5, 1.0)
IDENTIFY_PERIODS = 16
#: Periods an identification run discards before averaging (the chamber's first fill).
IDENTIFY_SKIP = 4
#: Load added for the droop's identification run, [N].
DROOP_LOAD = 50.0
#: Periods the runs hold (amplitude 0) before the command starts: the load settles on the
#: oil from the circuit's rest state (its first period moves the piston ~0.4 mm at 150 N).
SETTLE_PERIODS = 5
#: Default step [m], load step [N] and pump frequency [Hz] (smeha.studies.positionoptions).
TARGET = options.TARGET.default * options.TARGET.si
LOAD_STEP = options.LOAD_STEP.default
FREQUENCY = options.FREQUENCY.default
SINE_AMPLITUDE = options.SINE_AMPLITUDE.default * options.SINE_AMPLITUDE.si
#: The piston this close to an end stop is flagged, [m].
END_STOP_MARGIN = 0.5e-3
#: The hand calculation's stall loads decide before a run only beyond this fraction of the
#: stall pressure: nearer, the identified lines decide (positionlimits: quasi-static).
HAND_MARGIN = 0.5


class OutsideEnvelope(gmt.errors.InputError):
    """A load, frequency or mode at which the pump cannot move the cylinder both ways."""


@dataclass(frozen=True)
class PositionSettings:
    """One position study (defaults and ranges: :mod:`smeha.studies.positionoptions`)."""

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
    sine_amplitude: float = SINE_AMPLITUDE  #: the sine scenario's amplitude, [m]
    #: the controller's sample rate, [Hz]: the pump frequency over a whole number N (the
    #: drive changes at a period's start, so the controller decides every N-th one and its
    #: decision holds N periods); None: the pump frequency, once a period
    controller_rate: float | None = None

    def __post_init__(self):
        if self.mode not in MODES:
            raise gmt.ParameterError(f"mode = {self.mode!r} is not one of {MODES}")
        if self.circuit not in flow.CIRCUITS:
            raise gmt.ParameterError(f"circuit = {self.circuit!r} is not one of "
                                     f"{flow.CIRCUITS}")
        options.check_target(self.target)
        for name in ("frequency", "load", "duration", "load_step", "sine_amplitude",
                     "controller_rate"):
            if getattr(self, name) is not None:
                options.OPTIONS[name].check_si(getattr(self, name))
        gmt.errors.check_range("step", self.step, 0.0, 1e-3, unit="s", high_open=False)
        if self.backend not in ("fmu", "direct"):
            raise gmt.ParameterError(f"backend = {self.backend!r} is not one of "
                                     "('fmu', 'direct')")
        if self.controller_rate is not None:
            gmt.errors.check_range("controller_rate", self.controller_rate, 0.0,
                                   self.frequency, unit="Hz", high_open=False)
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
def _velocity(record: LoopRecord) -> float:
    """Mean piston velocity over the settled periods of an open-loop run, [m/s]."""
    x = record.periods["position"]
    return float((x[-1] - x[IDENTIFY_SKIP]) / (len(x) - 1 - IDENTIFY_SKIP) * record.frequency)


def full_drive_velocity(settings: PositionSettings, direction: str, load: float,
                        fmu_path=None) -> float:
    """The steady piston velocity at full drive in ``direction`` under ``load`` [N], [m/s]:
    an open-loop run of :data:`IDENTIFY_PERIODS` periods, the first :data:`IDENTIFY_SKIP`
    discarded."""
    limit = settings.amplitude_limit
    rec = _loop(settings, fmu_path, IDENTIFY_PERIODS + 1,
                lambda k, t, x: Decision(direction, limit), load=lambda t: load)
    return _velocity(rec)


def identify(settings: PositionSettings, fmu_path=None) -> PlantModel:
    """Open-loop runs at :data:`IDENTIFY_FRACTIONS` of the limit in each direction, and
    at full drive with :data:`DROOP_LOAD` more load: the lines of :class:`PlantModel`.
    The full-drive runs and the droop's come first, so a direction that stalls is refused
    (:class:`OutsideEnvelope`) after half the runs; :func:`check_plant` then checks the
    lines."""
    limit = settings.amplitude_limit
    full, droops = {}, {}
    for direction in ("down", "up"):
        full[direction] = full_drive_velocity(settings, direction, settings.load_force,
                                              fmu_path)
        heavier = full_drive_velocity(settings, direction, settings.load_force + DROOP_LOAD,
                                      fmu_path)
        droops[direction] = (heavier - full[direction]) / DROOP_LOAD
    _check_stalls(settings, full["down"], full["up"], droops["down"], droops["up"])
    points, lines = [], {}
    for direction in ("down", "up"):
        v = []
        for frac in IDENTIFY_FRACTIONS:
            if frac == 1.0:
                v.append(full[direction])
            else:
                rec = _loop(settings, fmu_path, IDENTIFY_PERIODS + 1,
                            lambda k, t, x, d=direction, a=frac * limit: Decision(d, a))
                v.append(_velocity(rec))
            points.append((direction, frac, v[-1]))
        slope, offset = np.polyfit(IDENTIFY_FRACTIONS, v, 1)
        lines[direction] = (float(offset), float(slope))
    (v0d, gd), (v0u, gu) = lines["down"], lines["up"]
    model = PlantModel(frequency=settings.frequency, v0_down=v0d, g_down=gd, v0_up=v0u,
                       g_up=-gu, droop_down=droops["down"], droop_up=droops["up"],
                       points=tuple(points))
    check_plant(model, settings)
    return model


def _where(settings: PositionSettings) -> str:
    return (f"at {settings.frequency:g} Hz ({settings.mode}, {settings.circuit} circuit, "
            f"{settings.load_force:g} N)")


def _stall_load(v_full: float, droop: float, load: float) -> float:
    """The load at which a full-drive line v(F) = v_full + dv/dF (F - load) reaches zero
    velocity, [N]; NaN without a droop (more load: slower down, faster up)."""
    return load - v_full / droop if droop < 0.0 else math.nan


def _check_stalls(settings: PositionSettings, v_down: float, v_up: float, droop_down: float,
                  droop_up: float) -> None:
    """Raise :class:`OutsideEnvelope` when full drive [m/s] does not move the piston both
    ways, naming the stall loads of the lines through it with their droops [m/s/N]."""
    load = settings.load_force
    down, up = _stall_load(v_down, droop_down, load), _stall_load(v_up, droop_up, load)
    span = (f"the loads it moves both ways are from {up:.0f} to {down:.0f} N"
            if math.isfinite(up) and math.isfinite(down) and up < down
            else f"no load moves it both ways (down needs less than about {down:.0f} N, "
                 f"up more than about {up:.0f} N)")
    if v_down <= 0.0:
        raise OutsideEnvelope(
            f"{_where(settings)} the pump stalls moving down (full drive gives "
            f"{v_down * 1e3:+.2f} mm/s): the largest load it moves down is about "
            f"{down:.0f} N; the position loop needs both directions: {span}")
    if v_up >= 0.0:
        raise OutsideEnvelope(
            f"{_where(settings)} the pump cannot lift the piston (full drive up gives "
            f"{v_up * 1e3:+.2f} mm/s): it lifts only loads above about {up:.0f} N "
            f"(opposing down); the position loop needs both directions: {span}")


def check_plant(model: PlantModel, settings: PositionSettings) -> None:
    """Raise :class:`OutsideEnvelope` (one line: the physical limit and the valid range)
    when the identified lines cannot carry the loop: the pump running backwards (a
    line's gain not positive), or one direction stalled at full drive."""
    for direction, gain in (("down", model.g_down), ("up", model.g_up)):
        if gain <= 0.0:
            raise OutsideEnvelope(
                f"{_where(settings)} the pump runs backwards: more drive {direction} moves "
                f"the piston the other way ({gain * 1e3:+.2f} mm/s per unit amplitude; the "
                "rod lags the valves' switching at the drive's extremes by more than a "
                "quarter period, smeha flow marks it flow_reversed), so the design model "
                "cannot be identified; the position loop needs a lower frequency or the "
                "compensated drive")
    _check_stalls(settings, model.v_max_down, model.v_max_up, model.droop_down,
                  model.droop_up)


def check_load(settings: PositionSettings, limits: PumpLimits | None = None) -> PumpLimits:
    """Before any run: refuse (:class:`OutsideEnvelope`) a load far past the hand
    calculation's stall loads (:mod:`smeha.studies.positionlimits`, by more than
    :data:`HAND_MARGIN` of the stall pressure), and a pump with no free stroke; nearer the
    stall the identified lines decide (:func:`check_plant`). Returns the hand figures."""
    lim = limits or pump_limits(settings.frequency, settings.mode, settings.circuit)
    load = settings.load_force
    if lim.free_stroke <= 0.0:
        raise OutsideEnvelope(f"{_where(settings)} the free transducer strokes "
                              f"{lim.free_stroke * 1e6:.1f} um between the valve switches: "
                              "the pump delivers nothing")
    down, up = lim.stall_load_down, lim.stall_load_up
    how = (f"hand calculation: the blocked force K dy = {lim.blocked_force:.0f} N over A_d "
           f"limits the pump to {lim.stall_pressure / 1e6:.2f} MPa")
    span = f"the loads it moves both ways are from about {up:.0f} to {down:.0f} N"
    if load > down + HAND_MARGIN * lim.big_area * lim.stall_pressure:
        raise OutsideEnvelope(f"{_where(settings)} the pump stalls moving down: the largest "
                              f"load it moves down is about {down:.0f} N ({how}); the "
                              f"position loop needs both directions: {span}")
    if load < up - HAND_MARGIN * lim.small_area * lim.stall_pressure:
        raise OutsideEnvelope(f"{_where(settings)} the pump cannot lift the piston: it lifts "
                              f"only loads above about {up:.0f} N, opposing down ({how}); the "
                              f"position loop needs both directions: {span}")
    return lim


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


#: Why the coil current leaves the transducer model's operating point, per drive mode.
DESIGN_POINT_REASON = {
    "compensated": "a compensated small demand from the stroke's bottom is an offset current, "
                   "and a changing amplitude no sinusoid",
    "uncompensated": "a current amplitude that changes from period to period is no steady "
                     "sinusoid"}


def _flags(record: LoopRecord, circuit, mode: str) -> list:
    """End stops, cavitation, the design point, direction reversals: never silent."""
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
                   f"model follows the drive's frequency and amplitude, follow_drive, but "
                   f"{DESIGN_POINT_REASON[mode]})")
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
    after = rec.rows["time"] >= ctrl.start - TIME_TOLERANCE
    return rec, ctrl, after


def _velocities(record, start) -> np.ndarray:
    """Period-averaged piston velocities from ``start`` on, [m/s] (the flow table's flows
    are period means, so these compare with them)."""
    per = record.periods
    x = per["position"][per["time"] >= start - TIME_TOLERANCE]
    return np.diff(x) * record.frequency


def step_duration(settings: PositionSettings, model: PlantModel, gains: Design) -> float:
    """The step's simulated time, [s]: ``settings.duration``, else twice the predicted
    settling time, at least 0.3 s (where the prediction does not settle: four times the
    step at full speed), at most the option's limit."""
    if settings.duration is not None:
        return settings.duration
    settle = gains.predicted_settling_time_s
    if not math.isfinite(settle):
        speed = model.v_max_down if settings.target > 0.0 else -model.v_max_up
        settle = 2.0 * abs(settings.target) / speed
    return min(max(2.0 * settle, 0.3), options.DURATION.high)


def run_step(settings, model, gains, fmu_path=None) -> PositionResult:
    """A step of ``settings.target`` from rest: rise time (10-90 %), overshoot, settling
    time (2 %), the final error at the run's end, the largest period-averaged speed. A
    step that does not settle within the run says so in its flags."""
    duration = step_duration(settings, model, gains)
    rec, ctrl, after = _run(settings, model, gains, lambda t: settings.target, duration,
                            fmu_path)
    t, x = rec.rows["time"][after] - ctrl.start, rec.rows["piston_position"][after]
    m = step_metrics(t, x, settings.target)
    v = _velocities(rec, ctrl.start)
    m.update(max_velocity_m_s=float(np.max(np.abs(v))) if v.size else 0.0,
             predicted_rise_time_s=gains.predicted_rise_time_s,
             predicted_settling_time_s=gains.predicted_settling_time_s,
             wall_s=rec.wall_s, cpu_s=rec.cpu_s, simulated_s=float(rec.rows["time"][-1]),
             saturated_periods=int(rec.periods["saturated"].sum()), duration_s=duration)
    flags = _flags(rec, presets.circuit(settings.circuit), settings.mode)
    if not m["settled"]:
        flags.insert(0, f"not settled within the duration ({duration:g} s): "
                        f"{m['final_error_m'] * 1e6:.1f} um from the command at the end "
                        "(a longer --duration shows the rest)")
    return PositionResult("step", settings.mode, m, flags, rec)


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
        flags += [f for f in _flags(rec, presets.circuit(settings.circuit), settings.mode)
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
                            load=lambda t: base + (extra if t >= at - TIME_TOLERANCE else 0.0))
    t, x = rec.rows["time"], rec.rows["piston_position"] - ctrl.origin
    late = t >= at - TIME_TOLERANCE
    dev = x[late]
    peak = float(dev[np.argmax(np.abs(dev))])
    out = np.flatnonzero(np.abs(dev) > 0.1 * abs(peak))
    if out.size and out[-1] == dev.size - 1:
        recovery = math.nan  # not back within the run
    else:
        recovery = float(t[late][out[-1]] - at) if out.size else 0.0
    figures = {"load_step_N": extra, "load_step_at_s": at, "origin_m": ctrl.origin,
               "peak_deflection_m": peak,
               "predicted_peak_deflection_m": -math.copysign(
                   gains.predicted_load_peak_m_per_N * abs(extra), extra),
               "stiffness_N_per_m": float(abs(extra / peak)) if peak else math.inf,
               "recovery_time_s": recovery, "final_error_m": float(abs(x[-1])),
               "wall_s": rec.wall_s, "simulated_s": float(t[-1])}
    flags = _flags(rec, presets.circuit(settings.circuit), settings.mode)
    tail = rec.periods["saturated"][-max(len(rec.periods) // 5, 1):]
    if tail.all():
        flags.append(f"the drive is at its limit after the load step: {base + extra:g} N is "
                     "about all the pump holds at this frequency and mode (its load line's "
                     "stall), so the position is not recovered")
    return PositionResult("load", settings.mode, figures, flags, rec)


def run_study(settings: PositionSettings, scenarios=("step",), sine_frequencies=None,
              fmu_path=None, on_design=None) -> dict:
    """Check the load against the hand calculation, identify, design, then run each
    scenario; returns {"limits", "model", "design", "results"}. ``on_design``, if given,
    is called with the estimated wall time of the rest [s] before the scenarios run."""
    limits = check_load(settings)
    model = identify(settings, fmu_path)
    gains = design(model, settings.target, settings.controller_periods)
    if on_design is not None:
        on_design(estimate_wall_time(settings, scenarios, limits, gains, model))
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
    return {"limits": limits, "model": model, "design": gains, "results": results}


#: Wall time per simulated second of a closed-loop or open-loop run through the FMU, [s]
#: (benchmarks/position_realtime.py: 0.75-1.5 on the 2-core machine, the larger figure
#: taken so the estimate errs long).
WALL_PER_SIMULATED = 1.5


def estimate_wall_time(settings: PositionSettings, scenarios=("step",),
                       limits: PumpLimits | None = None, gains: Design | None = None,
                       model: PlantModel | None = None) -> float:
    """A rough wall time, [s], of what is left of :func:`run_study` plus the flow table's
    run, times :data:`WALL_PER_SIMULATED`. Before the design (``gains`` None): the
    identification (8 runs), the flow table's run and, when the hand calculation moves the
    load both ways, each scenario with the step at its full speed (nearer a stall the
    identification decides, and most such runs are refused). After it: the scenarios,
    the step lasting :func:`step_duration`."""
    period = 1.0 / settings.frequency
    if gains is not None:
        step = step_duration(settings, model, gains)
        return (_scenarios_time(settings, scenarios, step) + DEFAULT_CYCLES * period) \
            * WALL_PER_SIMULATED
    lim = limits or pump_limits(settings.frequency, settings.mode, settings.circuit)
    simulated = identification_time(settings) / WALL_PER_SIMULATED
    direction = "down" if settings.target > 0.0 else "up"
    speed = abs(lim.velocity(settings.load_force, direction))
    if lim.stall_load_up < settings.load_force < lim.stall_load_down and speed > 0.0:
        step = settings.duration or min(max(4.0 * abs(settings.target) / speed, 0.3),
                                        options.DURATION.high)
        simulated += _scenarios_time(settings, scenarios, step) + DEFAULT_CYCLES * period
    return simulated * WALL_PER_SIMULATED


def identification_time(settings: PositionSettings) -> float:
    """The identification's wall time alone, [s] (8 runs; :data:`WALL_PER_SIMULATED`)."""
    return (2 * (len(IDENTIFY_FRACTIONS) + 1) * (IDENTIFY_PERIODS + 1) / settings.frequency
            * WALL_PER_SIMULATED)


def _scenarios_time(settings, scenarios, step) -> float:
    """Simulated time of the scenarios, [s]: the step, six sines around the bandwidth
    (~0.07 f, the design's), the load step."""
    period = 1.0 / settings.frequency
    simulated = step + SETTLE_PERIODS * period
    if "sine" in scenarios:
        simulated += sum(max(4.0 / (0.068 * settings.frequency * r), 0.3) + SETTLE_PERIODS
                         * period for r in (0.25, 0.5, 0.71, 1.0, 1.41, 2.0))
    if "load" in scenarios:
        simulated += (settings.duration or 0.5) + SETTLE_PERIODS * period
    return simulated


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
    return row["flow_sim_m3_s"] / presets.circuit(settings.circuit).cylinder.big_area

