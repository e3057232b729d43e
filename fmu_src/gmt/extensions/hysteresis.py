"""Rate-independent hysteresis: a Prandtl-Ishlinskii operator of the applied field.

The paper's complex permeability describes the loop at one operating point by
its first harmonic. A rate-independent hysteresis adds a loop that persists as
f -> 0, has pointed reversal tips and depends on the amplitude. It is written
here as a weighted sum of play (backlash) operators (Krasnosel'skii &
Pokrovskii 1989; Brokate & Sprekels 1996, ch. 2; Kuhnen 2003):

    P[H](t) = sum_j w_j F_{r_j}[H](t),
    F_r[H](t_k) = max(H_k - r, min(H_k + r, F_r[H](t_{k-1}))).

The operator's output is added to the paper's magnetisation (eq 5), whole:
its fundamental, whose quadrature part is its loss per cycle and depends on
H_m as the play operators do (not as eq 16's K_h B_m^n term, which follows
B_m), and its harmonics. The sensing coil measures the sum, so the paper's part
is the one whose flux density makes the total's |B_1| the measured B_m, with
eq 16's mu'' at its own flux density
(:func:`gmt.extensions.paperpart.paper_permeability`).

* periodic form: :meth:`PrandtlIshlinskii.periodic` in closed form for
  H = H_m cos(theta), added to M (:meth:`HysteresisForm.steady_output`);
* time-stepped form: the operating point carries the paper part's mu
  (:meth:`gmt.variants.Chain.paper_point`); the plays advance with each held H
  (:meth:`PrandtlIshlinskii.step`) and M gains P[H];
* parameters: the thresholds r_j [A/m] and weights w_j [-]. The diagnosis
  puts 40 thresholds on a geometric grid from 0.005 H_max to H_max (H_max the
  largest field amplitude of the data, :func:`play_thresholds`), so that the
  small thresholds of the order of Terfenol-D's coercive field (1-2 kA/m,
  against drive amplitudes of 10-15 kA/m; Engdahl (ed.), *Handbook of Giant
  Magnetostrictive Materials*, Academic Press 2000, ch. 1) are there as well
  as the large ones, and weighs them by a smooth threshold density (a Preisach
  density along its coercive axis; Mayergoyz, *Mathematical Models of
  Hysteresis*, Springer 1991, ch. 1), the gamma family
  p(r) = r^(k - 1) e^{-r/r_0} (k = 1: exponential; k > 1: peaked at
  (k - 1) r_0), w_j = chi p(r_j) dr_j / sum_j p(r_j) dr_j: three unknowns,
  the total weight chi, log10(r_0 / H_max) and k.

References
----------
* M. A. Krasnosel'skii, A. V. Pokrovskii, *Systems with Hysteresis*, Springer
  1989 (play and stop operators).
* M. Brokate, J. Sprekels, *Hysteresis and Phase Transitions*, Springer 1996.
* K. Kuhnen, Eur. J. Control 9 (2003) 407-418 (modified Prandtl-Ishlinskii).
* A. Gelb, W. E. Vander Velde, *Multiple-Input Describing Functions and
  Nonlinear System Design*, McGraw-Hill 1968.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ._base import HIGHER_HARMONICS, Extension, FitSpec, Parameter
from .magnetic import MagnetizationStage

#: Plays of the diagnosis' operator: thresholds spaced geometrically from this fraction of
#: the largest field amplitude of the data to that amplitude (module docstring).
PLAY_GRID = (0.005, 1.0, 40)


@functools.lru_cache(maxsize=8)
def play_thresholds(field_max, grid=PLAY_GRID):
    """The diagnosis' play thresholds r_j and their widths dr_j for H_max [A/m], [A/m]
    (read-only; cached: every evaluation of the form asks)."""
    low, high, count = grid
    edges = field_max * np.geomspace(low, high, count + 1)
    out = np.sqrt(edges[1:] * edges[:-1]), np.diff(edges)
    for a in out:
        a.flags.writeable = False
    return out


@dataclass(frozen=True)
class PrandtlIshlinskii:
    """Prandtl-Ishlinskii operator: a weighted sum of play operators (module docstring).

    Attributes
    ----------
    thresholds : tuple of float
        r_j >= 0, [A/m].
    weights : tuple of float
        w_j, magnetisation per unit play output, [-].
    """

    thresholds: tuple
    weights: tuple

    def __post_init__(self):
        if len(self.thresholds) != len(self.weights) or not self.thresholds:
            raise ParameterError("thresholds and weights must be non-empty and of equal "
                                 f"length (got {len(self.thresholds)} and {len(self.weights)})")
        for r in self.thresholds:
            check_range("threshold", r, 0.0, math.inf, unit="A/m", low_open=False)
        for w in self.weights:
            if not math.isfinite(w):
                raise ParameterError(f"weight = {w!r} is not finite")

    def step(self, field, state):
        """One sample of every play: returns (output [A/m], new state).

        Parameters
        ----------
        field : float
            H at this sample, [A/m].
        state : array
            The plays' previous outputs (zeros for the demagnetised state), [A/m].
        """
        r = np.asarray(self.thresholds)
        z = np.maximum(field - r, np.minimum(field + r, state))
        return float(np.dot(self.weights, z)), z

    def apply(self, field, state=None):
        """The operator over a sampled input, from ``state`` (default demagnetised), [A/m]."""
        z = np.zeros(len(self.thresholds)) if state is None else np.asarray(state, float)
        out = np.empty(len(field))
        for k, h in enumerate(np.asarray(field, dtype=float)):
            out[k], z = self.step(h, z)
        return out

    def periodic(self, field_amplitude, phase):
        """Periodic output for H = H_m cos(theta), closed form, [A/m].

        After one period from the demagnetised state a play of threshold
        r < H_m runs: falling (0 <= theta <= pi) min(H_m - r, H + r), rising
        max(-H_m + r, H - r); a play with r >= H_m stays at 0.

        Parameters
        ----------
        field_amplitude : float or array
            H_m, [A/m] (broadcast against ``phase``).
        phase : array
            theta, [rad].
        """
        return self.play_outputs(field_amplitude, phase) @ np.asarray(self.weights,
                                                                      dtype=float)

    def play_outputs(self, field_amplitude, phase):
        """The plays' periodic outputs (:meth:`periodic` before the weights), shape of the
        broadcast inputs + (plays,), [A/m]."""
        hm, th = np.broadcast_arrays(np.asarray(field_amplitude, dtype=float),
                                     np.mod(np.asarray(phase, dtype=float), 2 * np.pi))
        return _play_outputs(tuple(float(r) for r in self.thresholds), hm.shape,
                             hm.tobytes(), th.tobytes())


@functools.lru_cache(maxsize=16)
def _play_outputs(thresholds, shape, field_amplitude, phase):
    """The plays' periodic outputs F_r (:meth:`PrandtlIshlinskii.periodic`), shape + (plays,),
    [A/m]. They do not depend on the weights: a fit that moves only the weights (the
    diagnosis' density) reuses them (the arrays' bytes are the cache key; read-only)."""
    hm = np.frombuffer(field_amplitude, dtype=float).reshape(shape)[..., None]
    th = np.frombuffer(phase, dtype=float).reshape(shape)[..., None]
    h = hm * np.cos(th)
    r = np.asarray(thresholds, dtype=float)
    z = np.where(th <= np.pi, np.minimum(hm - r, h + r), np.maximum(-hm + r, h - r))
    z = np.where(r < hm, z, 0.0)
    z.flags.writeable = False
    return z


class HysteresisForm(MagnetizationStage, Extension):
    """Prandtl-Ishlinskii hysteresis added to the paper's magnetisation (module docstring).

    Memory of the time-stepped form: the plays' outputs, [A/m] (zero: the
    demagnetised state).
    """

    cause = "rate_independent_hysteresis"
    stage = "magnetization"
    #: its output adds to M and does not depend on it (gmt.extensions.steady.stage_adder)
    additive = True
    signals = "B and y"
    #: a hysteresis, first or later, must explain the loop's higher harmonics
    #: (Extension.signature)
    signature = HIGHER_HARMONICS
    parameters = (Parameter("thresholds_A_per_m", "A/m", 0.0, math.inf, low_open=False,
                            is_list=True),
                  Parameter("weights", "-", is_list=True))
    fit = FitSpec(("chi", "log10_r0_per_Hmax", "shape"),
                  ((0.2, -1.0, 1.0), (0.5, -0.5, 2.0), (0.1, -1.5, 1.0)),
                  (0.0, -2.5, 0.3), (3.0, 1.0, 30.0), neutral=(0.0, -1.0, 1.0))

    @classmethod
    def validate(cls, values):
        cls.operator_of(values)

    @staticmethod
    def operator_of(values) -> PrandtlIshlinskii:
        """The operator of the SI parameters."""
        return PrandtlIshlinskii(tuple(values["thresholds_A_per_m"]), tuple(values["weights"]))

    @classmethod
    def from_fit(cls, x, context):
        field_max = context["field_max"]
        r, dr = play_thresholds(field_max)
        r0, shape = field_max * 10.0 ** x[1], x[2]
        # the density in logs, scaled to its largest value on the grid (no overflow)
        log_p = (shape - 1.0) * np.log(r / field_max) - r / r0 + np.log(dr)
        p = np.exp(log_p - log_p.max())
        return {"thresholds_A_per_m": [float(v) for v in r],
                "weights": [float(v) for v in x[0] * p / p.sum()]}

    @classmethod
    def stack_values(cls, values_list, runs):
        """One row of weights a run (the thresholds are the data's, the same in each)."""
        thresholds = values_list[0]["thresholds_A_per_m"]
        if any(v["thresholds_A_per_m"] != thresholds for v in values_list):
            return None
        return {"thresholds_A_per_m": thresholds,
                "weights": np.repeat(np.array([v["weights"] for v in values_list], float),
                                     runs, axis=0)}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        # chi = 0 is the paper's model (no hysteresis), not a bound pressed on
        return tuple(n for n in super().at_bounds(x, tolerance)
                     if not (n == "chi" and x[0] <= tolerance * cls.fit.upper[0]))

    # periodic form
    @classmethod
    def steady_output(cls, values, steady, magnetization, theta, memo=None):
        if memo is not None and "output" in memo:
            return magnetization + memo["output"]
        sw = np.asarray(steady.switching_gain)[..., None]  # the field stage's
        hm = np.asarray(steady.field_amplitude)[..., None]
        w = np.asarray(values["weights"], float)
        if w.ndim == 1:
            out = cls.operator_of(values).periodic(np.abs(sw) * hm, theta + np.angle(sw))
        else:  # a row of weights a run (stack_values): the plays' outputs weighted per row
            plays = PrandtlIshlinskii(tuple(values["thresholds_A_per_m"]), tuple(w[0]))
            z = plays.play_outputs(np.abs(sw) * hm, theta + np.angle(sw))
            out = np.empty(z.shape[:-1])
            groups = {}
            for i, row in enumerate(w):
                groups.setdefault(row.tobytes(), []).append(i)
            for idx in groups.values():
                out[idx] = z[idx] @ w[idx[0]]
        if memo is not None:
            memo["output"] = out
        return magnetization + out

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.operator = self.operator_of(values)
        self.plays = np.zeros(len(self.operator.thresholds))

    def adjust(self, mag, step, time):
        out, self.plays = self.operator.step(self.switching_field(mag), self.plays)
        return self.with_magnetization(mag, out)

    def waveform(self, theta, upstream):
        sw = self.point_switching_gain
        return upstream(theta) + self.operator.periodic(abs(sw) * self.point.field_amplitude,
                                                        theta + np.angle(sw))

    def reset(self, rest_displacement):
        self.plays = np.zeros(len(self.operator.thresholds))

    def get_state(self):
        return tuple(float(z) for z in self.plays)

    def set_state(self, state):
        if len(state) != len(self.plays):
            raise ParameterError(f"{self.cause} state has {len(state)} values; the operator "
                                 f"has {len(self.plays)} plays")
        self.plays = np.array(state, dtype=float)
