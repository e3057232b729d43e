"""Anhysteretic magnetisation laws: Langevin and Froehlich-Kennelly.

* Langevin, L(x) = coth x - 1/x: the classical paramagnet of freely rotating moments, used
  for the anhysteretic magnetisation of ferromagnets with a mean field by Jiles and Atherton
  (J. Magn. Magn. Mater. 61, 1986, 48-60). Slope 1/3 at 0, L -> 1 as x -> infinity.
* Froehlich-Kennelly, M = M_s H / (a + |H|): the empirical law of the magnetisation curve
  (Froehlich 1881; Kennelly, Trans. AIEE 8, 1891, 485-517; e.g. Bozorth, Ferromagnetism,
  1951, ch. 11). In units of M_s and a, f(x) = x / (1 + |x|): slope 1 at 0 and no linear
  initial region (f'' = -2 / (1 + x)^3 for x > 0, largest at the origin), where the Langevin
  law is linear with a cubic correction.
"""
from __future__ import annotations

import numpy as np


def langevin(x):
    """L(x) = coth x - 1/x (series x/3 - x^3/45 + 2 x^5/945 for |x| < 1e-3), [-]."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-3
    xs = np.where(small, 1.0, x)
    return np.where(small, x / 3 - x**3 / 45 + 2 * x**5 / 945, 1.0 / np.tanh(xs) - 1.0 / xs)


def frohlich_kennelly(x):
    """f(x) = x / (1 + |x|), the Froehlich-Kennelly law in units of M_s and a, [-]."""
    x = np.asarray(x, dtype=float)
    return x / (1.0 + np.abs(x))


def frohlich_kennelly_inverse(y: float) -> float:
    """x with f(x) = y, |y| < 1: x = y / (1 - |y|), [-]."""
    return y / (1.0 - abs(y))
