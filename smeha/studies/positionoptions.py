"""The position study's numeric options, each declared once (plain numbers: cheap to import).

One :class:`smeha.settings.Setting` holds what ``smeha position --help`` shows, what its
parser checks and what :class:`smeha.studies.position.PositionSettings` enforces: the name,
the unit the user types, the SI factor, the range with its open or closed ends, the default
and the help text. The command line (:mod:`smeha.studies.positioncommands`) builds its
argparse types and help from these; the study checks its SI fields with
:meth:`Setting.check_si`.
"""
from __future__ import annotations

from dataclasses import replace

from gmt.errors import ParameterError

from ..settings import Setting
from . import flowsettings

__all__ = ["TARGET", "FREQUENCY", "LOAD", "DURATION", "LOAD_STEP", "CONTROLLER_RATE",
           "SINE_AMPLITUDE", "SMALLEST_TARGET", "OPTIONS"]


#: The step's distance; > 0 moves down (oil into the big cavity). The piston starts
#: mid-stroke of the 50 mm cylinder (system_models.cylinder), so 20 mm leaves 5 mm to
#: each end stop.
TARGET = Setting("target", "mm", -20.0, 20.0, low_open=False, default=5.0, option="--target-mm",
                 si=1e-3, help="the step; > 0 moves down (oil into the big cavity), not 0 and "
                               "not below 0.05 mm in size")
#: The smallest step the study takes, [mm]: about half the piston's travel in one pump
#: period at full drive (0.1 mm at 100 Hz), a step the loop takes in a period or two; a
#: smaller number is most likely metres typed where millimetres are asked.
SMALLEST_TARGET = 0.05
#: The pump frequency: the flow study's declaration (the transducer FMU's range, a
#: likely unit mistake named below it), with the position study's default.
FREQUENCY = replace(flowsettings.FREQUENCY, default=100.0, help="pump frequency")
#: The load, opposing down; the pump's stall loads bound it (smeha.studies.positionlimits).
LOAD = Setting("load", "N", -1e4, 1e4, low_open=False,
               help="load on the cylinder, opposing down (negative: pulling down); the "
                    "pump's stall loads at the frequency and mode bound it",
               default_text="the circuit's, 150 N realistic, 0 otherwise")
DURATION = Setting("duration", "s", 0.0, 60.0, help="simulated time of the step",
                   default_text="twice the predicted settling time, at least 0.3 s")
LOAD_STEP = Setting("load_step", "N", -1e4, 1e4, low_open=False, default=50.0,
                    help="the load scenario's step of load while holding")
CONTROLLER_RATE = Setting("controller_rate", "Hz", 0.0, 1000.0,
                          help="the position controller's sample rate: the pump frequency "
                               "over a whole number N (a decision holds N periods)",
                          default_text="the pump frequency")
SINE_AMPLITUDE = Setting("sine_amplitude", "mm", 0.0, 10.0, default=0.1,
                         option="--sine-amplitude-mm", si=1e-3,
                         help="the sine scenario's amplitude")

#: Every option, by field.
OPTIONS = {o.name: o for o in (TARGET, FREQUENCY, LOAD, DURATION, LOAD_STEP,
                                CONTROLLER_RATE, SINE_AMPLITUDE)}


def check_target(target: float) -> None:
    """The step [m]: in :data:`TARGET`'s range and not below :data:`SMALLEST_TARGET` in size
    (a ParameterError names the likely mistake: metres typed where millimetres are asked)."""
    TARGET.check_si(target)
    mm = target / TARGET.si
    if abs(mm) < SMALLEST_TARGET:
        hint = (f"; --target-mm takes millimetres ({mm * 1e3:g} mm is --target-mm "
                f"{mm * 1e3:g}), was the step typed in metres?" if abs(mm) * 1e3 >= SMALLEST_TARGET
                else "")
        raise ParameterError(f"target = {mm:g} mm is below {SMALLEST_TARGET:g} mm in size, "
                             f"the least step the loop resolves{hint}")
