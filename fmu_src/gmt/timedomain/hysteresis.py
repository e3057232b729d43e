"""Rate-independent hysteresis with memory whose loss per cycle is K_h B_m^n (eq 7).

The operator is driven by the flux density B and returns the irreversible part
H_irr of the field. It is a Prandtl-Ishlinskii model, a superposition of stop
operators (elastic-perfectly-plastic elements, the subclass of Preisach models
whose Everett function depends on the swing only) [1]_ [2]_::

    H_irr(t) = sum over stops of rho(r) e_r(t),   e_r follows B with slope 1 inside
                                                   [-r, r] and sticks at +-r.

A stop of radius r cycled between -a and a (a > r) traces a parallelogram of
area 4 r (a - r), so a density rho(r) gives the loss per cycle

    W(a) = integral_0^a rho(r) 4 r (a - r) dr,   W''(a) = 4 a rho(a).

The density that makes W(a) = K_h a^n, the paper's eq 7 per cycle and volume,
is therefore rho(r) = c r^(n - 3) with c = K_h n (n - 1) / 4. Two limits make
it a physical operator:

* **Above r_max** (``steinmetz_upper``) there are no stops: the Steinmetz law
  holds for every cycle of half-swing a <= r_max (and a <= r_b, below), above
  it the loss grows linearly in a. r_max is the largest amplitude the law is asked to cover.
* **Above r_b** (``steinmetz_break``, optional) the density turns to
  c r_b^(n - m) r^(m - 3): the loss per cycle grows as a^n below r_b and its
  exponent turns towards m = ``steinmetz_exponent_high`` above. A ferrite's
  hysteresis loss rises as B^3 in its Rayleigh region (Rayleigh's law, [3]_
  ch. 7) and more slowly once the domain walls leave it (Snelling, *Soft
  Ferrites*, 1988, ch. 4). r_b >= r_max leaves one density.
* **Below r_0** (``steinmetz_lower``) the density r^(n - 3), infinite at
  r -> 0 for n < 3, would make dH/dB infinite at every reversal (the loop's
  tips horizontal in the B-H plane, so M = B/mu_0 - H would run backwards
  just after a turn). The stops below r_0 are replaced by one stop at
  r_1 = r_0 (n - 1)/n of weight w = c r_0^(n - 2) n/(n - 1)^2, which has the
  same first and second moments over [0, r_0]; W(a) = K_h a^n then holds
  exactly for r_0 <= a <= min(r_b, r_max), and below r_0 (cycles of a few mT, a
  negligible share of the energy) the loss is that of the single stop.

After a reversal at (B_k, H_k) the branch is H = H_k + s G(|B - B_k|), s the
direction, with the branch function (the PI model's Everett function)

    G(x) = integral rho(r) min(x, 2 r) dr,          G'(x) = integral_{r > x/2} rho(r) dr,

and from the demagnetised state the virgin curve H = sign(B) G(2 |B|) / 2.
Memory follows Madelung's rules: a branch that passes the reversal it started
from wipes the pair of reversals out and continues on the branch before them
([2]_, ch. 2). Only the reversal points are stored: the operator is exact,
with no discretisation of the stops.

References
----------
.. [1] M. Brokate and J. Sprekels, *Hysteresis and Phase Transitions*,
   Springer, 1996, ch. 2 (play and stop operators, the Prandtl-Ishlinskii model).
.. [2] I. D. Mayergoyz, *Mathematical Models of Hysteresis and Their
   Applications*, Elsevier, 2003, ch. 1-2 (Preisach model, wiping out).
.. [3] G. Bertotti, *Hysteresis in Magnetism*, Academic Press, 1998, ch. 7
   (Rayleigh's law) and ch. 12-13 (Steinmetz law and loss separation).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

__all__ = ["BranchFunction", "BranchSum", "SteinmetzHysteresis", "MAX_EXPONENT",
           "cycle_loss_per_coefficient"]

#: Largest exponent of a stop density r^(n - 3) the operator accepts, [-]: n > 3 is a
#: density growing with r (still nonnegative); the paper's n itself stays in (1, 3]
#: (:data:`gmt.parameters.STEINMETZ_RANGE`), a second density may be steeper.
MAX_EXPONENT = 4.0


def _power_integral(a, b, p):
    """integral_a^b r^p dr for 0 < a <= b, including p = -1."""
    if abs(p + 1.0) < 1e-12:
        return math.log(b / a)
    return (b ** (p + 1.0) - a ** (p + 1.0)) / (p + 1.0)


def _branch_piece(lo, hi, k, p):
    """What G and G' need of a piece k r^p of the stop density over [lo, hi] [T]: (lo, hi,
    q = p + 1, whether q = 0, k, k/q, k/(q + 1), the antiderivatives' constants k hi^q/q
    (k ln hi when q = 0) and k lo^(q+1)/(q+1), the whole piece's integral 2 k r^(p+1) dr
    and integral k r^p dr)."""
    q = p + 1.0
    log = abs(q) < 1e-12
    return (lo, hi, q, log, k, 0.0 if log else k / q, k / (q + 1.0),
            k * (math.log(hi) if log else hi ** q / q), k * lo ** (q + 1.0) / (q + 1.0),
            2.0 * k * _power_integral(lo, hi, p + 1.0), k * _power_integral(lo, hi, p))


def _moments(t, n, knee, m):
    """First and second moments integral_0^t rho(r) r^j dr, j = 1, 2, of the stop density
    per unit K_h (rho = c r^(n - 3) up to r_b = ``knee``, c r_b^(n - m) r^(m - 3) above,
    c = n (n - 1)/4; module docstring), for upper limits ``t`` [T] (an array)."""
    c = 0.25 * n * (n - 1.0)
    over = t > knee
    if not np.any(over):
        p = t ** (n - 1.0)
        return c * p / (n - 1.0), c * p * t / n
    r = float(knee)
    u = t if np.all(over) else np.maximum(t, r)
    scale, p = c * r ** (n - m), u ** (m - 1.0)
    m1 = c * r ** (n - 1.0) / (n - 1.0) + scale * (p - r ** (m - 1.0)) / (m - 1.0)
    m2 = c * r ** n / n + scale * (p * u - r ** m) / m
    if u is not t:  # the limits below the break
        under = ~over
        v = t[under]
        p = v ** (n - 1.0)
        m1[under], m2[under] = c * p / (n - 1.0), c * p * v / n
    return m1, m2


def cycle_loss_per_coefficient(amplitude, n, knee=math.inf, high_exponent=2.0, lower=0.0,
                               upper=math.inf):
    """Loss per cycle of the stop density per unit K_h for half-swings ``amplitude`` [T].

    W(a) = integral rho(r) 4 r (a - r) dr over the stops (module docstring), for the
    density c r^(n - 3) up to the break r_b = ``knee`` [T] and c r_b^(n - m) r^(m - 3)
    above it (m = ``high_exponent`` in (1, 4]), c = n (n - 1)/4 per unit K_h:

    * r_0 <= a <= min(r_b, r_max): the law itself, a^n (eq 7 per cycle);
    * a > r_b: 4 (a M_1(a) - M_2(a)) with the moments M_j of the broken density,

          n (n - 1) [a r_b^(n-1)/(n-1) - r_b^n/n + r_b^(n-m) (a (a^(m-1) - r_b^(m-1))/(m-1)
                     - (a^m - r_b^m)/m)],

      continuous with a^n and with its slope at r_b;
    * a > r_max = ``upper``: no stops above r_max, 4 (a M_1(r_max) - M_2(r_max)), linear
      in a;
    * a < r_0 = ``lower``: the one stop that replaces those below r_0 (radius
      r_1 = r_0 (n - 1)/n, weight c r_0^(n - 2) n/(n - 1)^2), n r_0^(n - 1) max(a - r_1, 0).

    ``lower`` = 0 and ``upper`` = inf (the defaults) are the limits r_0 -> 0, r_max ->
    inf the loss study fits with; :meth:`BranchFunction.cycle_loss` gives the operator's
    r_0 and r_max. Vectorised: an array in, an array out; a float in, a float out.
    """
    a = np.atleast_1d(np.asarray(amplitude, dtype=float))
    loss = a ** n
    beyond = a > min(knee, upper)
    if np.any(beyond):
        b = a[beyond]
        m1, m2 = _moments(b if upper == math.inf else np.minimum(b, upper), n, knee,
                          float(high_exponent))
        loss[beyond] = 4.0 * (b * m1 - m2)
    below = a < lower
    if np.any(below):
        r1 = lower * (n - 1.0) / n
        loss[below] = n * lower ** (n - 1.0) * np.maximum(a[below] - r1, 0.0)
    return loss if np.ndim(amplitude) else float(loss[0])


class BranchFunction:
    """G(x) and G'(x) of the stop density (see the module docstring).

    Parameters
    ----------
    hysteresis_coefficient : float
        K_h of eq 7, [W s/(m^3 T^n)] (J/m^3 per cycle at 1 T).
    steinmetz_exponent : float
        n of eq 7, [-], in (1, :data:`MAX_EXPONENT`].
    lower, upper : float
        r_0 and r_max, [T], 0 < r_0 < r_max.
    knee, high_exponent : float
        r_b, [T], > r_0, and m, [-], in (1, :data:`MAX_EXPONENT`]: the density's exponent
        turns from n - 3 to m - 3 at r_b (module docstring); r_b >= r_max: one density.

    Examples
    --------
    The loss per cycle of half-swing a is K_h a^n between the limits:

    >>> g = BranchFunction(85805.0, 1.8092, 2e-3, 0.2)
    >>> round(g.cycle_loss(0.0637) / (85805.0 * 0.0637 ** 1.8092), 12)
    1.0
    """

    def __init__(self, hysteresis_coefficient, steinmetz_exponent, lower, upper,
                 knee=math.inf, high_exponent=2.0):
        n = float(steinmetz_exponent)
        for name, value in (("steinmetz_exponent", n),
                            ("steinmetz_exponent_high", float(high_exponent))):
            if not 1.0 < value <= MAX_EXPONENT:
                raise ParameterError(
                    f"{name} = {value:g} is outside the allowed range (1, {MAX_EXPONENT:g}] "
                    "of the time-domain hysteresis operator (its stop density K_h n (n-1) "
                    "r^(n-3)/4)")
        if not (0.0 < lower < upper and math.isfinite(upper)):
            raise ParameterError(
                f"steinmetz_lower = {lower:g} T and steinmetz_upper = {upper:g} T must "
                "satisfy 0 < steinmetz_lower < steinmetz_upper")
        if not knee > lower:
            raise ParameterError(
                f"steinmetz_break = {knee:g} T must exceed steinmetz_lower = {lower:g} T")
        self.k_h = float(hysteresis_coefficient)
        self.n = n
        self.knee, self.high_exponent = float(knee), float(high_exponent)
        self.r0 = float(lower)
        self.rmax = float(upper)
        self.c = self.k_h * n * (n - 1.0) / 4.0
        self.r1 = self.r0 * (n - 1.0) / n
        self.w = self.c * self.r0 ** (n - 2.0) * n / (n - 1.0) ** 2
        # the continuous part: pieces k r^p of the density over [r_from, r_to]
        pieces = [(self.r0, min(knee, self.rmax), self.c, n - 3.0)]
        if knee < self.rmax:
            m = float(high_exponent)
            pieces.append((knee, self.rmax, self.c * knee ** (n - m), m - 3.0))
        self._pieces = tuple(_branch_piece(*piece) for piece in pieces)
        # its elastic slope below 2 r_0 and its value above 2 r_max
        self._tail = sum(piece[-1] for piece in self._pieces)
        self._top = sum(piece[-2] for piece in self._pieces)

    def _continuous(self, half):
        """(G, G') of the continuous part for r_0 < ``half`` < r_max, x = 2 half: over each
        piece k r^p of the density, G = integral 2 r rho dr below ``half`` + x integral
        rho dr above it and G' the second integral (module docstring); one power a piece."""
        g = gs = 0.0
        x = 2.0 * half
        for lo, hi, q, log, k, k_q, k_q1, upper, lower, whole_g, whole_gs in self._pieces:
            if half >= hi:
                g += whole_g
            elif half <= lo:
                g, gs = g + x * whole_gs, gs + whole_gs
            else:
                if log:  # p = -1: k integral dr/r above half
                    power, above = 1.0, upper - k * math.log(half)
                else:
                    power = half ** q
                    above = upper - k_q * power
                g += 2.0 * (k_q1 * power * half - lower) + x * above
                gs += above
        return g, gs

    def value_and_slope(self, x: float) -> tuple[float, float]:
        """(G(x) [A/m], G'(x) [A/(m T)]) for a swing x >= 0 [T] (the solvers' inner loop)."""
        w = self.w
        g, gs = (w * x, w) if x < 2.0 * self.r1 else (2.0 * w * self.r1, 0.0)
        half = 0.5 * x
        if half <= self.r0:
            return g + x * self._tail, gs + self._tail
        if half >= self.rmax:
            return g + self._top, gs
        gc, gcs = self._continuous(half)
        return g + gc, gs + gcs

    def value(self, x: float) -> float:
        """G(x), [A/m], for a swing x >= 0 [T]."""
        return self.value_and_slope(x)[0]

    def slope(self, x: float) -> float:
        """G'(x) = dH/dB along a branch a swing x >= 0 [T] from its reversal, [A/(m T)]."""
        return self.value_and_slope(x)[1]

    @property
    def reversal_slope(self) -> float:
        """G'(0), the largest dH_irr/dB, just after a reversal, [A/(m T)]."""
        return self.w + self._tail

    def cycle_loss(self, amplitude: float) -> float:
        """Loss per cycle and volume of half-swing a, integral rho 4 r (a - r) dr, [J/m^3].

        Equal to K_h a^n (eq 7 per cycle) for r_0 <= a <= min(r_b, r_max)
        (:func:`cycle_loss_per_coefficient` with this operator's r_0 and r_max).
        """
        return self.k_h * cycle_loss_per_coefficient(amplitude, self.n, self.knee,
                                                     self.high_exponent, self.r0, self.rmax)


class BranchSum:
    """Two stop densities superposed: loss per cycle K_h a^n + K_h2 a^n2.

    Densities add, and so do G, G' and the loss per cycle (each term of the module
    docstring is linear in rho); both nonnegative, the sum is a Prandtl-Ishlinskii
    operator too. With n2 > n the exponent of the loss per cycle turns from n at
    small swings to n2 at large ones, as a ferrite's Steinmetz exponent rises with
    flux density above its Rayleigh region (Bertotti 1998, ch. 12; Snelling,
    *Soft Ferrites*, 1988, ch. 4). Same interface as :class:`BranchFunction`.
    """

    def __init__(self, *parts: BranchFunction):
        self.parts = parts

    def value(self, x: float) -> float:
        """G(x), [A/m]."""
        return sum(p.value(x) for p in self.parts)

    def slope(self, x: float) -> float:
        """G'(x), [A/(m T)]."""
        return sum(p.slope(x) for p in self.parts)

    def value_and_slope(self, x: float) -> tuple[float, float]:
        """(G(x), G'(x))."""
        g = gs = 0.0
        for p in self.parts:
            a, b = p.value_and_slope(x)
            g, gs = g + a, gs + b
        return g, gs

    @property
    def reversal_slope(self) -> float:
        """G'(0), [A/(m T)]."""
        return sum(p.reversal_slope for p in self.parts)

    def cycle_loss(self, amplitude: float) -> float:
        """Loss per cycle and volume, [J/m^3]: the parts' sum."""
        return sum(p.cycle_loss(amplitude) for p in self.parts)


class SteinmetzHysteresis:
    """The operator with its memory: B in, H_irr out (see the module docstring).

    The state is the present point (B, H_irr), the direction of the branch
    and the stack of reversal points not yet wiped out. :meth:`evaluate`
    answers "what would H_irr be at B, reached monotonically from here"
    without changing the memory (the implicit solvers try many B per step);
    :meth:`move` commits.

    Parameters
    ----------
    branch : BranchFunction or BranchSum

    Examples
    --------
    >>> op = SteinmetzHysteresis(BranchFunction(85805.0, 1.8092, 2e-3, 0.2))
    >>> up = op.move(0.05); down = op.move(-0.05); back = op.move(0.05)
    >>> round(back - up, 9)   # the major loop closes on itself
    0.0
    """

    def __init__(self, branch: BranchFunction):
        self.branch = branch
        self.reset()

    def reset(self):
        """Back to the demagnetised state (B = 0, H_irr = 0, no reversals)."""
        self.b = 0.0
        self.h = 0.0
        self.direction = 0.0
        self._rb: list[float] = []
        self._rh: list[float] = []

    def _walk(self, b):
        """Reversal stack and branch for a move to ``b``: (rb, rh, depth, s)."""
        b0 = self.b
        s = 1.0 if b > b0 else -1.0
        rb, rh = self._rb, self._rh
        if (rb and s != self.direction) or (not rb and s * b0 < 0.0):
            rb, rh = rb + [b0], rh + [self.h]  # the present point becomes a reversal
        k = len(rb)
        while k:
            limit = rb[k - 2] if k >= 2 else -rb[0]  # the virgin curve's mirror point
            if s * (b - limit) > 0.0:
                k -= 2 if k >= 2 else 1
            else:
                break
        return rb, rh, k, s

    def evaluate(self, b: float) -> tuple[float, float]:
        """(H_irr [A/m], dH_irr/dB [A/(m T)]) at ``b`` [T], the memory unchanged."""
        if b == self.b:
            return self.h, self._present_slope()
        rb, rh, k, s = self._walk(b)
        if k == 0:
            g, gs = self.branch.value_and_slope(2.0 * abs(b))
            return (0.5 * g if b >= 0.0 else -0.5 * g), gs
        g, gs = self.branch.value_and_slope(s * (b - rb[k - 1]))
        return rh[k - 1] + s * g, gs

    def branch_towards(self, direction: float) -> tuple[float, float, float]:
        """The branch a move in ``direction`` (+1 or -1) starts on: (B_k, H_k, limit).

        Up to ``limit`` [T] (where it would wipe a reversal out) the move follows
        H_irr = H_k + direction G(direction (B - B_k)); B_k is NaN on the virgin
        curve (H_irr = sign(B) G(2|B|)/2). The solvers' fast path; the memory
        is not changed.
        """
        rb, rh = self._rb, self._rh
        b0 = self.b
        if (rb and direction != self.direction) or (not rb and direction * b0 < 0.0):
            return b0, self.h, (rb[-1] if rb else -b0)
        if rb:
            return rb[-1], rh[-1], (rb[-2] if len(rb) >= 2 else -rb[0])
        return math.nan, 0.0, direction * math.inf

    @property
    def reversals(self) -> tuple:
        """B of the reversal points not yet wiped out, oldest first, [T]."""
        return tuple(self._rb)

    def _present_slope(self) -> float:
        if not self._rb:
            return self.branch.slope(2.0 * abs(self.b))
        return self.branch.slope(abs(self.b - self._rb[-1]))

    def move(self, b: float, h: float | None = None) -> float:
        """Move to ``b`` [T] (monotonically from the present point); return H_irr [A/m].

        ``h``: H_irr at ``b`` when the caller has just evaluated it (skips the evaluation).
        """
        if b == self.b:
            return self.h
        rb, rh, k, s = self._walk(b)
        if h is None and k == 0:
            g = self.branch.value(2.0 * abs(b))
            h = 0.5 * g if b >= 0.0 else -0.5 * g
        elif h is None:
            h = rh[k - 1] + s * self.branch.value(s * (b - rb[k - 1]))
        self._rb, self._rh = rb[:k], rh[:k]
        self.b, self.h, self.direction = float(b), float(h), s
        return self.h

    def get_state(self) -> tuple:
        """(B, H_irr, direction, reversals..., their H_irr...) as floats."""
        return (self.b, self.h, self.direction, *self._rb, *self._rh)

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(float(v) for v in state)
        if len(state) < 3 or (len(state) - 3) % 2:
            raise ParameterError(
                f"hysteresis state has {len(state)} values; it needs 3 plus an even number")
        k = (len(state) - 3) // 2
        self.b, self.h, self.direction = state[:3]
        self._rb, self._rh = list(state[3:3 + k]), list(state[3 + k:])
