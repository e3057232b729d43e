"""The flow study: the EHA's cylinder flow by co-simulation against eqs 40/41.

Each case runs the transducer FMU (or, for comparison, gmt in-process) with
the hydraulic circuit (:mod:`system_models`) and checks the mean cylinder flow
against f A_d dy (:mod:`system_models.flowcheck`).

Control signals: uncompensated, u = (I_m / K_a) cos(2 pi f t), so the coil
current is i = I_m cos(2 pi f t) and the valves switch at i = -+I_m (eq 40);
compensated, u = a + a cos(2 pi f t), the valves switch at u = 0 and u = 2a
(eq 41), with a the paper's control amplitudes (stated next to its Figure 10:
2.2, 1.9, 1.7, 1.5 V at 50, 70, 80, 100 Hz, ``data/paper_table3.csv``;
interpolated linearly between) or, outside 50-100 Hz, 95 % of the half-stroke
the transducer reaches at that frequency.

Model variants: a case with ``variant`` (a :class:`gmt.ModelVariant`, e.g. the
extension ``smeha diagnose`` names) runs the transducer with that extension
added -- through the FMU's ``model_variant`` and ``variant_parameters``, or
``gmt.Transducer(variant=...)`` in-process -- so the flow with the paper's
model and with the extended model can be compared
(:func:`smeha.studies.flowtables.format_comparison`, ``smeha flow --variant FILE``).
The compensator stays the paper's inverse
model in both.

Results a reader could misread are flagged (:func:`flag_row`), in the table,
the JSON and the plot: a reversed flow (the uncompensated pump above ~120 Hz:
the rod lags the valve timing by more than a quarter period) carries
``flow_reversed``, and oil held in tension (a pressure in the pump chamber or a
cavity below :data:`~system_models.fluid.MINIMUM_PRESSURE`, 1 kPa absolute,
where a real oil cavitates; the ``differential`` preset's air-free stiff oil
does it) carries ``cavitation``; each with a ``note`` giving the reason.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, fields
from functools import lru_cache
from pathlib import Path

import numpy as np

import gmt
from gmt.parameters import BRANCH_RULE, COMPENSATOR_PERIOD
from system_models import presets
from system_models.controller import dead_times
from system_models.cosim import (CosimSettings, DirectTransducer, FmuTransducer,
                                 cosimulate, volume_balance)
from system_models.defaults import (DEFAULT_COUPLING, DEFAULT_CYCLES, DEFAULT_STEP,
                                    HYDRAULIC_STEP, VALVE_CONTROLLER_PERIOD)
from system_models.flowcheck import flow_check
from system_models.fluid import MINIMUM_PRESSURE

from .. import paperdata
from . import flowsettings as fs
from .flowrow import FlowRow

__all__ = ["MODES", "CIRCUITS", "CURRENT_AMPLITUDE", "paper_control_amplitudes", "paper_dy",
           "operating_current",
           "control_amplitude", "Sinusoid", "control_signal", "Case", "variant_start_values",
           "default_fmu_path", "ensure_fmu", "FREE_SAMPLES_PER_CYCLE", "free_dy", "SETTLED_DRIFT",
           "settled",
           "rod_lag_degrees", "WATCHED_PRESSURES", "lowest_pressure", "flag_row", "run_case",
           "run_cases", "compare_variant", "FlowRow"]

MODES = ("uncompensated", "compensated")
#: The named circuits (system_models.presets).
CIRCUITS = tuple(presets.CIRCUITS)

#: Current amplitude I_m of the study, [A] (the paper's 1 A).
CURRENT_AMPLITUDE = 1.0


@lru_cache(maxsize=1)
def _table3():
    return paperdata.table3()


def paper_control_amplitudes() -> dict:
    """Paper (text next to Figure 10, ``data/paper_table3.csv``): f [Hz] -> a [V]."""
    t3 = _table3()
    return {float(f): float(a) for f, a in zip(t3["frequency"], t3["control_amplitude"])}


def paper_dy(frequency: float, mode: str) -> float | None:
    """Paper, Table 3: dy [m] between the valve switching instants, or None off its rows.

    Uncompensated y(i = 1) - y(i = -1) (eq 40), compensated y(u = u_m) - y(u = 0) (eq 41).
    """
    t3 = _table3()
    rows = np.flatnonzero(t3["frequency"] == float(frequency))
    if not rows.size:
        return None
    k = rows[0]
    if mode == "uncompensated":
        return float(t3["displacement_at_current_max"][k] - t3["displacement_at_current_min"][k])
    return float(t3["displacement_at_control_max"][k] - t3["displacement_at_control_zero"][k])


def control_amplitude(frequency: float, params: gmt.TransducerParameters | None = None,
                      drive: gmt.DriveParameters | None = None) -> float:
    """a [V] of the compensated control signal u = a + a cos(2 pi f t) (module docstring)."""
    f = float(frequency)
    table = sorted(paper_control_amplitudes().items())
    if table[0][0] <= f <= table[-1][0]:
        fs, amps = zip(*table)
        return float(np.interp(f, fs, amps))
    params = params or gmt.TransducerParameters()
    drive = drive or gmt.DriveParameters()
    point = gmt.operating_point(params, gmt.Excitation(f, CURRENT_AMPLITUDE))
    low, high = gmt.inverse.stroke(params, point)
    return 0.95 * (high - low) / (2.0 * drive.displacement_per_volt)


class Sinusoid:
    """u(t) = offset + amplitude cos(2 pi f t), [V]: a float for a float t, an array for an array.

    The valve controller samples u in blocks (vectorised); the master calls it
    one instant at a time (plain floats).
    """

    def __init__(self, offset: float, amplitude: float, frequency: float):
        self.offset, self.amplitude = float(offset), float(amplitude)
        self.angular_frequency = 2.0 * math.pi * float(frequency)

    def __call__(self, t):
        if isinstance(t, np.ndarray):
            return self.offset + self.amplitude * np.cos(self.angular_frequency * t)
        return self.offset + self.amplitude * math.cos(self.angular_frequency * t)


def control_signal(mode: str, frequency: float, amplitude: float | None = None,
                   waveform: str = "sine"):
    """u(t) [V] for a mode; returns (u, a or None).

    ``amplitude`` a [V]: uncompensated u = a s(f t) (default I_m / K_a), compensated
    u = a + a s(f t) (default :func:`control_amplitude`); s the ``waveform``'s shape
    (:mod:`smeha.studies.waveforms`; a :class:`Sinusoid` for the paper's ``"sine"``).
    """
    from .waveforms import Waveform
    if mode == "uncompensated":
        a = CURRENT_AMPLITUDE if amplitude is None else amplitude
        if waveform == "sine":
            return Sinusoid(0.0, a, frequency), amplitude
        return Waveform(0.0, a, frequency, waveform), amplitude
    if mode == "compensated":
        a = control_amplitude(frequency) if amplitude is None else amplitude
        if waveform == "sine":
            return Sinusoid(a, a, frequency), a
        return Waveform(a, a, frequency, waveform), a
    raise gmt.ParameterError(f"mode = {mode!r} is not one of {MODES}")


@dataclass(frozen=True)
class Case:
    """One co-simulation of the study (defaults: the package's, defined once each)."""

    frequency: float
    mode: str
    circuit: str = "realistic"  # a name of system_models.presets.CIRCUITS
    load: float | None = None  # [N]; None: the circuit's (presets.default_load)
    step: float = DEFAULT_STEP  # communication step [s]
    cycles: float = DEFAULT_CYCLES  # simulated time in pumping cycles
    backend: str = "fmu"  # "fmu" or "direct"
    branch_rule: str = BRANCH_RULE
    variant: gmt.ModelVariant | None = None  # None: the paper's model
    coupling: str = DEFAULT_COUPLING  # system_models.cosim.COUPLINGS
    #: the valve controller's sample period [s] (CosimSettings.controller_period)
    controller_period: float = VALVE_CONTROLLER_PERIOD
    #: longest hydraulic substep [s] (CosimSettings.hydraulic_step); None: the step
    hydraulic_step: float | None = HYDRAULIC_STEP
    #: the digital compensator's sample period [s] (gmt.DriveParameters.compensator_period)
    compensator_period: float = COMPENSATOR_PERIOD
    #: the transducer's magnetics (gmt.transducer.MAGNETICS): the paper's or the time domain's
    magnetics: str = "paper"
    #: the model the compensator inverts; None: that of ``magnetics``
    inverse: str | None = None
    #: the control signal's shape (smeha.studies.waveforms.WAVEFORMS)
    waveform: str = "sine"
    #: the control signal's amplitude a [V] (control_signal); None: the study's default
    amplitude: float | None = None

    def __post_init__(self):
        if self.variant is not None:
            if not isinstance(self.variant, gmt.ModelVariant):
                raise gmt.ParameterError(
                    f"variant = {self.variant!r} must be a gmt.ModelVariant or None")
            if self.variant.is_paper:  # one spelling of the paper's model
                object.__setattr__(self, "variant", None)
        # the ranges the command line shows and checks (one declaration each)
        fs.FREQUENCY.check(self.frequency)
        fs.CYCLES.check(self.cycles)
        if self.mode not in MODES:
            raise gmt.ParameterError(f"mode = {self.mode!r} is not one of {MODES}")
        if self.circuit not in CIRCUITS:
            raise gmt.ParameterError(f"circuit = {self.circuit!r} is not one of {CIRCUITS}")
        if self.backend not in ("fmu", "direct"):
            raise gmt.ParameterError(
                f"backend = {self.backend!r} is not one of ('fmu', 'direct')")
        if self.load is not None:
            fs.LOAD.check(self.load)
        from gmt.transducer import MAGNETICS

        from .waveforms import WAVEFORMS
        if self.magnetics not in MAGNETICS:
            raise gmt.ParameterError(f"magnetics = {self.magnetics!r} is not one of {MAGNETICS}")
        if self.inverse is not None and self.inverse not in MAGNETICS:
            raise gmt.ParameterError(f"inverse = {self.inverse!r} is not one of {MAGNETICS}")
        if self.waveform not in WAVEFORMS:
            raise gmt.ParameterError(f"waveform = {self.waveform!r} is not one of {WAVEFORMS}")
        if self.amplitude is not None:
            fs.AMPLITUDE.check(self.amplitude)
        # the co-simulation's and the drive's settings, checked once, by their own classes
        # (step, coupling, controller_period, hydraulic_step, duration; compensator_period,
        # branch_rule), before any run
        self.cosim_settings()
        self.drive()

    def cosim_settings(self) -> CosimSettings:
        """The co-simulation's settings of this case (the one place they are checked)."""
        return CosimSettings(duration=self.cycles / self.frequency, step=self.step,
                             coupling=self.coupling, load_force=self.load_force,
                             controller_period=self.controller_period,
                             hydraulic_step=self.hydraulic_step)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @property
    def ideal(self) -> bool:
        return self.circuit == "ideal"

    @property
    def load_force(self) -> float:
        if self.load is not None:
            return float(self.load)
        return presets.default_load(self.circuit)

    @property
    def model(self) -> str:
        """"paper", or the variant's name (its cause, gmt.VARIANTS)."""
        return "paper" if self.variant is None else self.variant.name

    @property
    def current_amplitude(self) -> float:
        """I_m of the model's operating point, [A] (:func:`operating_current`)."""
        return operating_current(self.mode, self.amplitude, self.magnetics, self.waveform)

    def held_force_mechanics(self):
        """The rod's :class:`gmt.RodMechanics` where the plant takes the transducer's force
        linear over a step while the transducer holds it (a continuous drive:
        system_models.forceport), for :func:`smeha.studies.simmeasure.hold_correction`;
        None where both hold it (the digital compensator's current, the paper's
        magnetics)."""
        if self.mode == "compensated" and self.magnetics == "paper":
            return None
        return gmt.Transducer(excitation=gmt.Excitation(self.frequency, self.current_amplitude),
                              variant=self.variant).rod_mechanics()

    def drive(self) -> gmt.DriveParameters:
        return gmt.DriveParameters(compensated=self.mode == "compensated",
                                   branch_rule=self.branch_rule,
                                   compensator_period=self.compensator_period)

    def fmu_start_values(self) -> dict:
        """The transducer FMU's parameter values of this case (those that differ from its
        start values may be among them)."""
        drive = self.drive()
        values = {"frequency": self.frequency, "current_amplitude": self.current_amplitude,
                  "compensated": drive.compensated, "branch_rule": drive.branch_rule,
                  "compensator_period": drive.compensator_period,
                  **variant_start_values(self.variant)}
        if self.magnetics != "paper":
            values["magnetics"] = self.magnetics
        if self.inverse is not None:
            values["inverse_model"] = self.inverse
        return values


def operating_current(mode: str, amplitude: float | None, magnetics: str = "paper",
                      waveform: str = "sine") -> float:
    """I_m of the paper model's operating point (eqs 16-20 at the drive's f and I_m), [A]:
    the drive's own, K_a a, for a sinusoidal current of amplitude a (uncompensated, the
    paper's magnetics); otherwise the study's :data:`CURRENT_AMPLITUDE` (the compensated
    current is the compensator's; another waveform or the time-domain magnetics has no
    operating point of its own)."""
    if (mode == "uncompensated" and amplitude is not None and magnetics == "paper"
            and waveform == "sine"):
        return gmt.DriveParameters().amplifier_gain * amplitude
    return CURRENT_AMPLITUDE


def variant_start_values(variant: gmt.ModelVariant | None) -> dict:
    """The FMU's ``model_variant`` and ``variant_parameters`` for a variant ({} for the paper)."""
    if variant is None or variant.is_paper:
        return {}
    return {"model_variant": variant.name,
            "variant_parameters": json.dumps(variant.as_dict()["parameters"])}


def default_fmu_path() -> Path:
    """dist/SmehaGmt.fmu of the source tree (:data:`smeha.fmu.build.DIST`)."""
    from ..fmu import build as fmu_build
    return fmu_build.DIST / "SmehaGmt.fmu"


def ensure_fmu(path: Path | None = None, quiet: bool = False, say=None) -> Path:
    """Build the FMI 2.0 FMU unless it exists and is newer than its sources.

    ``say``, if given, is told before a build starts (it takes a minute or more); the
    library prints nothing itself. ``quiet`` silences ``say``."""
    from ..fmu import build as fmu_build
    path = Path(path) if path else default_fmu_path()
    sources = list((fmu_build.FMU_SRC).rglob("*.py")) + [Path(fmu_build.__file__)]
    newest = max(p.stat().st_mtime for p in sources)
    if path.is_file() and path.stat().st_mtime >= newest:
        return path
    if say is not None and not quiet:
        say(f"building the transducer FMU into {path.parent} ...")
    return fmu_build.build("2", out=path.parent)


#: Free runs, time-stepped: samples a cycle.
FREE_SAMPLES_PER_CYCLE = 1000


@lru_cache(maxsize=64)
def free_dy(frequency: float, mode: str, branch_rule: str = BRANCH_RULE,
            variant: gmt.ModelVariant | None = None,
            compensator_period: float = COMPENSATOR_PERIOD,
            cycles: float = DEFAULT_CYCLES, magnetics: str = "paper",
            inverse: str | None = None, waveform: str = "sine",
            amplitude: float | None = None) -> float:
    """dy of the transducer alone (no oil, no force) between the same instants, [m].

    Cached: a load line or a sweep asks for it once per case at the same
    frequency and mode.

    Uncompensated, the paper's model: y(i = I_m) - y(i = -I_m) of eq 30's
    periodic solution (closed form, eq 40). Otherwise (the compensated drive
    with its sample period, eq 41, or a model variant) the transducer is
    time-stepped alone (:data:`FREE_SAMPLES_PER_CYCLE` samples a cycle, or the step
    that divides the compensator's period T_c below that: a step longer than T_c, or
    one T_c does not divide, would hand the compensator a u held from an earlier
    instant, a staircase it differentiates, eq 34) for
    ``cycles`` cycles and dy is the mean stroke from each minimum of u to the
    next maximum over the compression windows the flow check of such a run
    averages (:mod:`system_models.flowcheck`): a compensator sampling at a
    rate the pump frequency does not divide (10 kHz against 70 Hz) samples
    each cycle at other phases, and a drifting variant has no steady state.
    The time-domain magnetics, another waveform or amplitude are time-stepped too;
    a waveform's window is the valve controller's
    (:func:`smeha.studies.waveforms.compression_window`).
    """
    from system_models.flowcheck import SKIP_CYCLES

    from .waveforms import compression_window
    params = gmt.TransducerParameters()
    if (mode == "uncompensated" and (variant is None or variant.is_paper)
            and magnetics == "paper" and waveform == "sine" and amplitude is None):
        point = gmt.operating_point(params, gmt.Excitation(frequency, CURRENT_AMPLITUDE))
        return gmt.loop_metrics(params, point)["dy"]
    drive = gmt.DriveParameters(compensated=mode == "compensated", branch_rule=branch_rule,
                                compensator_period=compensator_period)
    im = operating_current(mode, amplitude, magnetics, waveform)
    unit = gmt.Transducer(params, gmt.Excitation(frequency, im), drive,
                          variant=variant, magnetics=magnetics, inverse=inverse)
    control, _ = control_signal(mode, frequency, amplitude, waveform)
    h = 1.0 / (frequency * FREE_SAMPLES_PER_CYCLE)
    period = unit.sample_period
    if period > 0.0:  # a step that divides T_c: every sample sees u at its own instant
        h = period / math.ceil(period / h - 1e-9)
    start, end = compression_window(waveform)
    whole = max(int(cycles), SKIP_CYCLES + 2)
    n = int(math.ceil((whole + end - 1.0) / (frequency * h)))
    y = np.empty(n + 1)
    y[0] = unit.forward.displacement
    # the time-domain magnetics driven continuously hold u at each step's middle, as the
    # force port does (system_models.forceport): a held u(t_k) would lag by half a step
    mid = 0.5 if magnetics == "time_domain" and mode == "uncompensated" else 0.0
    for k in range(n):
        y[k + 1] = unit.step(control((k + mid) * h), h).displacement
    # compression window k runs from (k + start) T to (k + end) T (the samples nearest those
    # instants); for the paper's cosine from its minimum, (k + 1/2) T, to its maximum
    k = np.arange(SKIP_CYCLES, whole - 1)
    lows = np.rint((k + start) / (frequency * h)).astype(int)
    highs = np.rint((k + end) / (frequency * h)).astype(int)
    return float(np.mean(y[highs] - y[lows]))


def rod_lag_degrees(time, control, rod, frequency: float) -> float:
    """Phase lag of the rod's fundamental behind the control signal's, [deg], in (-180, 180]."""
    w = 2.0 * math.pi * frequency
    phasor = [np.sum(np.asarray(x) * np.exp(-1j * w * np.asarray(time))) for x in (control, rod)]
    return float(np.degrees(np.angle(phasor[0] / phasor[1])))


#: The volumes whose pressure :func:`lowest_pressure` watches (record field -> name): the
#: accumulator is left out, its gas charge keeps it far above.
WATCHED_PRESSURES = {"p_pump": "pump chamber", "p_big": "big cavity", "p_small": "small cavity"}


def lowest_pressure(record) -> tuple[float, str]:
    """The lowest absolute pressure of the run in the pump chamber and the cylinder's
    cavities, [Pa], and the volume's name (:data:`WATCHED_PRESSURES`)."""
    return min((float(np.min(record[field])), name) for field, name in WATCHED_PRESSURES.items())


def flag_row(row: dict, rod_lag_deg: float | None = None, dead_time: float = 0.0) -> dict:
    """Add ``flow_reversed`` and ``cavitation`` and, when either holds, a ``note`` with the
    reason (in place).

    Two reasons a flow runs backwards. The valves switch at the control
    signal's extremes (after their dead time) and eqs 40/41 count the rod's
    stroke between those instants: when the rod lags that timing by more than
    a quarter period (the uncompensated pump above ~120 Hz: the transducer's
    lag, eq 29 and mu'', grows with f, and the chamber's load adds to it), it
    travels backwards between the switches, dy < 0, and the pump draws from
    the cylinder it should fill. Or the stroke is forward (dy > 0) but the load
    needs a pressure above what the pump holds: the load drives the cylinder
    back (a load line past its stall point).

    Cavitation: with ``p_min_Pa`` (:func:`lowest_pressure`) below
    :data:`~system_models.fluid.MINIMUM_PRESSURE` (1 kPa absolute) the model's
    oil has held a pressure, possibly a tension, that no oil holds: a liquid
    cannot fall below its vapour pressure, and air dissolved in a mineral oil
    comes out of solution well above it, so a real oil would fill that volume
    with vapour and air (cavitate; Merritt, *Hydraulic Control Systems*, 1967,
    ch. 2). The co-simulation does not model that: its flow assumes the
    tension.
    """
    notes = []
    reversed_ = row["flow_sim_m3_s"] < 0.0
    row["flow_reversed"] = bool(reversed_)
    p_min = row.get("p_min_Pa")
    row["cavitation"] = p_min is not None and p_min < MINIMUM_PRESSURE
    if reversed_:
        notes.append(_reversed_note(row, rod_lag_deg, dead_time))
    if row["cavitation"]:
        notes.append(f"cavitation: the {row.get('p_min_volume', 'oil')}'s pressure falls to "
                     f"{p_min / 1e6:.2f} MPa absolute, below the {MINIMUM_PRESSURE / 1e3:g} kPa "
                     f"no oil holds: a real oil would cavitate there (vapour and released air), "
                     f"which this co-simulation does not model; its flow assumes the tension")
    if notes:
        row["note"] = "; ".join(notes)
    return row


def _reversed_note(row, rod_lag_deg, dead_time) -> str:
    """Why a row's flow runs backwards (:func:`flag_row`): the rod's lag past a quarter
    period after the valves' timing, or else the load past the stall point (which can
    drive the rod back between the switches too, dy < 0)."""
    timing = dead_time * row["frequency_Hz"] * 360.0
    lagging = rod_lag_deg is not None and abs(rod_lag_deg) + timing > 90.0
    if row["dy_um"] < 0.0 and (lagging or rod_lag_deg is None):
        lag = "" if rod_lag_deg is None else (
            f": the rod lags the control signal by {rod_lag_deg:.0f} deg")
        return (f"flow reversed{lag}, the valves act {timing:.0f} deg after its "
                f"extremes (dead time): past a quarter period the rod moves backwards "
                f"between the valve switches (dy {row['dy_um']:.1f} um < 0), so the "
                f"pump empties the big cavity instead of filling it")
    back = (" and pushes the rod back between the valve switches" if row["dy_um"] < 0.0
            else "")
    lag = "" if rod_lag_deg is None else (
        f"; the rod's lag ({abs(rod_lag_deg):.0f} deg, {timing:.0f} deg of valve dead time) "
        "is within a quarter period")
    return (f"flow reversed: the load needs p_B - p_S = "
            f"{row['load_pressure_Pa'] / 1e6:.2f} MPa, more than the pump holds "
            f"at this stroke (dy {row['dy_um']:.1f} um): the load drives the "
            f"cylinder back{back} (past the stall point of its load line){lag}")


#: The study's figures are printed to about 1e-3 of themselves (ratios with three decimals,
#: flows with four significant digits). One cycle more moves a mean over cycles whose flows
#: trend by ``drift`` a cycle by about ``drift / 2`` of itself, so a run counts as settled
#: when that stays within half a unit of those digits: ``|drift| <= 1e-3``. The realistic
#: circuit's flow trends by 2-5e-4 a cycle for as long as the piston travels (its cavities'
#: volumes and the accumulator's charge follow it), at 8 cycles as at 40, and its flow
#: ratios to eqs 40/41 agree to the third decimal between those lengths
#: (tests/test_study_fixes.py).
SETTLED_DRIFT = 1e-3


def settled(drift: float) -> bool:
    """Whether the cycles' flows' trend, [1/cycle], leaves the printed figures unchanged by a
    longer run (:data:`SETTLED_DRIFT`)."""
    return abs(drift) <= SETTLED_DRIFT


def run_case(case: Case, fmu_path: Path | None = None, progress=None):
    """Run one case; return (record, FlowCheck, :class:`~smeha.studies.flowrow.FlowRow`)."""
    params = gmt.TransducerParameters()
    drive = case.drive()
    control, a = control_signal(case.mode, case.frequency, case.amplitude, case.waveform)
    circuit = presets.circuit(case.circuit)
    settings = case.cosim_settings()
    if case.backend == "fmu":
        backend = FmuTransducer(fmu_path or default_fmu_path(), case.fmu_start_values())
    else:
        backend = DirectTransducer(params, gmt.Excitation(case.frequency, case.current_amplitude),
                                   drive, case.variant, magnetics=case.magnetics,
                                   inverse=case.inverse)
    wall = time.perf_counter()
    try:
        record = cosimulate(backend, control, circuit, settings, progress=progress)
    finally:
        backend.close()
    wall = time.perf_counter() - wall
    check = flow_check(record, case.frequency, circuit.chamber.piston_area)
    imbalance, pumped = volume_balance(record, circuit)
    half = len(record) // 2
    # Table 3 was measured with the paper's sinusoidal drives only
    paper = (paper_dy(case.frequency, case.mode)
             if case.waveform == "sine" and case.amplitude is None else None)
    area = circuit.chamber.piston_area
    p_min, p_min_volume = lowest_pressure(record)
    dy_free = free_dy(case.frequency, case.mode, case.branch_rule, case.variant,
                      case.compensator_period, case.cycles, case.magnetics, case.inverse,
                      case.waveform, case.amplitude)
    row = {
        "frequency_Hz": case.frequency, "mode": case.mode, "model": case.model,
        "circuit": case.circuit, "load_N": case.load_force,
        "flow_sim_m3_s": check.flow_sim, "flow_eq_m3_s": check.flow_eq,
        "flow_ratio": check.ratio, "dy_um": check.dy * 1e6,
        "flow_sim_L_min": check.flow_sim * 6e4,
        "flow_paper_m3_s": None if paper is None else case.frequency * area * paper,
        "dy_paper_um": None if paper is None else paper * 1e6,
        "dy_free_um": dy_free * 1e6,
        "flow_free_m3_s": case.frequency * area * dy_free,
        "delivered_fraction": check.flow_sim / (case.frequency * area * dy_free),
        "control_amplitude_V": a,
        "load_pressure_Pa": float(np.mean(record["p_big"][half:] - record["p_small"][half:])),
        "p_pump_min_Pa": float(record["p_pump"][half:].min()),
        "p_pump_max_Pa": float(record["p_pump"][half:].max()),
        "p_min_Pa": p_min, "p_min_volume": p_min_volume,
        "volume_imbalance_m3": imbalance, "volume_pumped_m3": pumped,
        "cycles_averaged": check.cycles, "flow_drift_per_cycle": check.drift,
        "settled": settled(check.drift), "step_s": case.step, "coupling": case.coupling,
        "backend": case.backend, "wall_s": wall,
        "magnetics": case.magnetics, "waveform": case.waveform,
    }
    window = slice(half, None)
    lag = rod_lag_degrees(record["time"][window], record["control"][window],
                          record["rod_displacement"][window], case.frequency)
    flag_row(row, lag, max(dead_times(circuit.valves)))
    return record, check, FlowRow(**row)


def _run_one(case, fmu_path):
    return run_case(case, fmu_path)[2]


def run_cases(cases, fmu_path=None, workers: int = 1, quiet: bool = False,
              say=None) -> list[dict]:
    """Run many cases (in worker processes when ``workers`` > 1, :mod:`smeha.pool`), with a
    progress bar on stderr unless ``quiet``; rows in the order of ``cases``. ``say``, if
    given, is told of a long preparation (the kernel's first compilation)."""
    from .. import pool
    pool.prepare(workers, (fmu_path or default_fmu_path())
                 if any(c.backend == "fmu" for c in cases) else None,
                 None if quiet else say)
    return pool.run_jobs(_run_one, [(c, fmu_path) for c in cases], workers,
                         desc="co-simulations", unit="run", quiet=quiet)


def compare_variant(rows) -> list[dict]:
    """Pair each variant row with the paper row of the same case (frequency, mode, circuit, load).

    Returns
    -------
    list of dict
        ``frequency_Hz``, ``mode``, ``circuit``, ``load_N``, ``model`` (the
        variant's cause), ``flow_paper_model_m3_s``, ``flow_variant_m3_s``,
        ``flow_ratio_variant_to_paper``, ``dy_paper_model_um``, ``dy_variant_um``,
        ``dy_free_paper_model_um``, ``dy_free_variant_um``, in the order of the
        variant rows; and the variant row's ``variant_marks`` (the reasons
        :func:`smeha.studies.variantcheck.mark_rows` gives, [] when unmarked or
        unchecked), ``variant_note``, and ``note`` (:func:`flag_row`) when it has them.
    """
    def key(r):
        return (r["frequency_Hz"], r["mode"], r["circuit"], r["load_N"])

    paper = {key(r): r for r in rows if r.get("model", "paper") == "paper"}
    out = []
    for r in rows:
        if r.get("model", "paper") == "paper" or key(r) not in paper:
            continue
        p = paper[key(r)]
        out.append({"frequency_Hz": r["frequency_Hz"], "mode": r["mode"],
                    "circuit": r["circuit"], "load_N": r["load_N"], "model": r["model"],
                    "flow_paper_model_m3_s": p["flow_sim_m3_s"],
                    "flow_variant_m3_s": r["flow_sim_m3_s"],
                    "flow_ratio_variant_to_paper": (r["flow_sim_m3_s"] / p["flow_sim_m3_s"]
                                                    if p["flow_sim_m3_s"] else None),
                    "dy_paper_model_um": p["dy_um"], "dy_variant_um": r["dy_um"],
                    "dy_free_paper_model_um": p["dy_free_um"],
                    "dy_free_variant_um": r["dy_free_um"],
                    "variant_marks": list(r.get("variant_marks") or []),
                    **{k: r[k] for k in ("variant_note", "note") if r.get(k)}})
    return out
