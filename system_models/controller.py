"""Valve controller: the four stages of the paper's Figure 2.

| stage | cylinder | pump chamber | open   | closed |
|-------|----------|--------------|--------|--------|
| 1     | down     | compressing  | V1, V4 | V2, V3 |
| 2     | down     | expanding    | V3, V4 | V1, V2 |
| 3     | up       | compressing  | V2, V3 | V1, V4 |
| 4     | up       | expanding    | V1, V2 | V3, V4 |

(the paper's Figure 2 and its text). The valves' square wave follows the
control signal: the chamber is compressing while the control signal rises and
expanding while it falls, so the valves switch at the extremes of the control
signal: at i = +-I_m uncompensated (eq 40), at u = 0 and u = u_m compensated
(eq 41).
"""
from __future__ import annotations

from bisect import bisect_right

import numpy as np

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

#: Controller samples taken at once (vectorised) when the controller looks ahead.
_BLOCK = 2048


class SampledValveController:
    """Figure 2's stage logic as a digital controller with its own sample period.

    At each sample t_j = j T it takes the pump phase from u(t_j + T) - u(t_j)
    (:func:`pump_phase`; the controller generates u, so it knows where u goes
    next) and commands the valves of that stage; valve k then acts a dead time
    d_k later. Both the switching instants (multiples of T) and the dead times
    are therefore independent of the co-simulation's communication step: the
    master puts a communication point at every valve action
    (:meth:`next_action`), so the commands are constant over each step
    (:meth:`commands_at`).

    Samples are taken in blocks ahead of the queries, u evaluated on a whole
    block at once when it accepts an array of times (a 10 us controller takes
    10^5 samples per simulated second).

    Parameters
    ----------
    direction : {"down", "up"}
    control : callable
        u(t), [V]; vectorised over an array of times if it can be.
    period : float
        Sample period T of the controller, [s], > 0.
    dead_times : sequence of 4 floats
        d_k of V1..V4, [s] (0 for valves with no dead time).
    in_force : sequence of 4 floats, optional
        The commands in force at t = 0 from before (1.0 open, 0.0 closed), to continue
        a run: a valve the first sample commands otherwise acts its dead time later.
        None: the first sample's commands are in force from t = 0.
    """

    def __init__(self, direction, control, period, dead_times, in_force=None):
        from gmt.errors import check_range
        check_range("period", period, 0.0, 1.0, unit="s")
        if len(dead_times) != 4 or min(dead_times) < 0.0:
            raise ParameterError(f"dead_times = {tuple(dead_times)!r} must be 4 values >= 0 s")
        if direction not in DIRECTIONS:
            raise ParameterError(f"direction = {direction!r} is not one of {DIRECTIONS}")
        self.direction = direction
        self.control = control
        self.period = float(period)
        self.dead_times = tuple(float(d) for d in dead_times)
        first = pump_phase(control(self.period), control(0.0), True)
        self._phase_times, self._phases = [0.0], [first]  # phase from each change on
        cmds = valve_commands(direction, first)
        # per valve: the times its command changes and the command from then on
        self._action_times = [[0.0] for _ in range(4)]
        self._action_commands = [[1.0 if c else 0.0] for c in cmds]
        for k, before in enumerate(in_force or ()):
            if (before > 0.5) != cmds[k] and self.dead_times[k] > 0.0:
                self._action_times[k].append(self.dead_times[k])
                self._action_commands[k] = [float(before > 0.5), 1.0 if cmds[k] else 0.0]
        self._issued = list(cmds)
        self._next = 1  # index of the next sample to take (sample 0 set the start)

    def _u(self, times):
        try:
            values = np.asarray(self.control(times), dtype=float)
            if values.shape == times.shape:
                return values
        except TypeError:  # a scalar-only u (math functions)
            pass
        return np.fromiter((self.control(float(t)) for t in times), float, times.size)

    def _sample_until(self, time):
        """Take every controller sample t_j < ``time`` (in blocks; may take more)."""
        period = self.period
        while self._next * period < time - 1e-15:
            j = np.arange(self._next, self._next + _BLOCK + 1)
            u = self._u(j * period)
            rise = np.sign(u[1:] - u[:-1])  # sample j's phase: sign of u(t_j + T) - u(t_j)
            keep = rise != 0.0
            if not keep.all():  # u standing still keeps the phase
                last = np.maximum.accumulate(np.where(keep, np.arange(rise.size), -1))
                rise = np.where(last >= 0, rise[np.maximum(last, 0)],
                                1.0 if self._phases[-1] else -1.0)
            phase = rise > 0.0
            before = np.concatenate(([self._phases[-1]], phase[:-1]))
            for i in np.flatnonzero(phase != before):
                t_j = float(j[i] * period)
                self._phase_times.append(t_j)
                self._phases.append(bool(phase[i]))
                for k, c in enumerate(valve_commands(self.direction, bool(phase[i]))):
                    if c != self._issued[k]:
                        self._issued[k] = c
                        self._action_times[k].append(t_j + self.dead_times[k])
                        self._action_commands[k].append(1.0 if c else 0.0)
            self._next += _BLOCK

    def _covered(self, time):
        """Sample far enough that every action up to ``time`` is known."""
        self._sample_until(time + TIME_TOLERANCE)

    def phase_at(self, time) -> bool:
        """Phase the controller commands at ``time`` (its last sample at or before it)."""
        self._covered(time)
        return self._phases[bisect_right(self._phase_times, time + 1e-15) - 1]

    def commands_at(self, time) -> tuple:
        """Valve commands in force at ``time`` (1.0 open, 0.0 closed), actions at ``time``
        (within :data:`TIME_TOLERANCE`) included."""
        self._covered(time)
        return tuple(self._action_commands[k][bisect_right(self._action_times[k],
                                                           time + TIME_TOLERANCE) - 1]
                     for k in range(4))

    def next_action(self, start, end):
        """Earliest instant in (start, end) at which a valve acts, or None, [s].

        Instants within :data:`TIME_TOLERANCE` of either end do not count.
        """
        self._covered(end)
        best = None
        for k in range(4):
            times = self._action_times[k]
            i = bisect_right(times, start + TIME_TOLERANCE)
            if i < len(times) and times[i] < end - TIME_TOLERANCE:
                best = times[i] if best is None else min(best, times[i])
        return best

    def actions_between(self, start, end) -> np.ndarray:
        """Every instant in (start, end) at which a valve acts, sorted, [s] (as
        :meth:`next_action`, all at once)."""
        self._covered(end)
        found = [t for k in range(4) for t in self._action_times[k]
                 if start + TIME_TOLERANCE < t < end - TIME_TOLERANCE]
        return np.unique(np.array(found, dtype=float))

    def commands_over(self, times) -> np.ndarray:
        """:meth:`commands_at` at each of ``times`` (ascending), (n, 4)."""
        times = np.asarray(times, dtype=float)
        self._covered(float(times[-1]) if times.size else 0.0)
        out = np.empty((times.size, 4))
        for k in range(4):
            i = np.searchsorted(self._action_times[k], times + TIME_TOLERANCE, side="right")
            out[:, k] = np.asarray(self._action_commands[k])[i - 1]
        return out

    def phases_over(self, times) -> np.ndarray:
        """:meth:`phase_at` at each of ``times`` (ascending), 1.0 compressing, 0.0 not."""
        times = np.asarray(times, dtype=float)
        self._covered(float(times[-1]) if times.size else 0.0)
        i = np.searchsorted(self._phase_times, times + 1e-15, side="right")
        return np.asarray(self._phases, dtype=float)[i - 1]

    def forget_before(self, time) -> None:
        """Drop what only matters before ``time`` (a long run keeps flat memory and fast
        look-ups): for each valve and the phase, all but the last change at or before it."""
        for times, values in zip(self._action_times + [self._phase_times],
                                 self._action_commands + [self._phases]):
            i = bisect_right(times, time) - 1
            if i > 0:
                del times[:i]
                del values[:i]


def dead_times(valves) -> tuple:
    """The dead time d_k of each valve, [s]: its ``opening_time`` for a ``"delay"`` response,
    0 otherwise (a first-order valve lags in the plant's own dynamics instead)."""
    return tuple(v.opening_time if v.response == "delay" else 0.0 for v in valves)


class FedValveController:
    """Figure 2's stage logic fed the control signal one sample at a time.

    The controller of a plant that sees u only as it arrives, e.g. a co-simulation
    slave whose input u a host sets before each step (the plant FMU, docs/FMU.md). At
    each sample t_j (:meth:`sample`) it takes the pump phase from u(t_j) - u(t_{j-1})
    (:func:`pump_phase`): the decision :class:`SampledValveController` takes at
    t_{j-1}, knowing u ahead, is taken here one sample later. Valve k then acts a
    dead time d_k after that sample (:meth:`advance`). Until u first changes, the phase
    is compressing, and its valves are open from the start.

    Parameters
    ----------
    direction : {"down", "up"}
    dead_times : sequence of 4 floats
        d_k of V1..V4, [s] (:func:`dead_times`).
    """

    def __init__(self, direction, dead_times):
        if len(dead_times) != 4 or min(dead_times) < 0.0:
            raise ParameterError(f"dead_times = {tuple(dead_times)!r} must be 4 values >= 0 s")
        if direction not in DIRECTIONS:
            raise ParameterError(f"direction = {direction!r} is not one of {DIRECTIONS}")
        self.direction = direction
        self.dead_times = tuple(float(d) for d in dead_times)
        self.compressing = True
        self.last_control = None  # u at the last sample
        first = valve_commands(direction, True)
        self.commands = [1.0 if c else 0.0 for c in first]  # in force now, V1..V4
        self._issued = list(first)  # commanded, dead times not yet elapsed
        self._pending = []  # (time, valve, command) of actions to come, in time order

    def sample(self, time, control) -> None:
        """Take the sample u(t_j) = ``control`` [V] at t_j = ``time`` [s]; the actions it
        causes at ``time`` itself (no dead time) are applied at once."""
        if self.last_control is not None:
            phase = pump_phase(control, self.last_control, self.compressing)
            if phase != self.compressing:
                self.compressing = phase
                for k, c in enumerate(valve_commands(self.direction, phase)):
                    if c != self._issued[k]:
                        self._issued[k] = c
                        self._pending.append((time + self.dead_times[k], k, 1.0 if c else 0.0))
                self._pending.sort()
        self.last_control = float(control)
        self.advance(time)

    def advance(self, time) -> None:
        """Apply the valve actions due at or before ``time`` (within :data:`TIME_TOLERANCE`)."""
        while self._pending and self._pending[0][0] <= time + TIME_TOLERANCE:
            _, k, c = self._pending.pop(0)
            self.commands[k] = c

    def next_action(self, start, end):
        """Earliest instant in (start, end) at which a valve acts, or None, [s] (instants
        within :data:`TIME_TOLERANCE` of either end do not count)."""
        for t, _, _ in self._pending:
            if t > start + TIME_TOLERANCE:
                return t if t < end - TIME_TOLERANCE else None
        return None

    @property
    def stage(self) -> int:
        """The stage of Figure 2 commanded now (1-4)."""
        return stage(self.direction, self.compressing)

    @property
    def valves_compressing(self) -> bool:
        """The phase the valves act on: V1 open going down, V3 going up (Figure 2)."""
        return self.commands[0 if self.direction == "down" else 2] > 0.5

    def get_state(self) -> tuple:
        """Everything that changes, as plain numbers (:meth:`set_state`)."""
        return (self.compressing, self.last_control, tuple(self.commands), tuple(self._issued),
                tuple(self._pending))

    def set_state(self, state) -> None:
        compressing, last, commands, issued, pending = state
        self.compressing = bool(compressing)
        self.last_control = None if last is None else float(last)
        self.commands = [float(c) for c in commands]
        self._issued = [bool(c) for c in issued]
        self._pending = [(float(t), int(k), float(c)) for t, k, c in pending]
