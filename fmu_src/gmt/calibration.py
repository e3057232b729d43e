"""Flux-density amplitude B_m at operating points that were not measured.

B_m is an input of the complex-permeability model (eqs 16, 20): the paper
measures it with the sensing coil (eq 22, Table 1) at six operating points.
To run the model elsewhere it needs B_m(f, I_m). This module builds it from a
calibration table of measured points (by default Table 1), through the
amplitude permeability mu_a = B_m / (mu_0 H_m) (eq 19), separated as

    mu_a(f, H_m) = R(H_m) * D(f)

* R(H_m) = mu_i + nu H_m, Rayleigh's law for the amplitude permeability
  (the low-field law behind eq 6), fitted by least squares through the points
  at the lowest table frequency that has two or more amplitudes (Table 1:
  5 Hz, 0.5 and 0.7 A). With a single amplitude R is constant.
* D(f), the frequency roll-off (eddy-current shielding), is the ratio
  mu_a / R at each table frequency (averaged over its amplitudes),
  interpolated by a monotone cubic (PCHIP, :mod:`gmt.interpolation`) in log f. Below the lowest table
  frequency D is held at its value there (the permeability is taken as
  quasi-static); above the highest it is extrapolated as a power law with the
  log-log slope of the last table segment, kept between -0.5 (the skin-effect
  asymptote of a lamination) and 0.

The table's own points are returned exactly. The model uses this calibration
whenever an :class:`~gmt.parameters.Excitation` carries no measured B_m.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import MU_0
from .errors import ParameterError
from .interpolation import Pchip

#: Paper, Table 1: (f [Hz], I_m [A], E_m [V], B_m [T]), measured with the
#: sensing coil (N_c = 150, d_c = 22 mm).
TABLE_1 = (
    (5.0, 0.5, 0.053, 0.0300),
    (5.0, 0.7, 0.095, 0.0530),
    (50.0, 1.0, 1.140, 0.0637),
    (70.0, 1.0, 1.500, 0.0590),
    (80.0, 1.0, 1.620, 0.0570),
    (100.0, 1.0, 1.900, 0.0531),
)


@dataclass(frozen=True)
class FluxDensityCalibration:
    """B_m(f, I_m) from a table of measured points (see module docstring).

    Attributes
    ----------
    points : tuple of (float, float, float)
        (frequency [Hz], current amplitude [A], B_m [T]) for each measurement.
    field_per_ampere : float
        N / (k_f L) of the transducer the table was measured on, [A/m per A]
        (eq 1); Table 2 gives 1300 / (1.1 * 0.08).
    """

    points: tuple = tuple((f, i, b) for f, i, _, b in TABLE_1)
    field_per_ampere: float = 1300.0 / (1.1 * 0.08)

    def __post_init__(self):
        pts = tuple(tuple(float(v) for v in p) for p in self.points)
        if len(pts) == 0:
            raise ParameterError("calibration points: at least one (f, I_m, B_m) point is needed")
        for k, (f, i, b) in enumerate(pts):
            if not (f > 0 and i > 0 and b > 0):
                raise ParameterError(
                    f"calibration point {k} = {(f, i, b)}: frequency, current amplitude "
                    "and B_m must all be > 0")
        object.__setattr__(self, "points", pts)
        f = np.array([p[0] for p in pts])
        h = np.array([p[1] for p in pts]) * self.field_per_ampere
        mua = np.array([p[2] for p in pts]) / (MU_0 * h)
        # Rayleigh law at the lowest frequency with >= 2 distinct amplitudes.
        rayleigh = (float(np.mean(mua[f == f.min()])), 0.0)
        for fk in np.unique(f):
            sel = f == fk
            if len(np.unique(h[sel])) >= 2:
                slope, intercept = np.polyfit(h[sel], mua[sel], 1)
                rayleigh = (float(intercept), float(slope))
                break
        object.__setattr__(self, "_rayleigh", rayleigh)
        freqs = np.unique(f)
        ratio = np.array([np.mean(mua[f == fk] / self._r(h[f == fk])) for fk in freqs])
        object.__setattr__(self, "_freqs", freqs)
        object.__setattr__(self, "_ratio", ratio)
        if len(freqs) >= 2:
            object.__setattr__(self, "_interp",
                               Pchip(np.log(freqs), np.log(ratio)))
            slope = (math.log(ratio[-1] / ratio[-2])
                     / math.log(freqs[-1] / freqs[-2]))
            object.__setattr__(self, "_tail_slope", min(0.0, max(-0.5, slope)))
        else:
            object.__setattr__(self, "_interp", None)
            object.__setattr__(self, "_tail_slope", 0.0)

    def _r(self, field_amplitude):
        mu_i, nu = self._rayleigh
        return mu_i + nu * field_amplitude

    @property
    def rayleigh_law(self) -> tuple[float, float]:
        """(mu_i [-], nu [m/A]) of R(H_m) = mu_i + nu H_m."""
        return self._rayleigh

    def rolloff(self, frequency) -> float:
        """Frequency factor D(f) of the amplitude permeability, [-]."""
        f = float(frequency)
        if f <= self._freqs[0] or self._interp is None:
            return float(self._ratio[0]) if f <= self._freqs[0] else float(self._ratio[-1])
        if f <= self._freqs[-1]:
            return float(math.exp(self._interp(math.log(f))))
        return float(self._ratio[-1] * (f / self._freqs[-1]) ** self._tail_slope)

    def amplitude_permeability(self, frequency, current_amplitude) -> float:
        """mu_a = B_m / (mu_0 H_m) at (f, I_m), [-] (eq 19)."""
        h = current_amplitude * self.field_per_ampere
        r = self._r(h)
        if not r > 0:
            raise ParameterError(
                f"current_amplitude = {current_amplitude:g} A is outside the range "
                f"where the calibration's Rayleigh law gives a positive permeability "
                f"(mu_a = {self._rayleigh[0]:g} + {self._rayleigh[1]:g} H_m)")
        return r * self.rolloff(frequency)

    def flux_density_amplitude(self, frequency, current_amplitude) -> float:
        """B_m at (f, I_m), [T]; a table point returns its measured value exactly."""
        for f, i, b in self.points:
            if f == frequency and i == current_amplitude:
                return b
        h = current_amplitude * self.field_per_ampere
        return MU_0 * h * self.amplitude_permeability(frequency, current_amplitude)


#: The calibration the model uses by default: Table 1 on the Table 2 transducer.
DEFAULT_CALIBRATION = FluxDensityCalibration()
