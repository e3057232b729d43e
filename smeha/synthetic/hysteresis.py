"""Truth of ``rate_independent_hysteresis``: a classical Preisach operator.

Relays +-1 over the Preisach half-plane with a lognormal-coercivity x Gaussian-interaction
density, evaluated through its Everett function (I. D. Mayergoyz, *Mathematical Models of
Hysteresis*, Springer 1991, ch. 1; X. Tan, J. S. Baras, Automatica 40 (2004) 1469-1480).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr

__all__ = ["preisach"]

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(48)


def _everett(alpha, beta, coercive_field, log_spread, interaction_spread):
    """Everett function F(alpha, beta) of the Preisach density, [-].

    The density over the Preisach half-plane alpha >= beta is factorised in the
    coercive field r = (alpha - beta)/2 (lognormal, median ``coercive_field``,
    log-spread ``log_spread``) and the interaction field u = (alpha + beta)/2
    (Gaussian, zero mean, ``interaction_spread``), normalised to 1 over the half
    plane (Mayergoyz 1991, sec. 1.2; the factorised form is Della Torre's).
    F(alpha, beta) is its integral over the triangle beta <= beta' <= alpha' <=
    alpha, i.e. over 0 <= r' <= R, |u' - c| <= R - r' with R = (alpha - beta)/2,
    c = (alpha + beta)/2:

        F = int_0^R w(r') [Phi((c + R - r')/s_u) - Phi((c - R + r')/s_u)] dr',

    evaluated by 48-point Gauss-Legendre quadrature in r' (in log r', where the
    lognormal is smooth). Vectorised over ``alpha``, ``beta``.
    """
    a = np.asarray(alpha, dtype=float)
    b = np.asarray(beta, dtype=float)
    big_r = np.maximum(0.5 * (a - b), 0.0)
    c = 0.5 * (a + b)
    # quadrature in z = ln r' over [ln r_lo, ln R]; below r_lo = r0 e^{-8 s} the
    # lognormal has no mass
    z_lo = math.log(coercive_field) - 8.0 * log_spread
    z_hi = np.log(np.maximum(big_r, 1e-300))
    valid = z_hi > z_lo
    z_hi = np.where(valid, z_hi, z_lo)
    half = 0.5 * (z_hi - z_lo)
    mid = 0.5 * (z_hi + z_lo)
    z = mid[..., None] + half[..., None] * _GL_NODES
    r = np.exp(z)
    # w(r) dr = lognormal pdf in z: N(z; ln r0, s) dz
    wz = np.exp(-0.5 * ((z - math.log(coercive_field)) / log_spread) ** 2) / (
        log_spread * math.sqrt(2.0 * math.pi))
    reach = big_r[..., None] - r
    inner = (ndtr((c[..., None] + reach) / interaction_spread)
             - ndtr((c[..., None] - reach) / interaction_spread))
    out = half * np.sum(_GL_WEIGHTS * wz * inner, axis=-1)
    return np.where(valid, out, 0.0)



class _DominantExtrema:
    """The memory of dominant extrema of a Preisach operator (Mayergoyz 1991, sec. 1.3).

    ``turning`` holds the stored turning values, alternating min, max, min, ...,
    starting with the sentinel -limit (negative saturation, never removed), and
    ``measure`` mu(S+) at each of them; ``rising`` is the input's direction and
    ``last`` its last value.
    """

    def __init__(self, limit, density):
        self.turning = [-limit]
        self.measure = [0.0]
        self.rising = True
        self.last = -limit
        self.density = density

    def move(self, u):
        """Feed the input value ``u``: store the extremum it ends, wipe out those it passes."""
        ext, mus, dens, last = self.turning, self.measure, self.density, self.last
        if u > last and not self.rising:  # a fall ended at `last`: a new minimum
            mus.append(mus[-1] - float(_everett(ext[-1], last, *dens)))
            ext.append(last)
            self.rising = True
        elif u < last and self.rising:  # a rise ended at `last`: a new maximum
            if len(ext) > 0 and last > ext[-1]:
                mus.append(mus[-1] + float(_everett(last, ext[-1], *dens)))
                ext.append(last)
            self.rising = False
        # wiping out (the sentinel -limit is never removed)
        if self.rising:
            while len(ext) >= 3 and u >= ext[-2]:
                del ext[-2:], mus[-2:]
        else:
            while len(ext) >= 3 and u <= ext[-2]:
                del ext[-2:], mus[-2:]
        self.last = u


def preisach(field, *, coercive_field, coercive_log_spread, interaction_spread,
             limit=None, demagnetisation_steps=64, history=()):
    """Output of a classical Preisach operator with relays +-1, in [-1, 1].

    Parameters
    ----------
    field : array
        Input H_k, [A/m], sample by sample (rate independent: only the order
        of values matters).
    coercive_field, coercive_log_spread, interaction_spread
        The density, see :func:`_everett`.
    limit : float, optional
        The Preisach triangle is alpha, beta in [-limit, limit], [A/m]
        (default: far beyond the density, r0 e^{4 s} + 6 s_u).
    demagnetisation_steps : int
        The operator starts from the AC-demagnetised state, made by the
        alternating extrema +-limit (1 - j/J), j = 0 ... J - 1.
    history : sequence of float
        Extra turning points fed after demagnetisation, before ``field``
        (e.g. one period of the excitation, so the run starts on its loop).

    Notes
    -----
    The relays' state is the staircase of the memory of dominant extrema
    (Mayergoyz 1991, sec. 1.3): a rise above a stored maximum wipes it out
    with the minimum that follows it, a fall below a stored minimum likewise.
    With S+ the region of relays at +1, the output is 2 mu(S+) - mu(T), and
    mu(S+) is a sum of Everett functions over the memory: at a maximum M
    reached from the minimum m, mu(S+) grows by F(M, m); at a minimum m'
    reached from M it falls by F(M, m'). The loop here only keeps the memory;
    the Everett functions are then evaluated vectorised.
    """
    h = np.asarray(field, dtype=float)
    dens = (coercive_field, coercive_log_spread, interaction_spread)
    if limit is None:
        limit = coercive_field * math.exp(4.0 * coercive_log_spread) + 6.0 * interaction_spread
    h = np.clip(h, -limit, limit)
    # the memory starts at negative saturation, then is AC-demagnetised
    memory = _DominantExtrema(limit, dens)
    turning = [limit * (1.0 - j / demagnetisation_steps) * (-1.0) ** j
               for j in range(demagnetisation_steps)]
    for u in list(turning) + [float(x) for x in history]:
        memory.move(u)
    base = np.empty(h.size)
    arg_a = np.empty(h.size)
    arg_b = np.empty(h.size)
    sign = np.empty(h.size)
    for k, u in enumerate(h.tolist()):
        memory.move(u)
        base[k] = memory.measure[-1]
        if memory.rising:  # mu(S+) = mu(at last minimum) + F(u, m)
            arg_a[k], arg_b[k], sign[k] = u, memory.turning[-1], 1.0
        else:  # mu(S+) = mu(at last maximum) - F(M, u)
            arg_a[k], arg_b[k], sign[k] = memory.turning[-1], u, -1.0
    mu_plus = base + sign * _everett(arg_a, arg_b, *dens)
    total = float(_everett(limit, -limit, *dens))
    return 2.0 * mu_plus - total
