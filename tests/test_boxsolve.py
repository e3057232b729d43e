"""Bounded linear least squares (smeha.diagnose.boxsolve) against scipy's bvls.

The reference is an implementation that shares nothing with the one tested: scipy's
``lsq_linear(method="bvls")`` (Stark & Parker, Comput. Stat. 10 (1995) 129-141), an
active-set method on A itself with an SVD least-squares solve per iteration. The problems
have the shape of the joint steps' (smeha.diagnose.linearfit._joint): a few box-bounded
unknowns, many nonnegative ones with no upper bound, a damping row per column, so the
minimiser is unique. Tolerances: both end at the exact minimiser up to rounding; the
objectives agree to 1e-10 relative, the solutions to 1e-6 of their largest entry (the
damped problems' condition numbers are ~1e2, 1e4 in the normal equations).
"""
import numpy as np
import pytest
from scipy.optimize import lsq_linear

from smeha.diagnose.boxsolve import bounded_least_squares


def _problem(seed, rows=120, boxed=6, weights=40, damping=1e-2):
    rng = np.random.default_rng(seed)
    n = boxed + weights
    a = rng.normal(size=(rows, n)) * np.exp(rng.normal(scale=1.0, size=n))
    a = np.vstack((a, np.sqrt(damping) * np.diag(np.linalg.norm(a, axis=0))))
    truth = np.concatenate((rng.normal(size=boxed), np.where(rng.random(weights) < 0.5, 0.0,
                                                             rng.exponential(size=weights))))
    b = a @ truth + rng.normal(scale=0.3, size=a.shape[0])
    lower = np.concatenate((np.full(boxed, -0.5), np.zeros(weights)))
    upper = np.concatenate((np.full(boxed, 0.5), np.full(weights, np.inf)))
    return a, b, lower, upper


@pytest.mark.parametrize("seed", range(12))
def test_same_minimiser_as_bvls(seed):
    a, b, lower, upper = _problem(seed)
    ref = lsq_linear(a, b, bounds=(lower, upper), method="bvls").x
    v = bounded_least_squares(a, b, lower, upper)
    assert np.all(v >= lower) and np.all(v <= upper)
    f_ref, f = np.sum((a @ ref - b) ** 2), np.sum((a @ v - b) ** 2)
    assert f == pytest.approx(f_ref, rel=1e-10)
    assert np.max(np.abs(v - ref)) <= 1e-6 * np.max(np.abs(ref))
    # and many of the bounds are active there (the case the method is for)
    assert np.sum((v == lower) | (v == upper)) >= 5


def test_karush_kuhn_tucker_conditions_hold():
    # at the minimiser the gradient A^T (A v - b) is zero on the free unknowns, >= 0 on
    # those at their lower bound and <= 0 at their upper (Nocedal & Wright 2006, sec. 16.5)
    a, b, lower, upper = _problem(3)
    v = bounded_least_squares(a, b, lower, upper)
    grad = a.T @ (a @ v - b)
    scale = np.abs(a.T @ b).max()
    at_lo, at_hi = v == lower, v == upper
    free = ~(at_lo | at_hi)
    assert np.all(np.abs(grad[free]) <= 1e-9 * scale)
    assert np.all(grad[at_lo] >= -1e-9 * scale)
    assert np.all(grad[at_hi] <= 1e-9 * scale)


def test_unbounded_problem_is_ordinary_least_squares():
    a, b, _, _ = _problem(5)
    v = bounded_least_squares(a, b, -np.inf, np.inf)
    assert np.allclose(v, np.linalg.lstsq(a, b, rcond=None)[0], rtol=1e-9, atol=1e-12)


def test_rank_deficient_problem_falls_back_to_bvls():
    # two equal columns: A^T A is singular, no Cholesky factor; scipy's bvls solves it
    a = np.array([[1.0, 1.0], [2.0, 2.0], [0.5, 0.5]])
    b = np.array([1.0, 2.0, 0.5])
    v = bounded_least_squares(a, b, 0.0, np.inf)
    assert np.sum((a @ v - b) ** 2) == pytest.approx(0.0, abs=1e-20)
    assert np.all(v >= 0.0)


def test_crossed_bounds_are_refused():
    with pytest.raises(ValueError, match="lower bound above its upper"):
        bounded_least_squares(np.eye(2), np.ones(2), [0.0, 1.0], [1.0, 0.0])
