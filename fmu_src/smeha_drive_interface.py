"""The drive FMU's variable table: the control signal of the EHA's controller.

``SmehaDrive.fmu`` (FMI 2.0 co-simulation) is the signal source of the EHA system: the
control signal u(t) = offset + amplitude cos(2 pi f t) [V] that drives the transducer (its
input ``u``: the amplifier's, or the compensator's, Figure 9) and that the plant's valve
controller follows (Figure 2's stages switch as u rises and falls). It is the signal the
project's co-simulation harness gives the transducer (``smeha.studies.flow.control_signal``:
uncompensated, offset 0 and amplitude I_m / K_a; compensated, offset = amplitude = a, the
paper's control amplitude next to its Figure 10). Stepped over [t, t + h], it outputs u at
t + h, the value a host hands the other units for the next step.

Bundled next to ``smeha_drive_fmu.py``; imports only the standard library (as does the FMU).
"""
from __future__ import annotations

from smeha_fmu_variables import Variable, unit_problems

MODEL_NAME = "SmehaDrive"
SLAVE_MODULE = "smeha_drive_fmu"
INTERFACE_MODULE = "smeha_drive_interface"
AUTHOR = "smeha developers"
LICENSE = "MIT"
DESCRIPTION = ("Control signal u = offset + amplitude cos(2 pi f t) of a smart-material "
               "electrohydrostatic actuator's controller (smeha)")
DEFAULT_EXPERIMENT = {"start_time": 0.0, "stop_time": 0.1, "step_size": 1e-5}

VARIABLES: tuple[Variable, ...] = (
    Variable("offset", "Real", "parameter", "V", "Offset of the control signal", 0.0, "signal"),
    Variable("amplitude", "Real", "parameter", "V", "Amplitude of the control signal, >= 0",
             1.0, "signal"),
    Variable("frequency", "Real", "parameter", "Hz", "Frequency f of the control signal, the "
             "pumping frequency, in (0, 1e5] Hz", 50.0, "signal"),
    Variable("u", "Real", "output", "V", "Control signal u at the end of the last step (at "
             "the start time before the first)", None, "output"),
)
BY_NAME: dict[str, Variable] = {v.name: v for v in VARIABLES}
PARAMETERS = tuple(v.name for v in VARIABLES if v.causality == "parameter")


def check() -> None:
    """Raise ``AssertionError`` if a unit of the table is not declared."""
    problems = unit_problems(VARIABLES)
    if problems:
        raise AssertionError("drive FMU interface:\n  " + "\n  ".join(problems))


def signal_problem(offset: float, amplitude: float, frequency: float) -> str | None:
    """Why these parameters make no control signal, or None."""
    import math

    if not all(math.isfinite(x) for x in (offset, amplitude, frequency)):
        return (f"offset, amplitude, frequency = {offset!r}, {amplitude!r}, {frequency!r}: "
                "not finite")
    if not 0.0 < frequency <= 1e5:
        return f"frequency = {frequency!r} Hz is outside the allowed range (0, 1e5] Hz"
    if amplitude < 0.0:
        return f"amplitude = {amplitude!r} V is outside the allowed range [0, inf) V"
    return None
