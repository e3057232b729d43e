"""Truth of ``magnetization_saturation``: a Langevin anhysteretic of the total field.

M_s L(x), L = coth x - 1/x (D. C. Jiles, D. L. Atherton, J. Magn. Magn. Mater. 61
(1986) 48-60), with the bias inside, linearised at the bias to match eq 5.
"""
from __future__ import annotations

import math

import numpy as np

from gmt.errors import ParameterError

__all__ = ["langevin", "langevin_slope", "inverse_langevin", "saturated_magnetization"]

def langevin(x):
    """Langevin function L(x) = coth(x) - 1/x, [-] (Taylor series for |x| < 0.05)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 0.05
    xs = np.where(small, 1.0, x)
    big = 1.0 / np.tanh(xs) - 1.0 / xs
    x2 = x * x
    series = x * (1.0 / 3.0 + x2 * (-1.0 / 45.0 + x2 * (2.0 / 945.0 - x2 / 4725.0)))
    return np.where(small, series, big)[()]


def langevin_slope(x):
    """L'(x) = 1/x^2 - 1/sinh^2(x), [-] (Taylor series for |x| < 0.05)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 0.05
    xs = np.where(small, 1.0, x)
    big = 1.0 / xs ** 2 - 1.0 / np.sinh(xs) ** 2
    x2 = x * x
    series = 1.0 / 3.0 + x2 * (-1.0 / 15.0 + x2 * (2.0 / 189.0 - x2 / 675.0))
    return np.where(small, series, big)[()]


def inverse_langevin(y: float) -> float:
    """x with L(x) = y, |y| < 1, by Newton's method from Cohen's Pade start."""
    if not abs(y) < 1.0:
        raise ParameterError(f"inverse_langevin: y = {y!r} is outside (-1, 1)")
    x = y * (3.0 - y * y) / (1.0 - y * y)
    for _ in range(50):
        step = (float(langevin(x)) - y) / float(langevin_slope(x))
        x -= step
        if abs(step) <= 1e-15 * max(1.0, abs(x)):
            break
    return x


def saturated_magnetization(magnetization, bias_magnetization, saturation_magnetization):
    """Coil magnetisation through a Langevin anhysteretic of the total field, [A/m].

    The paper's linear magnetisation M (eq 5, with its lag) stands for an
    effective field H_e = (M_b + M) / chi about the bias. The truth is the
    anhysteretic law of Jiles & Atherton (1986), M_tot = M_s L(H_e / a), with
    the bias inside: x_b = L^{-1}(M_b / M_s) places the bias, and the scale of
    H_e / a is fixed so the law's slope at the bias equals the paper's:

        M_tot = M_s L(x_b + M / (M_s L'(x_b))),  returned: M_tot - M_b.

    As M_s -> inf this tends to M (eq 5) exactly; for finite M_s the top of
    the loop (towards saturation) flattens and the bottom steepens, more so at
    larger amplitude.
    """
    m = np.asarray(magnetization, dtype=float)
    if math.isinf(saturation_magnetization):
        return m
    ms = saturation_magnetization
    xb = inverse_langevin(bias_magnetization / ms)
    return ms * langevin(xb + m / (ms * float(langevin_slope(xb)))) - bias_magnetization
