"""Magnetisation saturation: a tanh law of the total magnetisation.

The paper's M (eq 5) is linear in H about the bias M_b. A material with a
saturation magnetisation M_s cannot follow it: its total magnetisation is
the linear one through an anhysteretic law with unit slope at zero (a
tanh-type law: Jiles & Atherton, J. Magn. Magn. Mater. 61 (1986) 48-60;
Calkins, Smith & Flatau, IEEE Trans. Magn. 36 (2000) 429),

    M_b + M_sat = M_s tanh((M_b + M) / M_s),

which tends to M_b + M as M_s -> inf. The bias itself sits on that curve:
the total at M = 0 is M_s tanh(M_b / M_s) < M_b and the slope there is
sech^2(M_b / M_s) < 1, so the strain per unit magnetisation falls (eq 25), and
the loop flattens towards saturation and steepens away from it, more at
larger amplitude. The paper's part M is the linear magnetisation the coil
would see without saturation; the coil sees the total.

* periodic form: M_sat(M) over one period (:meth:`SaturationForm.steady_output`;
  the paper's part of M is the one whose saturated total gives the measured
  B_m, :func:`gmt.extensions.paperpart.paper_permeability`);
* time-stepped form: memoryless, per sample M becomes M_sat(M);
* parameter: M_s [A/m] > M_b; the diagnosis fits M_b/M_s in (0, 1).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ._base import Extension, FitSpec, Parameter
from .magnetic import MagnetizationStage


@dataclass(frozen=True)
class SoftSaturation:
    """tanh saturation of the total magnetisation (module docstring).

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
        """M_sat = M_s tanh((M_b + M) / M_s) - M_b of the linear M, [A/m] (per sample)."""
        ms = self.saturation_magnetization
        total = self.bias_magnetization + np.asarray(magnetization, dtype=float)
        return ms * np.tanh(total / ms) - self.bias_magnetization


class SaturationForm(MagnetizationStage, Extension):
    """tanh saturation of the total magnetisation (module docstring); no memory."""

    cause = "magnetization_saturation"
    stage = "magnetization"
    signals = "B and y"
    parameters = (Parameter("saturation_magnetization_A_per_m", "A/m", 0.0, math.inf),)
    fit = FitSpec(("M_b/M_s",), ((0.3,), (0.6,)), (1e-3,), (0.97,), neutral=(1e-3,))

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
    def steady_output(cls, values, steady, magnetization, theta, memo=None):
        return cls.law(values, steady.params).magnetization(magnetization)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.saturation = self.law(values, params)

    def adjust(self, mag, step, time):
        m = mag.magnetization
        return self.with_magnetization(mag, float(self.saturation.magnetization(m)) - m)

    def waveform(self, theta, upstream):
        return self.saturation.magnetization(upstream(theta))
