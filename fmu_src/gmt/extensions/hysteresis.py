"""Rate-independent hysteresis: a Prandtl-Ishlinskii operator of the applied field.

The paper's complex permeability describes the loop at one operating point by
its first harmonic. A rate-independent hysteresis adds a loop that persists as
f -> 0, has pointed reversal tips and depends on the amplitude. It is written
here as a weighted sum of play (backlash) operators (Krasnosel'skii &
Pokrovskii 1989; Brokate & Sprekels 1996, ch. 2; Kuhnen 2003):

    P[H](t) = sum_j w_j F_{r_j}[H](t),
    F_r[H](t_k) = max(H_k - r, min(H_k + r, F_r[H](t_{k-1}))).

Only the part of P that is not its fundamental enters M: the paper's mu' and
mu'' are the describing function of the magnetisation at the operating point
(Gelb & Vander Velde 1968), measured through B_m and the losses, so the
operator's fundamental is already in them.

* periodic form: :meth:`PrandtlIshlinskii.periodic` in closed form for
  H = H_m cos(theta), its non-fundamental part added to M;
* time-stepped form: the plays advance with each held H
  (:meth:`PrandtlIshlinskii.step`) and M gains P[H] - (c_h H + c_q H_q), the
  operator's output minus its fundamental at the operating point,
  c_h - j c_q = (2 / (N H_m)) sum_n P_n e^{-j theta_n} over one period of
  N = :data:`GRID` samples, H_q = H_m sin(w t) the quadrature field of eq 31;
* parameters: the thresholds r_j [A/m] and weights w_j [-]; the diagnosis
  fixes the thresholds at 0.2, 0.4, 0.6, 0.8 of the largest field amplitude of
  the data and fits 10 w_j >= 0.

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

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ._base import Extension, FitSpec, Parameter, harmonic_remainder
from .magnetic import MagnetizationStage

#: Play-operator thresholds as fractions of the largest field amplitude of the data.
PLAY_THRESHOLDS = (0.2, 0.4, 0.6, 0.8)


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
        th = np.mod(np.asarray(phase, dtype=float), 2 * np.pi)
        hm = np.asarray(field_amplitude, dtype=float)
        h = hm * np.cos(th)
        falling = th <= np.pi
        out = np.zeros(np.broadcast(hm, th).shape)
        for r, w in zip(self.thresholds, self.weights):
            z = np.where(falling, np.minimum(hm - r, h + r), np.maximum(-hm + r, h - r))
            out += w * np.where(r < hm, z, 0.0)
        return out


class HysteresisForm(MagnetizationStage, Extension):
    """Prandtl-Ishlinskii hysteresis added to the paper's magnetisation (module docstring).

    Memory of the time-stepped form: the plays' outputs, [A/m] (zero: the
    demagnetised state).
    """

    cause = "rate_independent_hysteresis"
    stage = "magnetization"
    signals = "B and y"
    parameters = (Parameter("thresholds_A_per_m", "A/m", 0.0, math.inf, low_open=False,
                            is_list=True),
                  Parameter("weights", "-", is_list=True))
    fit = FitSpec(tuple(f"w_{k + 1}" for k in range(len(PLAY_THRESHOLDS))),
                  ((0.5,) * len(PLAY_THRESHOLDS), (0.05,) * len(PLAY_THRESHOLDS)),
                  (0.0,) * len(PLAY_THRESHOLDS), (100.0,) * len(PLAY_THRESHOLDS))

    @classmethod
    def validate(cls, values):
        cls.operator_of(values)

    @staticmethod
    def operator_of(values) -> PrandtlIshlinskii:
        """The operator of the SI parameters."""
        return PrandtlIshlinskii(tuple(values["thresholds_A_per_m"]), tuple(values["weights"]))

    @classmethod
    def from_fit(cls, x, context):
        return {"thresholds_A_per_m": list(context["thresholds"]),
                "weights": [0.1 * v for v in x]}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        # a weight at 0 is a play the data do not need, not a bound the fit pressed on
        return tuple(n for n, v in zip(cls.fit.names, x) if v >= cls.fit.upper[0] * (1 - tolerance))

    # periodic form
    @classmethod
    def steady_remainder(cls, values, steady, magnetization, theta):
        hm = np.asarray(steady.field_amplitude)[..., None]
        return harmonic_remainder(cls.operator_of(values).periodic(hm, theta))

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.operator = self.operator_of(values)
        self.plays = np.zeros(len(self.operator.thresholds))
        self.coefficients = self.fundamental(
            self.operator.periodic(point.field_amplitude, self.grid()))

    def addition(self, mag):
        out, self.plays = self.operator.step(mag.field, self.plays)
        return out

    def waveform(self, theta, upstream):
        return upstream(theta) + harmonic_remainder(
            self.operator.periodic(self.point.field_amplitude, theta))

    def reset(self, rest_displacement):
        self.plays = np.zeros(len(self.operator.thresholds))

    def get_state(self):
        return tuple(float(z) for z in self.plays)

    def set_state(self, state):
        if len(state) != len(self.plays):
            raise ParameterError(f"{self.cause} state has {len(state)} values; the operator "
                                 f"has {len(self.plays)} plays")
        self.plays = np.array(state, dtype=float)
