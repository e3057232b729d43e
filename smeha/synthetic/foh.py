"""Linear systems driven by a signal linear between samples (first-order hold), exactly.

The generator's mechanics (eq 27 and the two-mass model) and its slab diffusion are
linear; each is integrated mode by mode for an input linear between the samples.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

__all__ = ["foh_response"]

def foh_response(a, b, c, u, step, x0=None):
    """Output c x_k of dx/dt = a x + b u(t) for u linear between samples, x(0) = x0.

    Exact first-order-hold integration, mode by mode (a = V diag(lam) V^-1,
    possibly complex): z' = lam z + g u gives z_{k+1} = e^{lam h} z_k
    + g (P0 - P1) u_k + g P1 u_{k+1}, with P0 = (e^{lam h} - 1)/lam and
    P1 = (e^{lam h} - 1 - lam h)/(lam^2 h); each mode is one
    :func:`scipy.signal.lfilter`. ``c`` may be a matrix (several outputs).
    """
    u = np.asarray(u, dtype=float)
    lam, vec = np.linalg.eig(np.asarray(a, dtype=float))
    g = np.linalg.solve(vec, np.asarray(b, dtype=complex))
    z0 = (np.zeros(lam.size, complex) if x0 is None
          else np.linalg.solve(vec, np.asarray(x0, dtype=complex)))
    x = lam * step
    em1 = np.expm1(x)
    p0 = em1 / lam
    small = np.abs(x) < 1e-3
    p1 = np.where(small, step * (0.5 + x / 6.0 + x * x / 24.0),
                  (em1 - x) / np.where(small, 1.0, lam * lam * step))
    cv = np.atleast_2d(np.asarray(c, dtype=float)) @ vec
    out = np.zeros((cv.shape[0], u.size))
    for i in range(lam.size):
        b1, b0 = g[i] * p1[i], g[i] * (p0[i] - p1[i])
        # z_k = e^{lam h} z_{k-1} + b1 u_k + b0 u_{k-1}; DF-II transposed: z_0 = b1 u_0 + zi
        zi = lfilter([b1, b0], [1.0, -np.exp(x[i])], u, zi=[z0[i] - b1 * u[0]])[0]
        out += (cv[:, i:i + 1] * zi).real
    return out if np.ndim(c) == 2 else out[0]
