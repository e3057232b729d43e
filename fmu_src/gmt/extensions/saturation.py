"""Magnetisation saturation: a tanh law of the total magnetisation about the bias.

The paper's M (eq 5) is the linear response about the bias M_b. With a
saturation magnetisation M_s the total follows

    M_b + M_sat = M_s tanh(x_b + M / (M_s (1 - m_b^2))),
    m_b = M_b / M_s,  x_b = artanh(m_b),

which keeps the bias (M = 0 gives M_b) and the slope there (d M_sat/dM = 1),
so it reduces to eq 5 as M_s -> inf, while the top of the loop (towards
saturation) flattens and the bottom steepens, more at larger amplitude (a
tanh-type anhysteretic: Jiles & Atherton, J. Magn. Magn. Mater. 61 (1986)
48-60; Calkins, Smith & Flatau, IEEE Trans. Magn. 36 (2000) 429).

* periodic form: the non-fundamental part of M_sat(M) - M over one period
  added to M (the paper's mu', mu'' are the fundamental; module
  :mod:`gmt.extensions.magnetic`);
* time-stepped form: memoryless, per sample M gains M_sat(M) - M minus its
  fundamental at the operating point;
* parameter: M_s [A/m] > M_b; the diagnosis fits M_b/M_s in (0, 1).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ._base import Extension, FitSpec, Parameter, harmonic_remainder
from .magnetic import MagnetizationStage


@dataclass(frozen=True)
class SoftSaturation:
    """tanh saturation of the total magnetisation about the bias (module docstring).

    Attributes
    ----------
    saturation_magnetization : float
        M_s, [A/m], > M_b.
    bias_magnetization : float
        M_b, [A/m].
    """

    saturation_magnetization: float
    bias_magnetization: float

    def __post_init__(self):
        check_range("saturation_magnetization", self.saturation_magnetization,
                    self.bias_magnetization, math.inf, unit="A/m")

    def magnetization(self, magnetization):
        """Coil magnetisation after saturation, M_sat, [A/m] (memoryless: per sample as is)."""
        ms = self.saturation_magnetization
        mb = self.bias_magnetization / ms
        x = math.atanh(mb) + np.asarray(magnetization, dtype=float) / (ms * (1.0 - mb * mb))
        return ms * np.tanh(x) - self.bias_magnetization


class SaturationForm(MagnetizationStage, Extension):
    """tanh saturation of the total magnetisation (module docstring); no memory."""

    cause = "magnetization_saturation"
    stage = "magnetization"
    signals = "B and y"
    parameters = (Parameter("saturation_magnetization_A_per_m", "A/m", 0.0, math.inf),)
    fit = FitSpec(("M_b/M_s",), ((0.3,), (0.6,)), (1e-3,), (0.97,))

    @classmethod
    def from_fit(cls, x, context):
        return {"saturation_magnetization_A_per_m":
                context["params"].bias_magnetization / x[0]}

    @classmethod
    def law(cls, values, params) -> SoftSaturation:
        """The law of the SI parameters for the transducer's M_b."""
        ms = values["saturation_magnetization_A_per_m"]
        if not ms > params.bias_magnetization:
            raise ParameterError(
                f"{cls.cause} parameter saturation_magnetization_A_per_m = {ms:g} A/m is "
                f"outside the allowed range (bias_magnetization = {params.bias_magnetization:g}"
                ", inf) A/m")
        return SoftSaturation(ms, params.bias_magnetization)

    # periodic form
    @classmethod
    def steady_remainder(cls, values, steady, magnetization, theta):
        sat = cls.law(values, steady.params)
        return harmonic_remainder(sat.magnetization(magnetization) - magnetization)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.saturation = self.law(values, params)
        m = upstream(self.grid())
        self.coefficients = self.fundamental(self.saturation.magnetization(m) - m)

    def addition(self, mag):
        m = mag.magnetization
        return float(self.saturation.magnetization(m)) - m

    def waveform(self, theta, upstream):
        m = upstream(theta)
        return m + harmonic_remainder(self.saturation.magnetization(m) - m)
