"""The classical Preisach model with a general density of hysterons.

Mayergoyz (Mathematical Models of Hysteresis, 1991, ch. 1) writes the output as a weighted
sum of rectangular relays: a relay with up-switching field alpha and down-switching field
beta <= alpha is +1 after the input has last reached alpha, -1 after it has last reached beta.
labsim labels a relay by its coercive field c = (alpha - beta) / 2 >= 0 and the centre of its
loop v = (alpha + beta) / 2 (the interaction field of Della Torre, Magnetic Hysteresis, 1999,
ch. 1, with the opposite sign), and gives the relays a density mu(c, v) >= 0 of unit mass:

    M_P(t) = M_s int_0^inf int mu(c, v) R_{c, v}(t) dv dc - M_P(0-).

Numerics (this generator's own): the relay (c, v) is up exactly when the play (backlash)
operator of half-width c, z_c = max(u - c, min(u + c, z_c)), stands above v (the play reaches
v when the input reaches v + c going up and leaves it when the input reaches v - c going
down; Brokate and Sprekels, Hysteresis and Phase Transitions, 1996, sec. 2.4). With the
demagnetised state z_c = 0 (relays up iff v < 0: the AC-demagnetised staircase alpha = -beta)
the added magnetisation is

    M_P(t) = 2 M_s int_0^inf [Phi(c, z_c(t)) - Phi(c, 0)] dc,   Phi(c, z) = int_-inf^z mu(c, v) dv,

where Phi is closed-form for the densities below (normal or Cauchy in v given c), and z_c(t)
is piecewise linear in c with slopes -1, 0, +1 (``hysteresis.PlayMemory``, which holds it for
any input history, wiping-out included). The integral over c is done by Gauss-Legendre
quadrature in ln c on panels split at every kink of z_c (the memory's breakpoints and the
moving crossing of the current branch), so each piece is smooth and the quadrature converges
exponentially. The steady loop for u = A cos(phase) is evaluated on Chebyshev points of each
branch (a smooth function of u) and interpolated; so are long monotone stretches of an input
history, piece by piece between the values where the branch meets an older one.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from .constants import LabsimError
from .hysteresis import PlayMemory, monotone_runs

#: Gauss-Legendre nodes per panel, and panels over the coercive fields' range (in ln c).
GAUSS_NODES = 12
PANELS = 40
#: The lognormal coercive-field densities are cut at +-this many of their log-spreads
#: (mass outside: 2e-19).
LOG_CUT = 9.0
#: Chebyshev points per branch of the steady loop.
BRANCH_POINTS = 160
_XI, _WI = np.polynomial.legendre.leggauss(GAUSS_NODES)


@dataclass(frozen=True)
class Population:
    """A population of relays: lognormal coercive fields, centres normal or Cauchy given c.

    The centre's width grows with the coercive field as sqrt(w^2 + (k c)^2) (k > 0: a
    density that does not factorise into a function of c times one of v).
    """

    weight: float  # share of all relays, [-]
    coercive_median: float  # median of c, [A/m]
    coercive_spread: float  # standard deviation of ln c, [-]
    centre: float  # mean (normal) or median (Cauchy) of the loop centre v, [A/m]
    width: float  # standard deviation (normal) or half-width (Cauchy) of v at c -> 0, [A/m]
    width_slope: float = 0.0  # k, [-]
    law: str = "normal"  # "normal" or "cauchy"

    def __post_init__(self) -> None:
        for name in ("weight", "coercive_median", "coercive_spread", "width"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise LabsimError(f"Preisach population: {name} = {value!r}; must be > 0")
        if not (math.isfinite(self.centre) and math.isfinite(self.width_slope)
                and self.width_slope >= 0):
            raise LabsimError(f"Preisach population: centre = {self.centre!r}, width_slope = "
                              f"{self.width_slope!r}; must be finite, the slope >= 0")
        if self.law not in ("normal", "cauchy"):
            raise LabsimError(f"Preisach population: law = {self.law!r}; must be 'normal' or "
                              "'cauchy'")

    def coercive_density(self, c):
        """Lognormal density of c, [m/A]."""
        c = np.asarray(c, dtype=float)
        s = self.coercive_spread
        x = (np.log(np.maximum(c, 1e-300)) - math.log(self.coercive_median)) / s
        return np.where(c > 0, np.exp(-0.5 * x * x) / (c * s * math.sqrt(2 * math.pi)), 0.0)

    def spread(self, c):
        return np.sqrt(self.width**2 + (self.width_slope * np.asarray(c)) ** 2)

    def centre_cdf(self, c, z):
        """P(v <= z | c), [-]."""
        x = (np.asarray(z) - self.centre) / self.spread(c)
        return ndtr(x) if self.law == "normal" else 0.5 + np.arctan(x) / math.pi

    def centre_density(self, c, v):
        """Density of v given c, [m/A]."""
        s = self.spread(c)
        x = (np.asarray(v) - self.centre) / s
        if self.law == "normal":
            return np.exp(-0.5 * x * x) / (s * math.sqrt(2 * math.pi))
        return 1.0 / (math.pi * s * (1.0 + x * x))


@dataclass(frozen=True)
class Density:
    """mu(c, v) = sum of the populations' weight x lognormal(c) x law(v | c); unit mass."""

    populations: tuple[Population, ...]

    def __post_init__(self) -> None:
        if not self.populations:
            raise LabsimError("Preisach density: at least one population is needed")
        total = sum(p.weight for p in self.populations)
        if abs(total - 1.0) > 1e-12:
            raise LabsimError(f"Preisach density: population weights sum to {total!r}; "
                              "must be 1")

    def cdf(self, c, z):
        """Phi(c, z) = int_-inf^z mu(c, v) dv, [m/A]."""
        return sum(p.weight * p.coercive_density(c) * p.centre_cdf(c, z)
                   for p in self.populations)

    def __call__(self, c, v):
        """mu(c, v), [m^2/A^2]."""
        return sum(p.weight * p.coercive_density(c) * p.centre_density(c, v)
                   for p in self.populations)

    @property
    def coercive_range(self) -> tuple[float, float]:
        """(c_lo, c_hi) outside which the coercive densities are below exp(-LOG_CUT^2/2)."""
        lo = min(p.coercive_median * math.exp(-LOG_CUT * p.coercive_spread)
                 for p in self.populations)
        hi = max(p.coercive_median * math.exp(LOG_CUT * p.coercive_spread)
                 for p in self.populations)
        return lo, hi

    @functools.cached_property
    def panel_edges(self) -> np.ndarray:
        lo, hi = self.coercive_range
        return np.exp(np.linspace(math.log(lo), math.log(hi), PANELS + 1))

    @functools.cached_property
    def demagnetised_integral(self) -> float:
        """int Phi(c, 0) dc, the relays' integral in the demagnetised state, [-]."""
        c, w = _quadrature(self.panel_edges[:-1], self.panel_edges[1:])
        return float(np.sum(w * self.cdf(c, 0.0)))


def _quadrature(lo: np.ndarray, hi: np.ndarray):
    """Gauss-Legendre nodes and weights in ln c on [lo, hi] (arrays of intervals, lo > 0):
    returns c and w of shape lo.shape + (GAUSS_NODES,), int f dc ~ sum w f(c)."""
    a, b = np.log(lo)[..., None], np.log(hi)[..., None]
    half = 0.5 * (b - a)
    c = np.exp(0.5 * (a + b) + half * _XI)
    return c, half * _WI * c


def branch_integral(density: Density, memory: PlayMemory, u, rising: bool) -> np.ndarray:
    """int_0^inf [Phi(c, z_c) - Phi(c, 0)] dc with the plays moved from ``memory`` by the
    input going monotonically (up if ``rising``) to each value of u, [-].

    Below the branch's crossing r* the plays follow the input (z_c = u -+ c), above it they
    keep the memory; panels wholly above r* are summed once per call, the panel holding r*
    is split there.
    """
    u = np.atleast_1d(np.asarray(u, dtype=float))
    lo_c, hi_c = density.coercive_range
    inner = memory.r[(memory.r > lo_c) & (memory.r < hi_c)]
    edges = np.unique(np.concatenate([density.panel_edges, inner]))
    panels = edges.size - 1
    c, w = _quadrature(edges[:-1], edges[1:])
    kept = np.sum(w * density.cdf(c, np.interp(c, memory.r, memory.z)), axis=1)
    above = np.concatenate([np.cumsum(kept[::-1])[::-1], [0.0]])  # panels j and higher
    slope = -1.0 if rising else 1.0
    out = np.empty(u.size)
    for start in range(0, u.size, 256):
        uu = u[start:start + 256]
        r_star = np.clip(np.asarray(memory._crossing(uu, rising), dtype=float), 0.0, None)
        k = np.searchsorted(edges, r_star, side="right") - 1  # -1: below all, panels: above
        total = above[np.clip(k + 1, 0, panels)]
        rows, cols = np.nonzero(np.arange(panels)[None, :] < k[:, None])
        if rows.size:
            moved = np.sum(w[cols] * density.cdf(c[cols], uu[rows, None] + slope * c[cols]),
                           axis=1)
            total = total + np.bincount(rows, moved, minlength=uu.size)
        split = np.flatnonzero((k >= 0) & (k < panels))
        if split.size:
            ks, rs = k[split], r_star[split]
            c_in, w_in = _quadrature(edges[ks], rs)
            c_out, w_out = _quadrature(rs, edges[ks + 1])
            total[split] += np.sum(w_in * density.cdf(c_in, uu[split, None] + slope * c_in),
                                   axis=1)
            total[split] += np.sum(w_out * density.cdf(c_out, np.interp(c_out, memory.r,
                                                                         memory.z)), axis=1)
        out[start:start + 256] = total - density.demagnetised_integral
    return out


def sequence(density: Density, saturation: float, u: np.ndarray,
             direct: bool = False) -> np.ndarray:
    """M_P at the samples u_0, u_1, ... of an input that was 0 (demagnetised) before u_0,
    [A/m]; turning points between samples are refined as in ``hysteresis.monotone_runs``.

    Along a monotone stretch the output is a smooth function of u between the values where
    the branch's crossing r* passes a breakpoint of the memory (where it meets an older
    branch: wiping-out), so each such piece with many samples is interpolated from
    ``BRANCH_POINTS`` Chebyshev points (``direct``: every sample by quadrature).
    """
    u = np.asarray(u, dtype=float)
    memory = PlayMemory()
    out = np.empty(u.size)
    before = 0.0
    for idx, rising, extremum in monotone_runs(u):
        values = u[idx]
        if direct or idx.size <= 2 * BRANCH_POINTS:
            out[idx] = branch_integral(density, memory, values, rising)
        else:
            out[idx] = _interpolated_branch(density, memory, before, extremum, values, rising)
        memory.turn(extremum, rising)
        before = extremum
    return 2.0 * saturation * out


def _interpolated_branch(density, memory, start, end, values, rising):
    """The branch integral at the values (between start and end) from Chebyshev
    interpolants on the smooth pieces."""
    meets = memory.z + memory.r if rising else memory.z - memory.r
    lo, hi = min(start, end), max(start, end)
    cuts = np.unique(np.concatenate([[lo, hi], meets[(meets > lo) & (meets < hi)]]))
    out = np.empty(values.size)
    piece = np.clip(np.searchsorted(cuts, values, side="right") - 1, 0, cuts.size - 2)
    for k in np.unique(piece):
        inside = piece == k
        if np.count_nonzero(inside) <= BRANCH_POINTS or cuts[k + 1] - cuts[k] <= 0.0:
            out[inside] = branch_integral(density, memory, values[inside], rising)
            continue
        fit = np.polynomial.Chebyshev.interpolate(
            lambda x: branch_integral(density, memory, x, rising), BRANCH_POINTS,
            [cuts[k], cuts[k + 1]])
        out[inside] = fit(values[inside])
    return out


@dataclass(frozen=True)
class Loop:
    """The steady loop for u = A cos(phase): Chebyshev interpolants of the branches in u."""

    amplitude: float
    rising: np.polynomial.Chebyshev
    falling: np.polynomial.Chebyshev

    def __call__(self, phase) -> np.ndarray:
        """The branch integral at u = A cos(phase) (rising where sin(phase) < 0), [-]."""
        phase = np.asarray(phase, dtype=float)
        u = self.amplitude * np.cos(phase)
        up = np.sin(phase) < 0.0
        return np.where(up, self.rising(u), self.falling(u))


@functools.lru_cache(maxsize=128)
def steady_loop(density: Density, amplitude: float) -> Loop:
    """The loop after the input has swept +A and -A from the demagnetised state."""
    memory = PlayMemory()
    memory.turn(amplitude, True)
    memory.turn(-amplitude, False)
    up_memory = memory.copy()
    memory.turn(amplitude, True)
    domain = [-amplitude, amplitude]
    rising = np.polynomial.Chebyshev.interpolate(
        lambda x: branch_integral(density, up_memory, x, True), BRANCH_POINTS, domain)
    falling = np.polynomial.Chebyshev.interpolate(
        lambda x: branch_integral(density, memory, x, False), BRANCH_POINTS, domain)
    return Loop(amplitude, rising, falling)
