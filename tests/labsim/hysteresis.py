"""Rate-independent hysteresis: a Preisach model whose density depends on the coercive field.

The Preisach model with a density mu(alpha, beta) = p((alpha - beta) / 2) is the
superposition of play (backlash) operators of threshold r (Krasnosel'skii and Pokrovskii,
Systems with Hysteresis, 1989; Brokate and Sprekels, Hysteresis and Phase Transitions, 1996,
sec. 2.3; its Everett function depends on alpha - beta only). labsim uses

    M_P(t) = chi_P * int_0^inf p(r) z_r(t) dr,    p(r) = exp(-r / r_0) / r_0,

with the play z_r = max(u - r, min(u + r, z_r(previous))) started at z_r = 0 (demagnetised)
and u the field. For u increasing monotonically from a turning point, z_r = max(z_r0, u - r);
decreasing, min(z_r0, u + r). The memory z(r) is piecewise linear in r with slopes
-1, 0, +1, and the integral against the exponential density is closed-form, so branches are
exact for any input history (return-point memory and wiping-out follow by construction).

Properties a reader can check: rate independent (only the sequence of input values counts);
for |u| << r_0 the branches are Rayleigh parabolas (p(0) > 0) with pointed tips and a loop
area ~ H_m^3; for |u| >> r_0 the loops widen to about 2 chi_P r_0 with slope chi_P.
"""
from __future__ import annotations

import math

import numpy as np


class PlayMemory:
    """The state z(r) of all plays: breakpoints r_b (r_b[0] = 0), values z_b; z constant after
    the last breakpoint."""

    def __init__(self, scale: float = math.nan) -> None:
        self.scale = scale  # r_0 of the exponential density (``integral`` only), [A/m]
        self.r = np.array([0.0])
        self.z = np.array([0.0])

    def copy(self) -> "PlayMemory":
        other = PlayMemory(self.scale)
        other.r, other.z = self.r.copy(), self.z.copy()
        return other

    def _crossing(self, u, rising: bool):
        """First r where z(r) + r >= u (rising) or z(r) - r <= u (falling)."""
        g = self.z + self.r if rising else self.r - self.z  # nondecreasing in r
        target = np.asarray(u if rising else -np.asarray(u), dtype=float)
        idx = np.searchsorted(g, target, side="left")  # first g[idx] >= target
        lo = np.clip(idx - 1, 0, g.size - 1)
        hi = np.clip(idx, 0, g.size - 1)
        span = np.where(hi > lo, g[hi] - g[lo], 1.0)
        inside = self.r[lo] + (target - g[lo]) * (self.r[hi] - self.r[lo]) / span
        beyond = self.r[-1] + (target - g[-1])  # g has slope 1 after the last breakpoint
        return np.where(idx == 0, 0.0, np.where(idx >= g.size, beyond, inside))

    def turn(self, extremum: float, rising: bool) -> None:
        """Update the memory after the input reached ``extremum`` going up (or down)."""
        r_star = float(self._crossing(extremum, rising))
        later = self.r > r_star
        self.r = np.concatenate([[0.0, r_star], self.r[later]])
        line_end = extremum - r_star if rising else extremum + r_star
        self.z = np.concatenate([[extremum, line_end], self.z[later]])
        if r_star == 0.0:
            self.r, self.z = self.r[1:], self.z[1:]

    def _primitive(self, r, a, s):
        """Antiderivative of (a + s r) exp(-r/r0)/r0: -exp(-r/r0) (a + s (r + r0))."""
        r0 = self.scale
        return -np.exp(-r / r0) * (a + s * (r + r0))

    def integral(self, u, rising: bool) -> np.ndarray:
        """int p(r) max(z(r), u - r) dr (rising) or int p(r) min(z(r), u + r) dr (falling)."""
        u = np.asarray(u, dtype=float)
        r_star = self._crossing(u, rising)
        s_line = -1.0 if rising else 1.0
        head = self._primitive(r_star, u, s_line) - self._primitive(0.0, u, s_line)
        return head + self._tail(r_star)

    def _tail(self, r_star: np.ndarray) -> np.ndarray:
        """int_{r*}^inf p(r) z(r) dr for the piecewise-linear z."""
        r, z = self.r, self.z
        slopes = np.diff(z) / np.diff(r) if r.size > 1 else np.zeros(0)
        slopes = np.append(slopes, 0.0)  # constant after the last breakpoint
        offsets = z - slopes * r
        upper = np.append(self._primitive(r[1:], offsets[:-1], slopes[:-1]), 0.0)
        lower = self._primitive(r, offsets, slopes)
        pieces = upper - lower
        after = np.concatenate([np.cumsum(pieces[::-1])[::-1][1:], [0.0]])
        k = np.clip(np.searchsorted(r, r_star, side="right") - 1, 0, r.size - 1)
        partial = upper[k] - self._primitive(r_star, offsets[k], slopes[k])
        return partial + after[k]


def monotone_runs(u: np.ndarray):
    """Split the samples u_0, u_1, ... of an input that was 0 before u_0 into monotone runs.

    Yields (indices of the samples in the run, rising, extremum at its end). At a turning
    point inside the record the extremum is refined by the parabola through the three
    samples around it (error O(h^3) for a smooth input sampled at step h); flat steps continue
    the previous direction.
    """
    u = np.asarray(u, dtype=float)
    v = np.concatenate([[0.0], u])
    step = np.diff(v)
    direction = np.sign(step)
    for k in range(1, direction.size):  # flat steps continue the previous direction
        if direction[k] == 0:
            direction[k] = direction[k - 1]
    if direction[0] == 0:
        direction[0] = 1.0
    start = 0
    while start < direction.size:
        rising = direction[start] > 0
        stop = start
        while stop + 1 < direction.size and direction[stop + 1] == direction[start]:
            stop += 1
        extremum = v[stop + 1]
        if stop >= 1 and stop + 2 < v.size:  # not at the switch-on jump, not at the end
            a, b, c = v[stop], v[stop + 1], v[stop + 2]
            curvature = a - 2 * b + c
            if curvature != 0.0:
                extremum = b - (c - a) ** 2 / (8 * curvature)
        yield np.arange(start, stop + 1), rising, extremum  # samples u[idx] = v[idx + 1]
        start = stop + 1


def play_sequence(u: np.ndarray, susceptibility: float, scale: float) -> np.ndarray:
    """M_P at the samples u_0, u_1, ... of an input that was 0 (demagnetised) before u_0.

    Monotone runs between turning points (``monotone_runs``) are evaluated in closed form.
    """
    u = np.asarray(u, dtype=float)
    memory = PlayMemory(scale)
    out = np.empty(u.size)
    for idx, rising, extremum in monotone_runs(u):
        out[idx] = memory.integral(u[idx], rising)
        memory.turn(extremum, rising)
    return susceptibility * out


def periodic_branches(amplitude: float, phase: np.ndarray, susceptibility: float,
                      scale: float) -> np.ndarray:
    """Steady-state M_P for u = A cos(phase): the loop after the input has swept +A and -A."""
    memory = PlayMemory(scale)
    memory.turn(amplitude, True)
    memory.turn(-amplitude, False)
    rising_memory = memory.copy()
    memory.turn(amplitude, True)
    u = amplitude * np.cos(phase)
    rising = np.sin(phase) < 0.0
    out = np.empty(u.shape)
    out[rising] = rising_memory.integral(u[rising], True)
    out[~rising] = memory.integral(u[~rising], False)
    return susceptibility * out


def loop_area(amplitude: float, susceptibility: float, scale: float, points: int = 4096):
    """Area of the steady loop, oint H dM (trapezoid over one period), [A^2/m^2]; times mu_0
    it is the hysteresis loss per cycle and volume, [J/m^3]."""
    phase = np.linspace(0.0, 2.0 * math.pi, points + 1)
    m = periodic_branches(amplitude, phase, susceptibility, scale)
    h = amplitude * np.cos(phase)
    return float(np.sum(0.5 * (h[1:] + h[:-1]) * np.diff(m)))
