"""What the co-simulation master records, and where: the communication points and the record.

The communication points (:class:`Grid`) are the multiples of the step, the
digital compensator's samples and the valve actions (each valve acts its dead
time after the controller's decision, :class:`~system_models.controller.SampledValveController`):
a step never straddles a change of the force or of a valve. The record
(:class:`Writer`) holds one row a communication point (:data:`RESULT_FIELDS`,
SI), kept in memory or streamed to an observer.
"""
from __future__ import annotations

import math

import numpy as np

from . import kernel
from .controller import SampledValveController

#: Fields of the structured array :func:`system_models.cosim.cosimulate` returns (SI).
RESULT_FIELDS = (
    "time", "control", "current", "rod_displacement", "rod_velocity", "force",
    "p_pump", "p_big", "p_small", "p_accumulator", "piston_position", "piston_velocity",
    "q_v1", "q_v2", "q_v3", "q_v4", "volume_into_big", "compression_volume",
    "compressing", "valves_compressing", "iterations", "flux_density", "free_displacement",
)
#: SI unit of each field, as CSV column names carry it (``p_pump_Pa``, ``q_v1_m3_s``):
#: "" for a 0/1 flag (``compressing``: the controller's pump phase, ``valves_compressing``:
#: the phase the valves act on) and a count (``iterations`` of the coupling).
RESULT_UNITS = {
    "time": "s", "control": "V", "current": "A", "rod_displacement": "m",
    "rod_velocity": "m_s", "force": "N", "p_pump": "Pa", "p_big": "Pa", "p_small": "Pa",
    "p_accumulator": "Pa", "piston_position": "m", "piston_velocity": "m_s",
    "q_v1": "m3_s", "q_v2": "m3_s", "q_v3": "m3_s", "q_v4": "m3_s", "volume_into_big": "m3",
    "compression_volume": "m3", "compressing": "", "valves_compressing": "", "iterations": "",
    "flux_density": "T", "free_displacement": "m",
}
#: ``flux_density``: the rod's B (eq 4) at the row's current; ``free_displacement``: the
#: transducer's own rod with no chamber force on it, as its displacement sensor reads it (the
#: FMU's ``sensed_displacement``), what a test of the transducer alone measures (the force
#: port; NaN in the displacement port, whose FMU rod carries the chamber's force).


class Grid:
    """Communication points: multiples of the step, the compensator's samples, valve actions."""

    def __init__(self, step, end, sample_period, controller: SampledValveController):
        self.step, self.end, self.sample = step, end, sample_period
        self.controller = controller
        self.tol = 1e-9 * step

    def points(self, t, count) -> np.ndarray:
        """t and the next ``count`` communication points after it (fewer at the end)."""
        tol, step = self.tol, self.step
        high = min(t + (count + 1) * step, self.end)
        k0 = math.floor((t + tol) / step) + 1
        candidates = [np.arange(k0, k0 + count + 2) * step, [self.end]]
        if self.sample > 0.0:
            j0 = math.floor((t + tol) / self.sample) + 1
            candidates.append(np.arange(j0, j0 + count + 2) * self.sample)
        candidates.append(self.controller.actions_between(t, high + step))
        points = np.sort(np.concatenate(candidates))
        points = points[(points > t + tol) & (points <= self.end + tol)]
        # one point where the sources coincide (within the tolerance)
        keep = np.concatenate(([True], np.diff(points) > tol))
        points = points[keep][:count]
        if points.size and self.end - points[-1] <= tol:
            points[-1] = self.end
        return np.concatenate(([t], points))

    def next(self, t) -> float:
        """The communication point after t."""
        return float(self.points(t, 1)[1])

    def before_end(self, t) -> bool:
        """Whether t is short of the run's end (beyond the tolerance)."""
        return self.end - t > self.tol


class Writer:
    """The record: one row a communication point, kept or streamed to an observer."""

    def __init__(self, size_hint, keep, observer):
        self.dtype = np.dtype([(name, float) for name in RESULT_FIELDS])
        self.keep, self.observer = keep, observer
        self.rows = np.zeros(size_hint + 1 if keep else 0, dtype=self.dtype)
        self.count = 0
        self.last = None

    def add(self, columns: dict, n: int):
        """Append n rows given as {field: array or scalar}."""
        block = np.zeros(n, dtype=self.dtype)
        for name, values in columns.items():
            block[name] = values
        if self.observer is not None:
            for row in block:
                self.observer(row)
        if self.keep:
            if self.count + n > len(self.rows):
                grow = np.zeros(max(n, len(self.rows) // 4 + 8), dtype=self.dtype)
                self.rows = np.concatenate((self.rows, grow))
            self.rows[self.count:self.count + n] = block
        self.count += n
        self.last = block[-1:].copy()

    def result(self):
        return self.rows[:self.count] if self.keep else self.last


def circuit_columns(x, rod, packed) -> dict:
    """Record columns of circuit states (rows of x, [:, :10]) and the rod's (y, v) rows."""
    x = np.atleast_2d(x)
    q = np.array([kernel.flows(row, packed) for row in x])
    p_a = np.array([kernel.accumulator_pressure(row, packed) for row in x])
    return columns(x, np.atleast_2d(rod), q, p_a)


def columns(x, rod, q, p_a) -> dict:
    """Record columns of circuit states x (rows), the rod's (y, v) rows, valve flows q and
    accumulator pressures p_a."""
    return {"p_pump": x[:, 0], "p_big": x[:, 1], "p_small": x[:, 2], "p_accumulator": p_a,
            "piston_position": x[:, 4], "piston_velocity": x[:, 5],
            "rod_displacement": rod[:, 0], "rod_velocity": rod[:, 1],
            "q_v1": q[:, 0], "q_v2": q[:, 1], "q_v3": q[:, 2], "q_v4": q[:, 3]}


def stack_first(first: dict, rest: dict) -> dict:
    """Columns ``first`` (one row) on top of the columns ``rest``."""
    return {k: np.concatenate((np.atleast_1d(first[k]), rest[k])) for k in first}
