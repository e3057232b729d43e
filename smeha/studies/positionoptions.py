"""The position study's numeric options, each declared once (plain numbers: cheap to import).

One :class:`Option` holds what ``smeha position --help`` shows, what its parser checks and
what :class:`smeha.studies.position.PositionSettings` enforces: the name, the unit the user
types, the SI factor, the range with its open or closed ends, the default and the help text.
The command line (:mod:`smeha.studies.positioncommands`) builds its argparse types and help
from these; the study checks its SI fields with :meth:`Option.check`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gmt.errors import ParameterError

__all__ = ["Option", "TARGET", "FREQUENCY", "LOAD", "DURATION", "LOAD_STEP", "CONTROLLER_RATE",
           "SINE_AMPLITUDE", "SMALLEST_TARGET", "OPTIONS"]


@dataclass(frozen=True)
class Option:
    """A numeric option: ``--{flag}`` in ``unit``, the study's ``field`` in SI.

    Attributes
    ----------
    field : str
        The settings field (SI), e.g. ``"target"``.
    flag : str
        The command line's option without its dashes, e.g. ``"target-mm"``.
    unit : str
        The unit the user types and reads, e.g. ``"mm"``.
    si : float
        SI per ``unit`` (1e-3 for mm).
    low, high : float
        The range in ``unit``; ``low_open``/``high_open`` exclude an end.
    default : float or None
        In ``unit``; None: the study decides (the help says how).
    help : str
        What the option is, without its range and default (added from the fields).
    """

    field: str
    flag: str
    unit: str
    si: float
    low: float
    high: float
    default: float | None
    help: str
    low_open: bool = True
    high_open: bool = False
    default_text: str = ""  #: the default's wording when ``default`` is None

    def interval(self) -> str:
        """The range as ``--help`` and the messages write it, e.g. ``[-20, 20] mm``."""
        return (f"{'(' if self.low_open else '['}{self.low:g}, {self.high:g}"
                f"{')' if self.high_open else ']'} {self.unit}")

    def contains(self, value: float) -> bool:
        """``value`` in ``unit`` inside the range (and finite)."""
        if not math.isfinite(value):
            return False
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def check(self, value_si: float) -> None:
        """Raise :class:`gmt.ParameterError` naming the field unless ``value_si`` [SI] is in
        the range."""
        value = value_si / self.si
        if not self.contains(value):
            raise ParameterError(f"{self.field} = {value:g} {self.unit} is outside the "
                                 f"allowed range {self.interval()}")

    def help_text(self) -> str:
        """The help line: what, range, default."""
        default = (f"default {self.default:g}" if self.default is not None
                   else f"default: {self.default_text}")
        return f"{self.help}, [{self.unit}] in {self.interval()} ({default})"


#: The step's distance; > 0 moves down (oil into the big cavity). The piston starts
#: mid-stroke of the 50 mm cylinder (system_models.cylinder), so 20 mm leaves 5 mm to
#: each end stop.
TARGET = Option("target", "target-mm", "mm", 1e-3, -20.0, 20.0, 5.0,
                "the step; > 0 moves down (oil into the big cavity), not 0 and not below "
                "0.05 mm in size", low_open=False)
#: The smallest step the study takes, [mm]: about half the piston's travel in one pump
#: period at full drive (0.1 mm at 100 Hz), a step the loop takes in a period or two; a
#: smaller number is most likely metres typed where millimetres are asked.
SMALLEST_TARGET = 0.05
#: The pump frequency: the transducer FMU's range (gmt.Excitation's frequency).
FREQUENCY = Option("frequency", "frequency", "Hz", 1.0, 0.0, 1000.0, 100.0,
                   "pump frequency")
#: The load, opposing down; the pump's stall loads bound it (smeha.studies.positionlimits).
LOAD = Option("load", "load", "N", 1.0, -1e4, 1e4, None,
              "load on the cylinder, opposing down (negative: pulling down); the pump's "
              "stall loads at the frequency and mode bound it", low_open=False,
              high_open=False, default_text="the circuit's, 150 N realistic, 0 otherwise")
DURATION = Option("duration", "duration", "s", 1.0, 0.0, 60.0, None,
                  "simulated time of the step",
                  default_text="twice the predicted settling time, at least 0.3 s")
LOAD_STEP = Option("load_step", "load-step", "N", 1.0, -1e4, 1e4, 50.0,
                   "the load scenario's step of load while holding", low_open=False)
CONTROLLER_RATE = Option("controller_rate", "controller-rate", "Hz", 1.0, 0.0, 1000.0, None,
                         "the position controller's sample rate: the pump frequency over a "
                         "whole number N (a decision holds N periods)",
                         default_text="the pump frequency")
SINE_AMPLITUDE = Option("sine_amplitude", "sine-amplitude-mm", "mm", 1e-3, 0.0, 10.0, 0.1,
                        "the sine scenario's amplitude")

#: Every option, by field.
OPTIONS = {o.field: o for o in (TARGET, FREQUENCY, LOAD, DURATION, LOAD_STEP,
                                CONTROLLER_RATE, SINE_AMPLITUDE)}


def check_target(target: float) -> None:
    """The step [m]: in :data:`TARGET`'s range and not below :data:`SMALLEST_TARGET` in size
    (a ParameterError names the likely mistake: metres typed where millimetres are asked)."""
    TARGET.check(target)
    mm = target / TARGET.si
    if abs(mm) < SMALLEST_TARGET:
        hint = (f"; --target-mm takes millimetres ({mm * 1e3:g} mm is --target-mm "
                f"{mm * 1e3:g}), was the step typed in metres?" if abs(mm) * 1e3 >= SMALLEST_TARGET
                else "")
        raise ParameterError(f"target = {mm:g} mm is below {SMALLEST_TARGET:g} mm in size, "
                             f"the least step the loop resolves{hint}")
