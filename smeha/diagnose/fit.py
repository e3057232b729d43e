"""Fitting a candidate on the training runs and scoring it on the held-out runs.

The unknowns are the four loss coefficients of eq 16 (K_h, n, K_e, K_ex),
shared by all runs and scaled by their start values, and the candidate's own
(:class:`smeha.diagnose.candidates.Candidate`). Least squares
(:func:`scipy.optimize.least_squares`, bounded) on the training features,
each residual over its standard deviation; every start vector is tried and
the best kept.

The **score** is the held-out chi^2 over every feature (y and B harmonics,
drift terms) plus k ln n for the k added parameters (the Bayesian information
criterion; Schwarz, Ann. Statist. 6 (1978) 461-464). The held-out RMS error of
y is over the samples of the held-out runs used for the features, with one
constant offset fitted per run (displacements are relative).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

import gmt

from .candidates import Batch, Candidate, Evaluator

LOSS_LOWER = (0.0, 1.0, 0.0, 0.0)
LOSS_UPPER = (np.inf, 3.0, np.inf, np.inf)
#: Most function evaluations of one start of a fit.
MAX_EVALUATIONS = 300


@dataclass
class Fit:
    """A candidate fitted on the training runs and scored on the held-out runs."""

    candidate: Candidate
    loss: tuple
    x: tuple
    train_chi2: float
    train_n: int
    heldout_chi2: float
    heldout_n: int
    heldout_chi2_y: float
    heldout_chi2_b: float
    heldout_chi2_drift: float
    heldout_rms: float
    score: float
    parameters: dict
    at_bounds: tuple = field(default=())

    @property
    def cause(self):
        return self.candidate.cause

    @property
    def causes(self):
        return self.candidate.causes

    @property
    def form(self):
        return self.candidate.form

    @property
    def label(self):
        return self.candidate.label

    @property
    def n_params(self):
        return self.candidate.n_params

    @property
    def heldout_excess(self):
        return self.heldout_chi2 - self.heldout_n

    @property
    def weak(self) -> bool:
        """True when an unknown sits on a bound the fit pressed on (a weak finding)."""
        return bool(self.at_bounds)


def _loss_scale(loss0):
    return np.array([max(abs(loss0[0]), 1.0), 1.0, max(abs(loss0[2]), 1.0),
                     max(abs(loss0[3]), 1.0)])


def fit_candidate(ev: Evaluator, train: Batch, cand: Candidate, loss0, starts=None) -> tuple:
    """Least squares on the training features: (loss, x, chi^2, number of residuals).

    ``starts`` replaces the candidate's own start vectors (e.g. a combination
    started from its members' fitted values).
    """
    scale = _loss_scale(loss0)
    factor = np.array([scale[0], 1.0, scale[2], scale[3]])
    l0 = np.clip(np.asarray(loss0, float), LOSS_LOWER, LOSS_UPPER) / factor
    l0[1] = min(max(loss0[1], 1.0 + 1e-6), 3.0 - 1e-6)
    lo = np.concatenate((LOSS_LOWER, cand.lower)).astype(float)
    hi = np.concatenate((LOSS_UPPER, cand.upper)).astype(float)

    def fun(x):
        return ev.residuals(train, tuple(x[:4] * factor), cand, tuple(x[4:]))

    best = None
    for start in (starts if starts is not None else cand.starts()):
        x0 = np.concatenate((l0, np.asarray(start, float)))
        pad = 1e-9 * (1.0 + np.abs(np.where(np.isfinite(lo), lo, 0.0)))
        x0 = np.minimum(np.maximum(x0, lo + pad), np.where(np.isfinite(hi), hi - pad, np.inf))
        try:
            sol = least_squares(fun, x0, bounds=(lo, hi), x_scale="jac",
                                max_nfev=MAX_EVALUATIONS, xtol=1e-10, ftol=1e-10)
        except (ValueError, gmt.ParameterError, FloatingPointError):
            continue
        if not np.isfinite(sol.cost):
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise ValueError(f"{cand.label}: no start of the fit gave a finite chi^2")
    loss = tuple(float(v) for v in best.x[:4] * factor)
    return loss, tuple(float(v) for v in best.x[4:]), float(2.0 * best.cost), int(best.fun.size)


def score(ev: Evaluator, cand: Candidate, loss, x, chi2_train, n_train, held: Batch) -> Fit:
    """The held-out score and RMS of a fitted candidate (module docstring)."""
    cy, cb, cd = ev.parts(held, loss, cand, x)
    n = sum(sum(ev.n_features(rf)) for rf in held.runs)
    sq, ns = 0.0, 0
    for rf in held.runs:
        r = rf.displacement - ev.samples(rf, loss, cand, x)
        sq += float(r @ r)
        ns += r.size
    chi = float(cy.sum() + cb.sum() + cd.sum())
    return Fit(candidate=cand, loss=loss, x=tuple(x), train_chi2=chi2_train, train_n=n_train,
               heldout_chi2=chi, heldout_n=n, heldout_chi2_y=float(cy.sum()),
               heldout_chi2_b=float(cb.sum()), heldout_chi2_drift=float(cd.sum()),
               heldout_rms=math.sqrt(sq / max(ns, 1)),
               score=chi + cand.n_params * math.log(max(n, 2)),
               parameters=cand.parameters(x, ev.context), at_bounds=cand.at_bounds(x))


def fit_and_score(ev, train, held, cand, loss0, starts=None) -> Fit:
    """:func:`fit_candidate` then :func:`score`."""
    loss, x, chi2, n = fit_candidate(ev, train, cand, loss0, starts)
    return score(ev, cand, loss, x, chi2, n, held)
