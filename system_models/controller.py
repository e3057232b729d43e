"""Valve controller: the four stages of the paper's Figure 2.

| stage | cylinder | pump chamber | open   | closed |
|-------|----------|--------------|--------|--------|
| 1     | down     | compressing  | V1, V4 | V2, V3 |
| 2     | down     | expanding    | V3, V4 | V1, V2 |
| 3     | up       | compressing  | V2, V3 | V1, V4 |
| 4     | up       | expanding    | V1, V2 | V3, V4 |

(the paper's Figure 2 and its text). The chamber is compressing while the control signal
rises and expanding while it falls, so the valves' square wave switches at the
extremes of the control signal: at i = +-I_m uncompensated (eq 40), at u = 0
and u = u_m compensated (eq 41).
"""
from __future__ import annotations

from gmt.errors import ParameterError

DIRECTIONS = ("down", "up")

#: (direction, compressing) -> (stage, open flags of V1..V4)
STAGES = {
    ("down", True): (1, (True, False, False, True)),
    ("down", False): (2, (False, False, True, True)),
    ("up", True): (3, (False, True, True, False)),
    ("up", False): (4, (True, True, False, False)),
}


def stage(direction: str, compressing: bool) -> int:
    """Stage number 1-4 of Figure 2."""
    return _lookup(direction, compressing)[0]


def valve_commands(direction: str, compressing: bool) -> tuple[bool, bool, bool, bool]:
    """Open (True) or closed command of V1, V2, V3, V4 in the stage of Figure 2.

    Examples
    --------
    >>> valve_commands("down", True)
    (True, False, False, True)
    """
    return _lookup(direction, compressing)[1]


def _lookup(direction, compressing):
    if direction not in DIRECTIONS:
        raise ParameterError(f"direction = {direction!r} is not one of {DIRECTIONS}")
    return STAGES[(direction, bool(compressing))]


def pump_phase(control, previous_control, previous_compressing: bool) -> bool:
    """Compressing (True) while the control signal rises, expanding while it falls.

    A control signal that does not change keeps the previous phase.
    """
    if control > previous_control:
        return True
    if control < previous_control:
        return False
    return previous_compressing


#: Valve actions closer than this to a step's ends count as at the end, [s].
TIME_TOLERANCE = 1e-9


class SampledValveController:
    """Figure 2's stage logic as a digital controller with its own sample period.

    At each sample t_j = j T it takes the pump phase from u(t_j + T) - u(t_j)
    (:func:`pump_phase`; the controller generates u, so it knows where u goes
    next) and commands the valves of that stage; valve k then acts a dead time
    d_k later. Both the switching instants (multiples of T) and the dead times
    are therefore independent of the co-simulation's communication step: a
    step only asks which commands are in force over its interval
    (:meth:`segments`), and is split where they change.

    Parameters
    ----------
    direction : {"down", "up"}
    control : callable
        u(t), [V].
    period : float
        Sample period T of the controller, [s], > 0.
    dead_times : sequence of 4 floats
        d_k of V1..V4, [s] (0 for valves with no dead time).
    """

    def __init__(self, direction, control, period, dead_times):
        from collections import deque

        from gmt.errors import check_range
        check_range("period", period, 0.0, 1.0, unit="s")
        if len(dead_times) != 4 or min(dead_times) < 0.0:
            raise ParameterError(f"dead_times = {tuple(dead_times)!r} must be 4 values >= 0 s")
        self.direction = direction
        self.control = control
        self.period = float(period)
        self.dead_times = tuple(float(d) for d in dead_times)
        self.compressing = pump_phase(control(self.period), control(0.0), True)
        first = valve_commands(direction, self.compressing)
        self.in_force = list(first)  # commands acting now
        self._issued = list(first)  # last command issued per valve
        self._pending = deque()  # (time, valve, command), in time order per valve
        self._next = 1  # index of the next sample (sample 0 set the start)
        self._phase_times = deque([(0.0, self.compressing)])

    def _sample_until(self, time):
        """Take every controller sample t_j < time."""
        t_j = self._next * self.period
        while t_j < time - 1e-15:
            self.compressing = pump_phase(self.control(t_j + self.period), self.control(t_j),
                                          self.compressing)
            self._phase_times.append((t_j, self.compressing))
            for k, c in enumerate(valve_commands(self.direction, self.compressing)):
                if c != self._issued[k]:
                    self._issued[k] = c
                    self._pending.append((t_j + self.dead_times[k], k, c))
            self._next += 1
            t_j = self._next * self.period

    def phase_at(self, time) -> bool:
        """Phase the controller commands at ``time`` (its last sample at or before it)."""
        self._sample_until(time + 1e-15)
        while len(self._phase_times) > 1 and self._phase_times[1][0] <= time + 1e-15:
            self._phase_times.popleft()
        return self._phase_times[0][1]

    def next_event(self, start, end):
        """Earliest instant in (start, end) at which a valve acts, or None, [s]."""
        self._sample_until(end)
        inside = [t for t, _, _ in self._pending
                  if start + TIME_TOLERANCE < t < end - TIME_TOLERANCE]
        return min(inside) if inside else None

    def segments(self, start, end):
        """Commands in force over [start, end): a list of (time, (c1, c2, c3, c4)).

        The first entry is at ``start``; each further one where a valve acts,
        strictly inside the interval. Commands are 1.0 (open) or 0.0. Calls
        must cover consecutive intervals.
        """
        # every sample that can act before ``end`` (dead times are >= 0)
        self._sample_until(end)
        events = sorted(self._pending)
        self._pending.clear()
        out = []
        for t, k, c in events:
            if t >= end - TIME_TOLERANCE:
                self._pending.append((t, k, c))
                continue
            if t > start + TIME_TOLERANCE and not out:
                out.append((start, _as_floats(self.in_force)))
            self.in_force[k] = c
            if t > start + TIME_TOLERANCE:
                if out[-1][0] != t:
                    out.append((t, None))
                out[-1] = (t, _as_floats(self.in_force))
        if not out:
            out.append((start, _as_floats(self.in_force)))
        return out


def _as_floats(flags):
    return tuple(1.0 if f else 0.0 for f in flags)
