"""The flow check of eqs 39-41 on a co-simulation record.

q = f A_d dy (eq 39): dy is the rod's displacement between the two valve
switching instants of a cycle -- from the start of compression (the control
signal's minimum) to its end (the maximum): i = -1 A to i = +1 A
uncompensated (eq 40), u = 0 to u = u_m compensated (eq 41).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

#: Cycles :func:`flow_check` discards by default, and the fewest a run needs (their home:
#: system_models.defaults, plain numbers the command line's help reads).
from .defaults import MINIMUM_CYCLES, SKIP_CYCLES  # noqa: F401  (MINIMUM_CYCLES re-exported)


@dataclass(frozen=True)
class FlowCheck:
    """Mean cylinder flow of a run against eq 39 (SI)."""

    flow_sim: float  #: mean net flow into the big cavity over whole cycles, [m^3/s]
    flow_eq: float  #: f A_d dy, eq 40/41, [m^3/s]
    dy: float  #: mean rod displacement from compression start to end, [m]
    cycles: int  #: whole cycles averaged
    window: tuple  #: (t_start, t_end) of the averaging window, [s]
    #: the cycles' flows' trend: the slope of a line through each averaged cycle's flow,
    #: per cycle, relative to their mean [1/cycle] (0 with fewer than three cycles, where
    #: no trend can be told from noise)
    drift: float = 0.0

    @property
    def ratio(self) -> float:
        """flow_sim / flow_eq, [-]."""
        return self.flow_sim / self.flow_eq

    def as_dict(self) -> dict:
        d = asdict(self)
        d["ratio"] = self.ratio
        return d




def cycle_flows(times, volumes, sign=1.0) -> np.ndarray:
    """Each whole cycle's mean flow from the compression starts' times and volumes."""
    return sign * np.diff(volumes) / np.diff(times)


def drift(flows) -> float:
    """The slope of a line through per-cycle flows, per cycle, relative to their mean
    (0 for fewer than three cycles)."""
    flows = np.asarray(flows, dtype=float)
    if flows.size < 3 or not np.mean(flows):
        return 0.0
    slope = np.polyfit(np.arange(flows.size), flows, 1)[0]
    return float(slope / abs(np.mean(flows)))


def switching_instants(record):
    """Indices where the valves switch to compression and back.

    The phase the valves act on (``valves_compressing``, after their dead
    times) defines the instants, as eq 39 defines dy between the valve
    switching instants; with instant valves it is the commanded phase.

    Returns
    -------
    (array, array)
        Record indices k whose phase differs from record k-1: compression
        starts (expanding -> compressing) and ends (compressing -> expanding).
    """
    c = record["valves_compressing"][:-1] > 0.5
    change = np.nonzero(c[1:] != c[:-1])[0] + 1
    starts = change[c[change]]
    ends = change[~c[change]]
    return starts, ends


def flow_check(record, frequency: float, piston_area: float, skip_cycles: int = SKIP_CYCLES,
               direction: str = "down") -> FlowCheck:
    """Compare the mean cylinder flow with eq 39 over whole cycles.

    Parameters
    ----------
    record : structured array
        From :func:`system_models.cosim.cosimulate`.
    frequency : float
        Pumping frequency f, [Hz].
    piston_area : float
        A_d, [m^2].
    skip_cycles : int
        Cycles discarded at the start (transient).
    direction : {"down", "up"}
        "down" measures the flow into the big cavity, "up" out of it.

    Raises
    ------
    ValueError
        When the run holds fewer than one whole cycle after ``skip_cycles``.
    """
    starts, ends = switching_instants(record)
    starts = starts[skip_cycles:]
    if starts.size < 2:
        raise ValueError(f"run too short: {starts.size + skip_cycles} compression starts, "
                         f"need at least {skip_cycles + 2}")
    k0, k1 = starts[0], starts[-1]
    t = record["time"]
    vol = record["volume_into_big"]
    sign = 1.0 if direction == "down" else -1.0
    flow = sign * (vol[k1] - vol[k0]) / (t[k1] - t[k0])
    y = record["rod_displacement"]
    dys = []
    for s in starts[:-1]:
        e = ends[ends > s]
        if e.size:
            dys.append(y[e[0]] - y[s])
    dy = float(np.mean(dys))
    per_cycle = cycle_flows(t[starts], vol[starts], sign)
    return FlowCheck(float(flow), frequency * piston_area * dy, dy, int(starts.size - 1),
                     (float(t[k0]), float(t[k1])), drift(per_cycle))


class RunningFlow:
    """The flow of :func:`flow_check`, accumulated record by record (flat memory).

    Give it as the ``observer`` of :func:`system_models.cosim.cosimulate`; it
    keeps, per compression start (the valves' phase turning to compressing),
    the time and the volume that has entered the big cavity, so a run of any
    length can be checked without its record.

    Parameters
    ----------
    skip_cycles : int
        Compression starts discarded at the beginning (transient).
    direction : {"down", "up"}
    """

    def __init__(self, skip_cycles: int = SKIP_CYCLES, direction: str = "down"):
        self.skip_cycles = skip_cycles
        self.sign = 1.0 if direction == "down" else -1.0
        self.starts = []  # (time, volume_into_big) at each compression start
        self._previous = None

    def __call__(self, rec) -> None:
        phase = rec["valves_compressing"] > 0.5
        if self._previous is not None and phase and not self._previous:
            self.starts.append((float(rec["time"]), float(rec["volume_into_big"])))
        self._previous = phase

    @property
    def flow(self) -> float:
        """Mean flow into the big cavity over whole cycles after the skipped ones, [m^3/s]."""
        s = self.starts[self.skip_cycles:]
        if len(s) < 2:
            raise ValueError(f"run too short: {len(self.starts)} compression starts, "
                             f"need at least {self.skip_cycles + 2}")
        return self.sign * (s[-1][1] - s[0][1]) / (s[-1][0] - s[0][0])
