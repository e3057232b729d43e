"""Valve controller: the four stages of the paper's Figure 2.

| stage | cylinder | pump chamber | open   | closed |
|-------|----------|--------------|--------|--------|
| 1     | down     | compressing  | V1, V4 | V2, V3 |
| 2     | down     | expanding    | V3, V4 | V1, V2 |
| 3     | up       | compressing  | V2, V3 | V1, V4 |
| 4     | up       | expanding    | V1, V2 | V3, V4 |

(shared/paper/NOTES.md). The chamber is compressing while the control signal
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
