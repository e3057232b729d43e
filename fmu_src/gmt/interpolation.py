"""Monotone piecewise cubic Hermite interpolation (PCHIP), in numpy.

The calibration of B_m (:mod:`gmt.calibration`) interpolates its frequency
roll-off through the table's points with a curve that neither overshoots nor
oscillates between them. The interpolant is the cubic Hermite spline through
the points whose slopes d_k are chosen so that it is monotone wherever the data
are (F. N. Fritsch and R. E. Carlson, "Monotone piecewise cubic interpolation",
SIAM J. Numer. Anal. 17(2), 238-246, 1980):

* at an interior point, d_k = 0 where the secants delta_{k-1}, delta_k change
  sign or vanish, else their weighted harmonic mean
  (w_1 + w_2) / (w_1/delta_{k-1} + w_2/delta_k), w_1 = 2 h_k + h_{k-1},
  w_2 = h_k + 2 h_{k-1} (F. N. Fritsch and J. Butland, "A method for
  constructing local monotone piecewise cubic interpolants", SIAM J. Sci. Stat.
  Comput. 5(2), 300-304, 1984);
* at an end, the one-sided three-point estimate
  ((2 h_0 + h_1) delta_0 - h_0 delta_1) / (h_0 + h_1), set to 0 if its sign
  differs from delta_0's, and limited to 3 delta_0 where the secants change
  sign (the same monotonicity region, Fritsch & Carlson's Theorem 2);
* two points: the straight line.

This is the interpolant SciPy's ``PchipInterpolator`` computes; the tests
check the two agree (``tests/test_physics_magnetics.py``). Written here so the
FMU's run time needs numpy only.
"""
from __future__ import annotations

import numpy as np

from .errors import ParameterError


def _end_slope(h0, h1, d0, d1):
    slope = ((2.0 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
    if np.sign(slope) != np.sign(d0):
        return 0.0
    if np.sign(d0) != np.sign(d1) and abs(slope) > 3.0 * abs(d0):
        return 3.0 * d0
    return slope


def pchip_slopes(x, y) -> np.ndarray:
    """Slopes d_k of the monotone cubic Hermite interpolant at the points (module docstring).

    Parameters
    ----------
    x : array
        Abscissae, strictly increasing, at least two.
    y : array
        Ordinates, same length.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape or x.size < 2 or not np.all(np.diff(x) > 0.0):
        raise ParameterError("pchip: x must be a strictly increasing 1-D array of at least two "
                             "points and y of the same shape")
    h = np.diff(x)
    delta = np.diff(y) / h
    if x.size == 2:
        return np.array([delta[0], delta[0]])
    d = np.zeros_like(y)
    w1 = 2.0 * h[1:] + h[:-1]
    w2 = h[1:] + 2.0 * h[:-1]
    same = (np.sign(delta[:-1]) * np.sign(delta[1:])) > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
    d[1:-1] = np.where(same, mean, 0.0)
    d[0] = _end_slope(h[0], h[1], delta[0], delta[1])
    d[-1] = _end_slope(h[-1], h[-2], delta[-1], delta[-2])
    return d


class Pchip:
    """The monotone cubic Hermite interpolant through (x, y); call it at x_new in [x_0, x_n].

    Outside [x_0, x_n] it extends the end cubics (callers that need another
    extrapolation, like :class:`gmt.calibration.FluxDensityCalibration`, apply
    their own).
    """

    def __init__(self, x, y):
        self.x = np.asarray(x, dtype=float)
        self.y = np.asarray(y, dtype=float)
        self.slopes = pchip_slopes(self.x, self.y)

    def __call__(self, x_new):
        """Interpolated value(s) at ``x_new`` (float in, float out)."""
        xn = np.asarray(x_new, dtype=float)
        k = np.clip(np.searchsorted(self.x, xn, side="right") - 1, 0, self.x.size - 2)
        h = self.x[k + 1] - self.x[k]
        t = (xn - self.x[k]) / h
        t2, t3 = t * t, t * t * t
        value = ((2.0 * t3 - 3.0 * t2 + 1.0) * self.y[k] + (t3 - 2.0 * t2 + t) * h * self.slopes[k]
                 + (-2.0 * t3 + 3.0 * t2) * self.y[k + 1] + (t3 - t2) * h * self.slopes[k + 1])
        return float(value) if np.ndim(value) == 0 else value
