"""Anhysteretic magnetisation laws: Langevin, Froehlich-Kennelly, Brillouin, arctangent and
the Langevin law with a mean field.

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

import math

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


def brillouin(j: float, x):
    """Brillouin function B_J(x) = c1 coth(c1 x) - c2 coth(c2 x), c1 = (2J + 1) / 2J,
    c2 = 1 / 2J: moments of angular momentum J in a field (Kittel, *Introduction to Solid
    State Physics*, ch. 11). Slope (J + 1) / 3J at 0 (series below |x| < 1e-3), B_J -> 1."""
    x = np.asarray(x, dtype=float)
    c1, c2 = (2.0 * j + 1.0) / (2.0 * j), 1.0 / (2.0 * j)
    small = np.abs(x) < 1e-3
    xs = np.where(small, 1.0, x)
    slope = (j + 1.0) / (3.0 * j)
    cube = (c1**4 - c2**4) / 45.0
    return np.where(small, slope * x - cube * x**3,
                    c1 / np.tanh(c1 * xs) - c2 / np.tanh(c2 * xs))


def arctangent(x):
    """(2 / pi) atan(pi x / 2): slope 1 at 0, -> 1 as 1 - 4 / (pi^2 x) (an empirical
    magnetisation-curve law; e.g. Trutt, Erdelyi and Hopkins, IEEE Trans. PAS 87, 1968), [-]."""
    return 2.0 / np.pi * np.arctan(0.5 * np.pi * np.asarray(x, dtype=float))


def arctangent_inverse(y: float) -> float:
    """x with arctangent(x) = y, |y| < 1, [-]."""
    return 2.0 / np.pi * math.tan(0.5 * np.pi * y)


def mean_field_langevin(x, coupling: float):
    """m solving m = L(3 ((1 - alpha) x + alpha m)): the Langevin law with the domains'
    mean field alpha m (Weiss; Jiles and Atherton, JMMM 61, 1986, eq 2), scaled so its slope
    at 0 is 1; 0 <= alpha < 1 keeps it single-valued (the right side's slope in m is at most
    alpha). Bisection on [-1, 1] (the right side minus m falls monotonically), [-]."""
    x = np.asarray(x, dtype=float)
    lo, hi = -np.ones_like(x), np.ones_like(x)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = langevin(3.0 * ((1.0 - coupling) * x + coupling * mid)) > mid
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    return 0.5 * (lo + hi)
