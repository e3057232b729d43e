"""Drive waveforms of the studies: the paper's sinusoid, a square and a trapezoid.

Each shape s(phase) runs between -1 and 1 with the cosine's timing: +1 at
phase 0, -1 at phase 1/2. The valve controller compresses while the control
signal rises and keeps its phase while it stands still (Figure 2 stages;
:mod:`system_models.controller`), so its window runs from where u starts to
rise to where it starts to fall (:func:`compression_window`): a cosine's
minimum to its maximum, a square's rising edge to its falling edge, the start
of a trapezoid's rising ramp to the start of its falling one. The control
signal is u = offset + amplitude s(f t): uncompensated
the coil current i = K_a u; compensated the demanded stroke
(y_d = 10 u um above the bottom, Figure 9).

=============  ================================================  ===========
shape          s over a period                                    RMS of s
=============  ================================================  ===========
``sine``       cos(2 pi phase)                                    1/sqrt(2)
``square``     sign(cos(2 pi phase))                              1
``trapezoid``  the square with linear ramps of RAMP = 0.15 of     sqrt(1 - 4 RAMP/3)
               the period centred on its edges
=============  ================================================  ===========

The trapezoid's RMS: on the plateaus s^2 = 1 over 1 - 2 RAMP of the period,
on the two ramps the mean of a linear s^2 from -1 to 1 is 1/3.
"""
from __future__ import annotations

import math

import numpy as np

from gmt.errors import ParameterError

__all__ = ["WAVEFORMS", "RAMP", "Waveform", "compression_window", "rms_factor", "shape"]

WAVEFORMS = ("sine", "square", "trapezoid")
#: Each ramp of the trapezoid, as a fraction of the period.
RAMP = 0.15


def rms_factor(name: str) -> float:
    """RMS of the unit shape (module docstring's table), [-]."""
    if name == "sine":
        return 1.0 / math.sqrt(2.0)
    if name == "square":
        return 1.0
    if name == "trapezoid":
        return math.sqrt(1.0 - 4.0 * RAMP / 3.0)
    raise ParameterError(f"waveform = {name!r} is not one of {WAVEFORMS}")


def compression_window(name: str) -> tuple[float, float]:
    """(start, end) phases [cycles] of the valve controller's compression window, end > start."""
    if name == "sine":
        return 0.5, 1.0
    if name == "square":
        return 0.75, 1.25
    if name == "trapezoid":
        return 0.75 - 0.5 * RAMP, 1.25 - 0.5 * RAMP
    raise ParameterError(f"waveform = {name!r} is not one of {WAVEFORMS}")


def shape(name: str, phase):
    """s(phase) in [-1, 1] of a unit-period shape, phase in cycles (float or array)."""
    if name == "sine":
        return np.cos(2.0 * np.pi * phase)
    # the triangle wave with the cosine's timing: 1 at phase 0, -1 at 1/2
    tri = 1.0 - 4.0 * np.abs(np.mod(np.asarray(phase, dtype=float) + 0.5, 1.0) - 0.5)
    if name == "square":
        return np.where(tri >= 0.0, 1.0, -1.0)
    if name == "trapezoid":  # the triangle's slope is 4 a period: ramps of RAMP are 1/(2 RAMP)
        return np.clip(tri / (2.0 * RAMP), -1.0, 1.0)
    raise ParameterError(f"waveform = {name!r} is not one of {WAVEFORMS}")


class Waveform:
    """u(t) = offset + amplitude s(f t), [V]: a float for a float t, an array for an array.

    The same interface as :class:`smeha.studies.flow.Sinusoid` (the valve controller
    samples it in blocks, the master one instant at a time).
    """

    def __init__(self, offset: float, amplitude: float, frequency: float, name: str):
        rms_factor(name)  # checks the name
        self.offset, self.amplitude = float(offset), float(amplitude)
        self.frequency, self.name = float(frequency), name

    def __call__(self, t):
        value = self.offset + self.amplitude * shape(self.name, self.frequency * np.asarray(t))
        return value if isinstance(t, np.ndarray) else float(value)
