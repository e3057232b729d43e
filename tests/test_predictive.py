"""The predictive chi^2 of a fit (smeha.diagnose.fit.predictive_chi2).

Reference: for residuals r(z) = A z - d, linear in the unknowns, the held-out residuals of
a fit with covariance Cov have the covariance I + A Cov A^T, and the predictive chi^2 is
r^T (I + A Cov A^T)^-1 r (Seber & Wild, *Nonlinear Regression*, Wiley 1989, sec. 5.1).
Here it is computed from A directly, with numpy's solve, not by the function's finite
differences; residuals linear in z make the finite differences exact to rounding (rtol
1e-7: a step of 1e-6 relative on values of order 1, the difference quotient exact for a
linear map but rounded at ~1e-16 / 1e-6).
"""
from __future__ import annotations

import numpy as np

from smeha.diagnose.fit import BASE_LOWER, base_factor, predictive_chi2

NB = len(BASE_LOWER)


class _LinearEvaluator:
    """Residuals A z - d in the fit's scaled unknowns z (base over base_factor, then x)."""

    def __init__(self, a, d, base):
        self.a, self.d, self.factor = a, d, base_factor(base)

    def residuals(self, held, base, cand, x):
        z = np.concatenate((np.asarray(base[:NB]) / self.factor[:NB], np.asarray(x)))
        return self.a @ z - self.d

    def residuals_stacked(self, held, points, cand):
        return np.array([self.residuals(held, b, cand, x) for b, x in points])


class _Candidate:
    def __init__(self, n):
        self.upper = (np.inf,) * n


def _case(seed, pinned):
    rng = np.random.default_rng(seed)
    base = (2.0, 1.6, 3.0, 0.5, 1.1)
    x = tuple(rng.uniform(0.1, 1.0, 6))
    nz = NB + len(x)
    a = rng.normal(size=(40, nz))
    d = rng.normal(size=40)
    m = rng.normal(size=(nz, nz))
    cov = 0.01 * m @ m.T
    for j in pinned:  # an unknown the fit held: its row and column of cov are zero
        cov[j, :] = 0.0
        cov[:, j] = 0.0
    ev = _LinearEvaluator(a, d, base)
    z = np.concatenate((np.asarray(base) / ev.factor, x))
    r = a @ z - d
    direct = float(r @ np.linalg.solve(np.eye(r.size) + a @ cov @ a.T, r))
    return predictive_chi2(ev, None, _Candidate(len(x)), base, x, cov), direct


def test_predictive_chi2_is_that_of_the_linearised_fit():
    got, direct = _case(1, pinned=())
    np.testing.assert_allclose(got, direct, rtol=1e-7)


def test_an_unknown_held_by_the_fit_adds_nothing_to_the_predictive_chi2():
    # a density's weights at zero are pinned (smeha.diagnose.linearfit): their columns
    # are not evaluated, and the figure is that of the full formula
    got, direct = _case(2, pinned=(NB + 1, NB + 4))
    np.testing.assert_allclose(got, direct, rtol=1e-7)
