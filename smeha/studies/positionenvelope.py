"""The EHA's speed-load envelope (``smeha position --envelope``): the datasheet curve.

At each load the pump runs open loop at full drive in each direction (the same
co-simulation the position study identifies its lines from,
:func:`smeha.studies.position.full_drive_velocity`), and the steady piston velocity is the
period mean after the chamber's first fill. The stall loads are where the velocity each
way crosses zero, interpolated linearly between the loads that bracket it (the velocity
is linear in the load, :mod:`smeha.studies.positionlimits`). Beside them: the hand
calculation's line and stall loads (the pump cycle with the piston's swing,
:mod:`smeha.studies.pumpcycle`), its quasi-static stall loads, and the flow table's point
(``smeha flow``, direction down: its flow over the big cavity's area).

The stall loads are judged in pressure against the pump's pressure limit p_lim = A_d Y / C
(the rod's whole free stroke against the chamber's compliance): a stall load agrees when it
is within :data:`AGREEMENT` p_lim A_L of the hand's (A_L the loaded cavity's area). The
stall pressure itself is a small difference where the rod lags the valves (uncompensated,
200 Hz: 0.03 MPa of 0.45), so a fraction of it would ask for a fraction of a newton.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

import gmt

from .positionlimits import PumpLimits, pump_limits

__all__ = ["EnvelopePoint", "Envelope", "envelope_loads", "run_envelope", "format_envelope",
           "estimate_wall_time", "LOADS", "AGREEMENT", "tolerance"]

#: Wall time a run costs besides its simulated time (the transducer opened, the flow
#: check), [s]: 6 curves at 100 Hz took 3-4 min on the shared 2-core machine.
RUN_OVERHEAD = 1.0
#: Loads a curve is run at: spread over the range of the hand calculation's stall loads
#: (the pump cycle's and the quasi-static ones) and a quarter of it beyond each end, so both
#: stalls are bracketed.
LOADS = 7
#: A stall load agrees with the hand's within this fraction of p_lim A_L (module docstring).
AGREEMENT = 0.1


@dataclass(frozen=True, kw_only=True)
class EnvelopePoint:
    """One load, one direction (SI; velocities positive down)."""

    load: float  #: [N], opposing down
    direction: str
    velocity: float  #: co-simulation, full drive, [m/s] (NaN: the run stopped, see note)
    hand_velocity: float  #: the hand calculation's (the pump cycle's), [m/s]
    flow_table_velocity: float  #: smeha flow's flow over A_B, down only, [m/s] (NaN up)
    note: str = ""


@dataclass(frozen=True, kw_only=True)
class Envelope:
    """One mode and circuit at one pump frequency."""

    mode: str
    circuit: str
    frequency: float  #: [Hz]
    points: tuple
    stall_load_down: float  #: co-simulation, [N] (NaN: not bracketed)
    stall_load_up: float  #: co-simulation, [N] (NaN: not bracketed)
    hand: PumpLimits

    def as_dict(self) -> dict:
        return {"mode": self.mode, "circuit": self.circuit, "frequency_Hz": self.frequency,
                "stall_load_down_N": self.stall_load_down,
                "stall_load_up_N": self.stall_load_up,
                "hand_stall_load_down_N": self.hand.cycle_stall_load_down,
                "hand_stall_load_up_N": self.hand.cycle_stall_load_up,
                "quasi_static_stall_load_down_N": self.hand.stall_load_down,
                "quasi_static_stall_load_up_N": self.hand.stall_load_up,
                "tolerance_down_N": tolerance(self.hand, "down"),
                "tolerance_up_N": tolerance(self.hand, "up"),
                "hand": self.hand.as_dict(), "points": [asdict(p) for p in self.points]}


def tolerance(hand: PumpLimits, direction: str) -> float:
    """:data:`AGREEMENT` p_lim A_L: how far a stall load may be from the hand's, [N]."""
    area = hand.big_area if direction == "down" else hand.small_area
    return AGREEMENT * abs(hand.pressure_limit) * area


def envelope_loads(hand: PumpLimits, count: int = LOADS) -> np.ndarray:
    """``count`` loads over the hand's stall loads (the pump cycle's and the quasi-static
    ones) and a quarter of their range beyond each end, [N]."""
    stalls = [x for x in (hand.stall_load_up, hand.stall_load_down,
                          hand.cycle_stall_load_up, hand.cycle_stall_load_down)
              if math.isfinite(x)]
    low, high = min(stalls), max(stalls)
    span = max(high - low, 1.0)
    return np.linspace(low - 0.25 * span, high + 0.25 * span, count)


def _stall(loads, velocities, direction) -> float:
    """Where the velocity of ``direction`` crosses zero, [N]: the last moving load and the
    first stalled one, linearly (NaN: no crossing among the loads run)."""
    sign = 1.0 if direction == "down" else -1.0
    moving = [bool(sign * v > 0.0) if math.isfinite(v) else None for v in velocities]
    order = range(len(loads) - 1) if direction == "down" else range(len(loads) - 1, 0, -1)
    for i in order:
        j = i + 1 if direction == "down" else i - 1
        if moving[i] and moving[j] is False:
            v1, v2 = velocities[i], velocities[j]
            return float(loads[i] + (loads[j] - loads[i]) * v1 / (v1 - v2))
    return math.nan


def _flow_table(frequency, mode, circuit, load, backend, fmu_path) -> float:
    """smeha flow's flow at this point over the big cavity's area, [m/s]."""
    from system_models import presets

    from . import flow
    case = flow.Case(frequency, mode, circuit=circuit, load=load, backend=backend)
    row = flow.run_case(case, fmu_path)[2]
    return row["flow_sim_m3_s"] / presets.circuit(circuit).cylinder.big_area


def run_envelope(mode: str, circuit: str, frequency: float, backend: str = "fmu",
                 fmu_path=None, loads=None) -> Envelope:
    """The envelope of one mode and circuit (module docstring)."""
    from . import position
    hand = pump_limits(frequency, mode, circuit)
    loads = envelope_loads(hand) if loads is None else np.asarray(loads, float)
    settings = position.PositionSettings(mode=mode, frequency=frequency, circuit=circuit,
                                         backend=backend)
    points = []
    for direction in ("down", "up"):
        for load in loads:
            note, v, q = "", math.nan, math.nan
            try:
                v = position.full_drive_velocity(settings, direction, float(load), fmu_path)
                if direction == "down":
                    q = _flow_table(frequency, mode, circuit, float(load), backend, fmu_path)
            except gmt.errors.RunError as exc:
                note = str(exc).split(":")[0]
            points.append(EnvelopePoint(load=float(load), direction=direction, velocity=v,
                                        hand_velocity=hand.cycle_velocity(float(load),
                                                                         direction),
                                        flow_table_velocity=q, note=note))
    stall = {d: _stall(loads, [p.velocity for p in points if p.direction == d], d)
             for d in ("down", "up")}
    return Envelope(mode=mode, circuit=circuit, frequency=float(frequency),
                    points=tuple(points), stall_load_down=stall["down"],
                    stall_load_up=stall["up"], hand=hand)


def estimate_wall_time(frequency: float, curves: int) -> float:
    """A rough wall time of ``curves`` envelopes at ``frequency`` [Hz], [s]: per load two
    full-drive runs and the flow table's run, their simulated time times the position
    study's :data:`~smeha.studies.position.WALL_PER_SIMULATED`, and :data:`RUN_OVERHEAD`
    each."""
    from system_models.defaults import DEFAULT_CYCLES

    from .position import IDENTIFY_PERIODS, WALL_PER_SIMULATED
    periods = LOADS * (2 * (IDENTIFY_PERIODS + 1) + DEFAULT_CYCLES)
    return curves * (periods / frequency * WALL_PER_SIMULATED + 3 * LOADS * RUN_OVERHEAD)


def _n(x, fmt):
    return "-" if x is None or not math.isfinite(x) else format(x, fmt)


def _diff(a, b, tol) -> str:
    """a - b against the tolerance, [N]: "+3/24" (within it) or "+30/24 !" (outside)."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return "-"
    return f"{a - b:+.0f}/{tol:.0f}" + (" !" if abs(a - b) > tol else "")


def format_envelope(curves) -> str:
    """The table: per curve the stall loads (co-simulation; the hand calculation, its
    quasi-static limit; the difference and its tolerance), then per load the full-drive
    speed each way beside the hand calculation and the flow table."""
    lines = ["Speed-load envelope: the largest steady piston speed each way at full drive "
             "(co-simulation, the paper's magnetics, sinusoidal drive; period means), "
             "positive down; load opposing down",
             "stall loads [N]: co-simulation (hand: the pump cycle) (quasi-static) "
             f"co-sim - hand / tolerance {AGREEMENT:g} p_lim A_L; p_lim = A_d Y / C",
             f"{'circuit':<12}  {'mode':<13}  {'f [Hz]':>6}  {'down':>7}  {'(hand)':>7}  "
             f"{'(q-s)':>7}  {'diff/tol':>9}  {'up':>7}  {'(hand)':>7}  {'(q-s)':>7}  "
             f"{'diff/tol':>9}  {'p_lim [MPa]':>11}"]
    for c in curves:
        h = c.hand
        row = f"{c.circuit:<12}  {c.mode:<13}  {c.frequency:>6g}  "
        for sim, hand, quasi, d in ((c.stall_load_down, h.cycle_stall_load_down,
                                     h.stall_load_down, "down"),
                                    (c.stall_load_up, h.cycle_stall_load_up,
                                     h.stall_load_up, "up")):
            row += (f"{_n(sim, '.1f'):>7}  {hand:>7.1f}  {quasi:>7.1f}  "
                    f"{_diff(sim, hand, tolerance(h, d)):>9}  ")
        lines.append(row + f"{h.pressure_limit / 1e6:>11.3f}")
    for c in curves:
        lines += ["", f"{c.circuit}, {c.mode}, {c.frequency:g} Hz: velocity [mm/s] at full drive",
                  f"{'load [N]':>9}  {'down':>8}  {'(hand)':>7}  {'(flow table)':>12}  "
                  f"{'up':>8}  {'(hand)':>7}"]
        down = [p for p in c.points if p.direction == "down"]
        up = [p for p in c.points if p.direction == "up"]
        for d, u in zip(down, up):
            note = "; ".join(n for n in (d.note, u.note) if n)
            lines.append(f"{d.load:>9.1f}  {_n(d.velocity * 1e3, '+.2f'):>8}  "
                         f"{d.hand_velocity * 1e3:>+7.2f}  "
                         f"{_n(d.flow_table_velocity * 1e3, '+.2f'):>12}  "
                         f"{_n(u.velocity * 1e3, '+.2f'):>8}  {u.hand_velocity * 1e3:>+7.2f}"
                         + (f"  ({note})" if note else ""))
    return "\n".join(lines)
