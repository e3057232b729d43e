"""Bounded linear least squares in its normal equations: the joint steps' solver.

The damped Gauss-Newton steps of :func:`smeha.diagnose.linearfit._joint` each solve

    min_v ||A v - b||^2   subject to   l <= v <= u,

A with a few hundred columns (the density's node weights and the other unknowns) and a
damping row for every column, so that A^T A is positive definite and the minimiser is
unique. Written as the quadratic program min 1/2 v^T H v - g^T v (H = A^T A, g = A^T b),
it is solved here by a primal active-set method (Nocedal & Wright, *Numerical
Optimization*, 2nd ed., 2006, sec. 16.5; for bounds alone the constraint matrix is the
identity): each iterate is feasible; the variables not on a bound solve the equality
problem by a Cholesky factorisation of their block of H; a step that would pass a bound
stops there and fixes that variable; at a minimiser over the free set the bound
variable whose multiplier has the wrong sign (the gradient pointing inwards) is freed,
and the method ends when none has. It starts from the unconstrained minimiser clipped
to the bounds, so that the variables far inside stay free from the first iteration.

The same minimiser as scipy's bounded-variable least squares (``lsq_linear(...,
method="bvls")``; Stark & Parker, Comput. Stat. 10 (1995) 129-141), which works on A
itself and solves a least-squares problem by SVD at each of its iterations; on the
joint steps of labsim's Preisach hysteresis (ten problems of 790 x 216) the objectives
agree to 3e-13 and the solutions to 1.5e-8 of the largest value, and it takes a quarter
of bvls's time (a third over 200 problems of the density with eddy diffusion, where bvls
stops short by up to 1.5e-10 of the objective; ``benchmarks/bounded_solve.py``).
Squaring A squares its condition number: the joint steps scale each column by its
damped norm, floored, which holds it near 1e2 (:func:`smeha.diagnose.linearfit._joint`),
1e4 for H. Where H is not positive definite to working precision, or the active set
does not settle within its iteration limit, scipy's bvls solves the problem from A.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

__all__ = ["ITERATIONS_PER_VARIABLE", "bounded_least_squares"]

#: Active-set changes allowed per variable before the fallback to scipy's bvls.
ITERATIONS_PER_VARIABLE = 10


def bounded_least_squares(a, b, lower, upper) -> np.ndarray:
    """argmin ||a v - b||^2 with ``lower`` <= v <= ``upper`` (module docstring).

    Parameters
    ----------
    a : array (rows, n)
    b : array (rows,)
    lower, upper : arrays (n,) or scalars
        Bounds, -inf / inf allowed, lower <= upper.

    Examples
    --------
    >>> v = bounded_least_squares(np.eye(2), np.array([2.0, -1.0]), 0.0, 1.0)
    >>> [float(x) for x in v]
    [1.0, 0.0]
    """
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    n = a.shape[1]
    lo = np.broadcast_to(np.asarray(lower, float), (n,)).copy()
    hi = np.broadcast_to(np.asarray(upper, float), (n,)).copy()
    if np.any(lo > hi):
        raise ValueError("bounded_least_squares: a lower bound above its upper bound")
    try:
        v = _active_set(a.T @ a, a.T @ b, lo, hi)
    except LinAlgError:
        v = None
    if v is None:
        from scipy.optimize import lsq_linear

        v = lsq_linear(a, b, bounds=(lo, hi), method="bvls").x
    return v


def _solve_free(h, g, v, free):
    """The minimiser over the ``free`` variables, the others held at ``v``."""
    fixed = ~free
    rhs = g[free] - h[np.ix_(free, fixed)] @ v[fixed]
    return cho_solve(cho_factor(h[np.ix_(free, free)]), rhs)


def _active_set(h, g, lo, hi):
    """The primal active-set iteration (module docstring); None where it does not settle
    within :data:`ITERATIONS_PER_VARIABLE` per variable."""
    n = g.size
    side = np.zeros(n, np.int8)  # -1 on the lower bound, +1 on the upper, 0 free
    v = cho_solve(cho_factor(h), g)
    side[v < lo] = -1
    side[v > hi] = 1
    v = np.clip(v, lo, hi)
    # the multipliers' test: a gradient entry below this is zero (rounding)
    tiny = 1e-13 * (np.abs(g).max() + np.abs(h).max() * max(np.abs(v).max(), 1.0))
    for _ in range(ITERATIONS_PER_VARIABLE * n):
        free = side == 0
        if np.any(free):
            s = _solve_free(h, g, v, free)
            d = s - v[free]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(d < 0, (lo[free] - v[free]) / d,
                                 np.where(d > 0, (hi[free] - v[free]) / d, np.inf))
            step = min(1.0, float(ratio.min())) if ratio.size else 1.0
            step = max(step, 0.0)
            v[free] = v[free] + step * d
            if step < 1.0:
                # the variables whose bound stopped the step are fixed on it
                idx = np.flatnonzero(free)[ratio <= step]
                side[idx] = np.where(d[ratio <= step] < 0, -1, 1)
                v[idx] = np.where(side[idx] < 0, lo[idx], hi[idx])
                continue
        grad = h @ v - g
        # a variable on its lower bound leaves it where the gradient is negative, on its
        # upper bound where it is positive: the most negative multiplier is freed
        pull = np.where(side < 0, -grad, np.where(side > 0, grad, 0.0))
        j = int(np.argmax(pull))
        if pull[j] <= tiny:
            return v
        side[j] = 0
    return None
