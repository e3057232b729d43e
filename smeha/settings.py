"""One declaration per numeric setting: its name, unit, range and default.

A :class:`Setting` is read by the three places that would otherwise each state a range: the
command line's ``--help`` (:meth:`Setting.describe`), its parser
(:func:`smeha.cliargs.setting_type`) and the study that enforces it
(:meth:`Setting.check`, raising :class:`gmt.ParameterError`). A range changed here
changes all three. Importing this module costs nothing (the standard library and
:mod:`gmt.errors`), so ``--help`` can read it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gmt.errors import ParameterError

__all__ = ["Setting", "interval"]


def interval(low, high, low_open=True, high_open=False, unit="") -> str:
    """A range as text: ``(0, 1000] Hz``; ``None`` is an open infinite side."""
    lo = "-inf" if low is None else f"{low:g}"
    hi = "inf" if high is None else f"{high:g}"
    u = f" {unit}" if unit else ""
    return (f"{'(' if low_open or low is None else '['}{lo}, {hi}"
            f"{')' if high_open or high is None else ']'}{u}")


@dataclass(frozen=True)
class Setting:
    """A numeric setting of a study.

    Parameters
    ----------
    name : str
        The study's name of it (``frequency``); the option is ``--`` + name with
        dashes unless ``option`` says otherwise.
    unit : str
        Its unit as printed (``Hz``, ``N``, ``s``); "" for a pure number.
    low, high : float or None
        The range's bounds; ``None`` leaves a side unbounded.
    low_open, high_open : bool
        Whether a bound itself is excluded.
    default : float or None
        The study's default (``None``: decided by the study, e.g. per circuit).
    whole : bool
        Whole numbers only (a count).
    option : str
        The command line's spelling, if not derived from ``name``.
    si : float
        SI per ``unit`` (1e-3 for mm): the study holds ``value * si``.
    help : str
        What the setting is, for ``--help`` (without its range and default).
    default_text : str
        The default in words where ``default`` is None (decided by the study).
    """

    name: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = True
    high_open: bool = False
    default: float | None = None
    whole: bool = False
    option: str = ""
    #: why the lower bound is where it is (or the likely mistake below it), said when a
    #: value below the range is refused
    below: str = ""
    #: the same for a value above the range
    above: str = ""
    si: float = 1.0
    help: str = ""
    default_text: str = ""

    def __post_init__(self):
        if self.low is not None and self.high is not None and not self.low < self.high:
            raise ValueError(f"{self.name}: the range {self.interval()} is empty")

    @property
    def flag(self) -> str:
        """The option on the command line, ``--hydraulic-step``."""
        return self.option or "--" + self.name.replace("_", "-")

    def interval(self) -> str:
        """The allowed range with its unit in words or brackets: ``in (0, 1000] Hz``,
        ``at least 4 cycles``, ``any finite number of N``."""
        u = f" {self.unit}" if self.unit else ""
        if self.low is None and self.high is None:
            return f"any finite number{' of' + u if u else ''}"
        if self.high is None:
            return f"{'more than' if self.low_open else 'at least'} {self.low:g}{u}"
        if self.low is None:
            return f"{'less than' if self.high_open else 'at most'} {self.high:g}{u}"
        return "in " + interval(self.low, self.high, self.low_open, self.high_open, self.unit)

    def contains(self, value: float) -> bool:
        """Whether ``value`` is a finite number in the range (and whole if it must be)."""
        if not math.isfinite(value):
            return False
        if self.low is not None and not (value > self.low if self.low_open
                                          else value >= self.low):
            return False
        if self.high is not None and not (value < self.high if self.high_open
                                          else value <= self.high):
            return False
        return not self.whole or value == int(value)

    def describe(self) -> str:
        """The range and default for ``--help``: ``in (0, 1000] Hz (default 100)``."""
        kind = "a whole number " if self.whole else ""
        if self.default is not None:
            default = f" (default {self.default:g})"
        else:
            default = f" (default: {self.default_text})" if self.default_text else ""
        return f"{kind}{self.interval()}{default}"

    def help_text(self) -> str:
        """The whole ``--help`` line: what it is, the range, the default."""
        return f"{self.help}: {self.describe()}" if self.help else self.describe()

    def refusal(self, text: str) -> str | None:
        """Why ``text`` is not a value of this setting (None: it is one), in one line
        that repeats the value: the command line's and the study's message."""
        try:
            v = float(text)
        except (TypeError, ValueError):
            return f"{text!r} is not a number"
        if v != v:
            return f"{text} is not a number (allowed: {self.interval()})"
        if not math.isfinite(v):
            return f"{text} is not finite (allowed: {self.interval()})"
        if self.contains(v):
            return None
        if self.whole and self.contains(round(v)):
            return f"{text} is not a whole number"
        low_side = self.low is not None and v <= self.low
        why = self.below if low_side else self.above
        why = f" ({why})" if why else ""
        return f"{text} is outside the allowed range: {self.interval()}{why}"

    def check(self, value) -> float:
        """``value`` as a float (an int for a whole setting), or :class:`gmt.ParameterError`
        naming the setting, the value and the range."""
        text = value if isinstance(value, str) else f"{value!r}"
        reason = self.refusal(text)
        if reason is not None:
            raise ParameterError(f"{self.name} = {reason}")
        v = float(value)
        return int(v) if self.whole else v

    def check_si(self, value_si: float) -> float:
        """:meth:`check` of a value held in SI (``value * si``); returns it unchanged."""
        self.check(f"{value_si / self.si:.12g}")  # 12 digits: no float noise of the unit change
        return value_si
