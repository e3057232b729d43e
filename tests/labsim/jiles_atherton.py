"""Rate-independent hysteresis after Jiles and Atherton: pinned domain walls.

Jiles and Atherton (J. Magn. Magn. Mater. 61, 1986, 48-60) split the magnetisation into an
irreversible part, held back by the pinning of domain walls, and a reversible part from wall
bowing:

    M = c M_an(H) + (1 - c) M_irr,
    dM_irr/dH = (M_an(H) - M_irr) / (delta k)   while delta (M_an - M_irr) > 0, else 0,

with delta = sign(dH/dt), k the pinning parameter (a field, [A/m]), c the reversibility
(0..1) and M_an(H) = M_s L(H / a) the Langevin anhysteretic (``anhysteretic``). The second
line is the usual repair of the model's negative irreversible susceptibility after reversals
(discussed e.g. by Zirka, Moroz, Harrison and Chwastek, J. Appl. Phys. 112, 2012, 043916):
after a reversal M_irr stays put until M_an has crossed it. The mean-field coupling alpha of
the 1986 paper is left out (alpha = 0): this component is a small part of the rod's
magnetisation, added to the paper's (see README.md).

Only the sequence of field values counts (rate independence), so each monotone stretch of
the field is integrated in H itself: the frozen part is constant, the moving part is a linear
first-order law in H, solved by its integrating factor with Gauss-Legendre quadrature
(``_relax``). The field is H = H_0 + u with u the applied AC field and H_0 an offset of the
wall population's operating point on M_an (H_0 != 0 makes the loops asymmetric); before the
drive the state is the one reached by raising H from 0 to H_0 from the demagnetised state,
and the output is M(t) - M(0-).

Energy balance (Jiles and Atherton 1986): where M_irr moves, M_an - M_irr = delta k
dM_irr/dH, so over a closed cycle oint (M_an - M_irr) dH = k oint |dM_irr| plus the integral
over the frozen stretches; with oint M_an dH = 0 this is the loop area of M_irr, and (1 - c)
times it that of M (tested).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .anhysteretic import langevin
from .hysteresis import monotone_runs

#: The periodic loop is converged when the irreversible state at the crest moves less than
#: this times M_s from one cycle to the next, [-].
CYCLE_TOLERANCE = 1e-14


@dataclass(frozen=True)
class Model:
    """Jiles-Atherton parameters (SI)."""

    saturation: float  # M_s of the wall population, [A/m]
    shape: float  # a of the Langevin anhysteretic, [A/m]
    pinning: float  # k, [A/m]
    reversibility: float  # c, [-]
    offset: float  # H_0, [A/m]

    def anhysteretic(self, h):
        """M_an(H) = M_s L(H / a), [A/m]."""
        return self.saturation * langevin(np.asarray(h, dtype=float) / self.shape)

    def total(self, h, m_irr):
        """M = c M_an(H) + (1 - c) M_irr, [A/m]."""
        c = self.reversibility
        return c * self.anhysteretic(h) + (1.0 - c) * np.asarray(m_irr)

    def bias_state(self) -> float:
        """M_irr after H rose from 0 to H_0 from the demagnetised state, [A/m]."""
        return branch(self, 0.0, 0.0, self.offset)[0]


def branch(model: Model, h_start: float, m_start: float, h_end: float, h_eval=None):
    """Irreversible magnetisation along a monotone field stretch h_start -> h_end.

    Returns (M_irr at h_end, M_irr at the fields h_eval, which lie between the two ends).
    """
    h_eval = np.zeros(0) if h_eval is None else np.asarray(h_eval, dtype=float)
    values = np.full(h_eval.shape, float(m_start))
    if h_end == h_start:
        return float(m_start), values
    delta = 1.0 if h_end > h_start else -1.0
    gap_start = delta * (float(model.anhysteretic(h_start)) - m_start)
    gap_end = delta * (float(model.anhysteretic(h_end)) - m_start)
    if gap_start > 0.0:
        h_x = h_start
    elif gap_end <= 0.0:  # M_an never crosses M_irr: frozen all along
        return float(m_start), values
    else:
        h_x = brentq(lambda h: float(model.anhysteretic(h)) - m_start, h_start, h_end,
                     xtol=1e-13 * model.shape, rtol=4 * np.finfo(float).eps)
    xi_eval = delta * (h_eval - h_x)  # distance moved since M_irr started to move, >= 0
    moving = xi_eval > 0.0
    xi = np.append(xi_eval[moving], delta * (h_end - h_x))
    m = _relax(model, h_x, float(m_start), delta, xi)
    values[moving] = m[:-1]
    return float(m[-1]), values


def _relax(model: Model, h_x: float, m_x: float, delta: float, xi: np.ndarray) -> np.ndarray:
    """M_irr at distances xi >= 0 along the field from h_x, where it starts moving.

    In xi = delta (H - h_x) the law reads dM_irr/dxi = (M_an - M_irr) / k for both directions,
    so M_irr(xi) = exp(-xi/k) [m_x + int_0^xi exp(sigma/k) M_an(h_x + delta sigma) dsigma / k]:
    the integral by 8-point Gauss-Legendre on panels no wider than a quarter of k and of a
    (error far below 1e-14 for the analytic integrand), accumulated over the sorted points.
    """
    k, a = model.pinning, model.shape
    top = float(np.max(xi))
    if top > 200.0 * k:  # keep exp(xi/k) far from overflow: restart halfway
        half = 0.5 * top
        m_half = _relax(model, h_x, m_x, delta, np.array([half]))[0]
        first = xi <= half
        out = np.empty(xi.size)
        out[first] = _relax(model, h_x, m_x, delta, xi[first]) if np.any(first) else 0.0
        out[~first] = _relax(model, h_x + delta * half, m_half, delta, xi[~first] - half)
        return out
    panels = max(1, int(math.ceil(top / (0.25 * min(k, a)))))
    nodes = np.union1d(np.concatenate([[0.0], xi]), np.linspace(0.0, top, panels + 1))
    left, right = nodes[:-1], nodes[1:]
    mid, half_width = 0.5 * (left + right), 0.5 * (right - left)
    sigma = mid[:, None] + half_width[:, None] * _GL_NODES[None, :]
    integrand = np.exp(sigma / k) * model.anhysteretic(h_x + delta * sigma) / k
    pieces = half_width * (integrand @ _GL_WEIGHTS)
    at_nodes = np.exp(-nodes / k) * (m_x + np.concatenate([[0.0], np.cumsum(pieces)]))
    return at_nodes[np.searchsorted(nodes, xi)]


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(8)


def sequence(model: Model, u: np.ndarray) -> np.ndarray:
    """M(t) - M(0-) at the samples of the applied field u (0 before u_0), [A/m]."""
    u = np.asarray(u, dtype=float)
    h0 = model.offset
    m_irr = model.bias_state()
    before = float(model.total(h0, m_irr))
    h_now = h0
    out = np.empty(u.size)
    for idx, _rising, extremum in monotone_runs(u):
        h_turn = h0 + extremum
        m_end, out[idx] = branch(model, h_now, m_irr, h_turn, h0 + u[idx])
        out[idx] = model.total(h0 + u[idx], out[idx]) - before
        h_now, m_irr = h_turn, m_end
    return out


def _cycle(model: Model, amplitude: float, m_crest: float) -> tuple[float, float]:
    """From the crest H_0 + A down to H_0 - A and up again: (M_irr at the trough, at the crest)."""
    h0 = model.offset
    m_trough = branch(model, h0 + amplitude, m_crest, h0 - amplitude)[0]
    return m_trough, branch(model, h0 - amplitude, m_trough, h0 + amplitude)[0]


@dataclass(frozen=True)
class Loop:
    """The periodic state for u = A cos(phase): irreversible magnetisation at the crest and the
    trough, and how fast a deviation from it dies out."""

    amplitude: float  # A, [A/m]
    crest: float  # M_irr at H_0 + A, [A/m]
    trough: float  # M_irr at H_0 - A, [A/m]
    first_deviation: float  # |M_irr at the first crest - crest|, [A/m]
    contraction: float  # factor of a crest deviation per cycle, [-]

    def cycles_to_settle(self, model: Model, tolerance: float = 1e-15) -> int:
        """Cycles after the first crest until a deviation is below tolerance x M_s."""
        floor = tolerance * model.saturation
        if self.first_deviation <= floor or self.contraction <= 0.0:
            return 0
        if self.contraction >= 1.0:
            raise ValueError("Jiles-Atherton loop does not converge")
        return int(math.ceil(math.log(floor / self.first_deviation) / math.log(self.contraction)))


def periodic_loop(model: Model, amplitude: float) -> Loop:
    """The closed loop reached under u = A cos: the fixed point of the crest-to-crest map
    g (a contraction), by secant steps on g(x) - x from the first crest."""
    h0 = model.offset
    first = branch(model, h0, model.bias_state(), h0 + amplitude)[0]
    floor = CYCLE_TOLERANCE * model.saturation
    x_a = first
    f_a = _cycle(model, amplitude, x_a)[1] - x_a
    x_b = x_a + f_a
    for _ in range(100):
        f_b = _cycle(model, amplitude, x_b)[1] - x_b
        if abs(f_b) <= floor or f_b == f_a:
            break
        x_a, f_a, x_b = x_b, f_b, x_b - f_b * (x_b - x_a) / (f_b - f_a)
    else:
        raise ValueError(f"Jiles-Atherton loop at amplitude {amplitude} A/m did not converge")
    trough, crest = _cycle(model, amplitude, x_b)
    # contraction per cycle: the map's slope at the fixed point, by a small perturbation
    step = 1e-6 * model.saturation
    slope = abs(_cycle(model, amplitude, crest + step)[1] - crest) / step
    return Loop(amplitude, crest, trough, abs(first - crest), min(slope, 1.0 - 1e-12))


def periodic_branches(model: Model, loop: Loop, phase: np.ndarray) -> np.ndarray:
    """M - M(0-) on the closed loop at u = A cos(phase), [A/m]."""
    h0, amp = model.offset, loop.amplitude
    u = amp * np.cos(phase)
    rising = np.sin(phase) < 0.0
    m_irr = np.empty(u.shape)
    m_irr[~rising] = branch(model, h0 + amp, loop.crest, h0 - amp, h0 + u[~rising])[1]
    m_irr[rising] = branch(model, h0 - amp, loop.trough, h0 + amp, h0 + u[rising])[1]
    before = float(model.total(h0, model.bias_state()))
    return model.total(h0 + u, m_irr) - before
