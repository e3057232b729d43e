"""Small numerical tools of the time-stepped extensions, in numpy only.

The FMU's run-time path imports numpy and nothing else (no scipy, no
python-control), so the few things the step forms need from numerical
libraries are written here, each with its textbook source:

* :func:`nnls` -- non-negative least squares, the active-set algorithm of
  C. L. Lawson and R. J. Hanson, *Solving Least Squares Problems*,
  Prentice-Hall 1974 (SIAM reprint 1995), ch. 23;
* :func:`expm` -- the matrix exponential by scaling and squaring of a
  truncated Taylor series (C. Moler, C. Van Loan, "Nineteen dubious ways to
  compute the exponential of a matrix, twenty-five years later", SIAM Review
  45 (2003) 3-49, methods 1 and 3);
* :func:`bessel_j0_zeros` -- the positive zeros j_{0,n} of J_0, by Newton's
  method on Bessel's integral J_n(x) = (1/pi) int_0^pi cos(n t - x sin t) dt
  (Abramowitz & Stegun 9.1.21), evaluated by the trapezoid rule, which
  converges geometrically for this periodic analytic integrand, from
  McMahon's asymptotic start (A&S 9.5.12);
* :func:`bessel_i1_over_i0` -- I_1(z)/I_0(z) for complex z with Re z >= 0,
  from the continued fraction of the ratio of modified Bessel functions
  (A&S 9.6.26 recurrence; Gauss's continued fraction), evaluated backwards.

Each is checked against scipy in ``tests/test_extensions_numerics.py``.
"""
from __future__ import annotations

import math

import numpy as np


def nnls(a, b, max_iterations=None):
    """x >= 0 minimising ||a x - b||_2 (Lawson & Hanson 1974, algorithm NNLS).

    Parameters
    ----------
    a : array, shape (m, n)
    b : array, shape (m,)
    max_iterations : int, optional
        Outer iterations before giving up (default 3 n).

    Returns
    -------
    (array, float)
        x and the residual norm ||a x - b||.

    Examples
    --------
    >>> x, r = nnls(np.eye(2), np.array([1.0, -1.0]))
    >>> x.tolist(), round(r, 12)
    ([1.0, 0.0], 1.0)
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    m, n = a.shape
    x = np.zeros(n)
    passive = np.zeros(n, dtype=bool)
    tol = 10.0 * np.finfo(float).eps * np.linalg.norm(a, 1) * max(m, n)
    limit = 3 * n if max_iterations is None else int(max_iterations)

    def solve(mask):
        z = np.zeros(n)
        z[mask] = np.linalg.lstsq(a[:, mask], b, rcond=None)[0]
        return z

    for _ in range(limit):
        w = a.T @ (b - a @ x)
        w[passive] = -np.inf
        while True:
            j = int(np.argmax(w))
            if not w[j] > tol:
                return x, float(np.linalg.norm(a @ x - b))
            z = solve(passive | (np.arange(n) == j))
            if z[j] > 0.0:  # in exact arithmetic always; rounding may deny it (L&H 23.3)
                break
            w[j] = -np.inf
        passive[j] = True
        while True:
            if np.all(z[passive] > 0.0):
                x = z
                break
            # step back to the boundary of the feasible region and drop what hits zero
            neg = passive & (z <= 0.0)
            gap = x[neg] - z[neg]
            alpha = float(np.min(np.where(gap > 0.0, x[neg] / np.where(gap > 0.0, gap, 1.0),
                                          0.0)))
            x = x + alpha * (z - x)
            passive &= x > 1e-15 * np.abs(x).max()
            x[~passive] = 0.0
            z = solve(passive)
    return x, float(np.linalg.norm(a @ x - b))


def expm(matrix):
    """e^A of a small square matrix (scaling and squaring of the Taylor series).

    A is scaled by 2^-s so that its 1-norm is at most 1/2, the series is
    summed until its terms fall below machine precision of the sum (at most
    30 terms; the truncation error is then below 1e-17 relative), and the
    result is squared s times (Moler & Van Loan 2003, methods 1 and 3).
    Accurate to about 1e-14 relative for the well-scaled systems here.

    Examples
    --------
    >>> bool(np.allclose(expm(np.array([[0.0, 1.0], [-1.0, 0.0]])),
    ...                  [[math.cos(1), math.sin(1)], [-math.sin(1), math.cos(1)]]))
    True
    """
    a = np.asarray(matrix, dtype=float)
    norm = float(np.abs(a).sum(axis=0).max()) if a.size else 0.0
    s = max(0, int(math.ceil(math.log2(norm / 0.5)))) if norm > 0.5 else 0
    a = a / (2.0 ** s)
    result = np.eye(a.shape[0])
    term = np.eye(a.shape[0])
    for k in range(1, 31):
        term = term @ a / k
        result = result + term
        if np.abs(term).max() <= 1e-18 * np.abs(result).max():
            break
    for _ in range(s):
        result = result @ result
    return result


def _bessel_j(order, x):
    """J_order(x) for integer order and real x by Bessel's integral (A&S 9.1.21), array x."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    # trapezoid rule on [0, pi] of a periodic analytic integrand: exact to rounding once
    # the number of nodes exceeds |x| + order + ~30
    nodes = int(np.max(np.abs(x))) + order + 40
    t = (np.arange(nodes) + 0.5) * math.pi / nodes
    return np.cos(order * t[None, :] - x[:, None] * np.sin(t)[None, :]).mean(axis=1)


def bessel_j0_zeros(count):
    """The first ``count`` positive zeros j_{0,n} of J_0, [-].

    McMahon's expansion (A&S 9.5.12) with beta = (n - 1/4) pi,
    j ~ beta + 1/(8 beta) - 124/(3 (8 beta)^3), starts Newton's iteration
    x <- x + J_0(x)/J_1(x) (J_0' = -J_1), which converges to rounding in a few
    steps (j_{0,1} = 2.404825557695773, A&S Table 9.5).

    Examples
    --------
    >>> round(float(bessel_j0_zeros(1)[0]), 12)
    2.404825557696
    """
    n = np.arange(1, int(count) + 1, dtype=float)
    beta = (n - 0.25) * math.pi
    x = beta + 1.0 / (8.0 * beta) - 124.0 / (3.0 * (8.0 * beta) ** 3)
    for _ in range(8):
        dx = _bessel_j(0, x) / _bessel_j(1, x)
        x = x + dx
        if np.max(np.abs(dx)) < 1e-15 * np.max(x):
            break
    return x


def bessel_i1_over_i0(z):
    """I_1(z)/I_0(z) for complex z with Re z >= 0, [-] (no overflow for large |z|).

    From the recurrence I_{k-1}(z) - I_{k+1}(z) = (2k/z) I_k(z) (A&S 9.6.26),
    r_k = I_k/I_{k-1} obeys r_k = 1 / (2k/z + r_{k+1}): Gauss's continued
    fraction, evaluated backwards from r_K = 0 with K above |z| + 60, where
    the tail is negligible (the minimal solution of the recurrence).

    Examples
    --------
    >>> # I_1(1) / I_0(1) = 0.5651591040 / 1.2660658778 (A&S Table 9.8)
    >>> bool(abs(bessel_i1_over_i0(1.0) - 0.5651591040 / 1.2660658778) < 1e-10)
    True
    """
    z = np.asarray(z, dtype=complex)
    flat = np.atleast_1d(z).ravel()
    out = np.zeros(flat.shape, dtype=complex)
    small = np.abs(flat) < 1e-300
    zs = np.where(small, 1.0, flat)
    depth = int(np.max(np.abs(zs))) + 60 if zs.size else 60
    r = np.zeros(zs.shape, dtype=complex)
    for k in range(depth, 0, -1):
        r = 1.0 / (2.0 * k / zs + r)
    out = np.where(small, flat / 2.0, r)
    return out.reshape(z.shape) if z.shape else complex(out[0])
