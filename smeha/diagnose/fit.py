"""Fitting a candidate on the training runs and scoring it on the held-out runs.

The unknowns are the base ones, the four loss coefficients of eq 16
(K_h, n, K_e, K_ex, scaled by their start values) and the strain scale s
(:mod:`smeha.diagnose.candidates`; without a sense voltage too: each run's B_m then
follows y's fundamental, and s shows in the harmonics' ratio to it, Y_2 / Y_1^2 going as
1 / s by eq 25's square law, though every magnetic nonlinearity changes that ratio too:
:func:`smeha.diagnose.report.scale_caution`), shared by all runs, and the
candidate's own (:class:`smeha.diagnose.candidates.Candidate`). Least squares
(:func:`scipy.optimize.least_squares`, bounded) on the training features,
each residual over its standard deviation; every start vector is tried and
the best kept.

The **score** is the held-out chi^2 over every feature (y and B harmonics,
drift terms), each residual over its feature's standard deviation, plus k ln n
for the k added parameters (the Bayesian information criterion; Schwarz, Ann.
Statist. 6 (1978) 461-464): how well the fitted model predicts runs it never
saw, at its fitted values. The candidates are *ranked* by the same criterion
over all the data, training and held-out together (:attr:`Fit.total_score`):
where the held-out features are few, or a formulation is not quite the data's,
the training runs carry evidence the held-out ones alone would miss; the
held-out score then decides whether the best-ranked model is named
(:mod:`smeha.diagnose.decision`).

Whether a model is within noise on the held-out runs asks more: the fitted
unknowns carry the uncertainty the training data leave them, so the held-out
residuals r have the covariance C = I + J_h Cov J_h^T, with J_h their Jacobian
in the unknowns and Cov = (J_t^T J_t)^-1 from the training fit's Jacobian J_t,
and the *predictive* chi^2 is r^T C^-1 r (of a linearised least-squares fit;
e.g. Seber & Wild, *Nonlinear Regression*, Wiley 1989, sec. 5.1;
``heldout_predictive_chi2``). Without it, four loss coefficients fitted within
noise on the training runs predict the held-out ones outside it, and a model
within noise would look like one that is not. It is not the score: it grows
lenient as a model's unknowns grow uncertain, which would favour a loosely
determined model over a sharp one.

Two held-out RMS errors of y are reported. ``heldout_rms``: over the samples of
the held-out runs used for the features, with one constant offset fitted per
run (displacements are relative); it includes the sensor's noise, so it cannot
fall below it. ``heldout_misfit``: the model against the deterministic part of
the measured y, the one the features hold (the noise averaged over the
periods): over one period the RMS of the difference of the harmonics,
sqrt(sum_k |dY_k|^2 / 2), and over the run the RMS of the difference of the
drift lines, (|d offset slope|^2 + |d Y_1 slope|^2 / 2) T^2 / 12 for a run of
duration T, summed in quadrature and averaged over the held-out runs. The
measured features carry the sensor's noise, whose share of that mean square is
known from their variances (per run, sum_k 2 var_k / 2 over the harmonics'
real components plus (var(offset slope) + var(Y_1 slope)) T^2 / 12): it is
subtracted, so that the misfit estimates the model's distance from the
deterministic y whatever the sampling (with fewer samples a period the noise's
share is larger, and a good model's misfit would otherwise be the noise's). It
is floored at the noise share's own scatter, sqrt(2 / m) of it for m real
features (a chi^2 with m degrees of freedom), below which no misfit can be told
from zero. ``heldout_noise_misfit`` is the noise's share alone. The gain of a
model (:attr:`smeha.diagnose.Diagnosis.gain`) is the ratio of misfits, so it
measures the model and not the sensor or the sampling.
"""
from __future__ import annotations

import contextlib
import contextvars
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares

from .baseunknowns import BASE_LOWER, BASE_UPPER, base_factor
from .candidates import Batch, Candidate, Evaluator, harmonic_chi2, parts_of
from .differences import jacobian, relative_steps, scipy_steps
from .linearfit import fit_linear, linear_member

__all__ = ["BASE_LOWER", "BASE_UPPER", "FIRST_EVALUATIONS", "HIGHER_FROM", "LEVEL_GAP",
           "MAX_EVALUATIONS", "UNEVALUATED", "Fit", "base_factor", "drive_levels",
           "fit_candidate", "solver_method", "predictive_chi2", "score", "fit_and_score",
           "fit_all"]

#: Most function evaluations of one start of a fit.
MAX_EVALUATIONS = 300
#: Most function evaluations of the dogbox fit that starts a fit whose members ask for it
#: (:func:`solver_method`), before trf's.
FIRST_EVALUATIONS = 60
#: The held-out harmonics from this one up are counted apart (:attr:`Fit.heldout_chi2_higher`):
#: those a nonlinearity of M shows beyond a change of the fundamental (y's second follows
#: the fundamental through eq 25's square law; B's and y's third and up do not).
HIGHER_FROM = 3
#: What a model raises at unknowns it is not defined for (gmt.ParameterError is a
#: ValueError): a start vector that raises one is passed over.
UNEVALUATED = (ValueError, FloatingPointError)
#: Runs whose current amplitudes I_m lie within this fraction of the next larger one are one
#: drive level (:func:`drive_levels`): a lab sets its amplitudes in steps far coarser (the
#: paper's runs: 0.6 and 1 A) than its current regulation holds them (the outside lab A
#: file: peak currents from 0.603 to 0.606 A at its lower level, 1.003 to 1.006 A at its upper).
LEVEL_GAP = 0.1


@dataclass
class Fit:
    """A candidate fitted on the training runs and scored on the held-out runs."""

    candidate: Candidate
    base: tuple  # (K_h, n, K_e, K_ex, s)
    x: tuple
    train_chi2: float
    train_n: int
    heldout_chi2: float
    heldout_predictive_chi2: float
    heldout_n: int
    heldout_chi2_y: float
    heldout_chi2_b: float
    heldout_chi2_drift: float
    heldout_rms: float
    heldout_misfit: float
    score: float
    heldout_noise_misfit: float
    parameters: dict
    at_bounds: tuple = field(default=())
    #: the effective number of added parameters when it is not their count (a penalised
    #: linear family, smeha.diagnose.linearfit); None: the count
    effective_params: float | None = None
    #: held-out features of y, of B and of the drift terms
    heldout_n_parts: tuple = (0, 0, 0)
    #: held-out chi^2 of y's and B's harmonics from :data:`HIGHER_FROM` up, and their number
    #: of features (a part of heldout_chi2_y and heldout_chi2_b)
    heldout_chi2_higher: float = 0.0
    heldout_n_higher: int = 0
    #: the current amplitude I_m of each held-out run, [A], and its held-out excess chi^2
    #: (chi^2 - n) of y, of B and of the drift terms (the per-run parts of the totals)
    heldout_run_amplitudes: tuple = ()
    heldout_run_excess: tuple = ()
    #: the CPU time its fit and score took, [s]: what the next fits of the same candidate
    #: may cost (:func:`fit_all`'s ``costs``), not a property of the model
    seconds: float = field(default=0.0, compare=False)

    def _heldout_part(self, channel) -> tuple:
        """(chi^2, number of features) of the held-out ``channel`` ("y", "B", "drift")."""
        chi = {"y": self.heldout_chi2_y, "B": self.heldout_chi2_b,
               "drift": self.heldout_chi2_drift}[channel]
        return chi, dict(zip(("y", "B", "drift"), self.heldout_n_parts))[channel]

    def measured_of(self, channels) -> tuple:
        """Those of ``channels`` ("y", "B", "drift") that have held-out features (no B
        without a sense voltage)."""
        return tuple(c for c in channels if self._heldout_part(c)[1] > 0)

    def heldout_excess_in(self, channels) -> float:
        """chi^2 - n over the held-out features of ``channels`` ("y", "B", "drift")."""
        return sum(chi - n for chi, n in map(self._heldout_part, channels))

    def heldout_excess_by_level(self, channels) -> dict:
        """{I_m of a drive level [A]: held-out excess chi^2 of ``channels`` over its runs}
        (levels: :func:`drive_levels`; {} without per-run parts)."""
        idx = [("y", "B", "drift").index(c) for c in channels]
        out = {}
        for level, runs in drive_levels(self.heldout_run_amplitudes):
            out[level] = float(sum(self.heldout_run_excess[r][i] for r in runs for i in idx))
        return out

    def heldout_dispersion(self, channel) -> float:
        """chi^2 per held-out feature of ``channel`` ("y", "B", "drift"): about 1 where the
        model is within noise, the square of its misfit over the noise where its form is
        off (0 for a channel without features)."""
        return self.heldout_dispersion_in((channel,))

    def heldout_dispersion_in(self, channels) -> float:
        """chi^2 per held-out feature over ``channels`` together (as
        :meth:`heldout_dispersion`; 0 where they have no features)."""
        parts = [self._heldout_part(c) for c in channels]
        n = sum(n for _, n in parts)
        return sum(chi for chi, _ in parts) / n if n else 0.0

    @property
    def loss(self):
        """(K_h, n, K_e, K_ex) of eq 16."""
        return self.base[:4]

    @property
    def strain_scale(self):
        """s = K_lambda / K_lambda of Table 2, [-]."""
        return self.base[4]

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
    def k(self) -> float:
        """The added parameters the score charges: their count, or the effective number
        of a penalised linear family (smeha.diagnose.linearfit)."""
        return self.n_params if self.effective_params is None else self.effective_params

    @property
    def heldout_excess(self):
        return self.heldout_chi2 - self.heldout_n

    @property
    def total_score(self):
        """chi^2 of the training and the held-out features plus k ln n over both: how well
        the model describes all the data (module docstring; the ranking)."""
        n = self.train_n + self.heldout_n
        return self.train_chi2 + self.heldout_chi2 + self.k * math.log(max(n, 2))

    @property
    def weak(self) -> bool:
        """True when an unknown sits on a bound the fit pressed on (a weak finding)."""
        return bool(self.at_bounds)


def _split(z, nb, base0, factor):
    """(base, x) of the fit's unknowns ``z`` (the first ``nb`` are the base's)."""
    base = np.array(base0, float)
    base[:nb] = z[:nb] * factor[:nb]
    return tuple(float(v) for v in base), tuple(float(v) for v in z[nb:])


class _Training:
    """The training residuals of ``cand``, one vector or several stacked: the problem
    :func:`fit_candidate` solves unless it is given another."""

    def __init__(self, ev: Evaluator, train: Batch, cand: Candidate):
        self.ev, self.train, self.cand = ev, train, cand

    def residuals(self, base, x):
        return self.ev.residuals(self.train, base, self.cand, x)

    def stacked(self, points):
        return self.ev.residuals_stacked(self.train, points, self.cand)


def solver_method(cand: Candidate) -> str:
    """How ``cand``'s fit starts: "dogbox" where a member's unknowns ask for it
    (:attr:`gmt.extensions.FitSpec.method`; at most :data:`FIRST_EVALUATIONS` evaluations
    of scipy's dogbox method, then trf from where it ended), else "trf" alone.

    Both are scipy's bounded trust-region methods (trf: Branch, Coleman & Li, SIAM J. Sci.
    Comput. 21 (1999) 1-23; dogbox: Voglis & Lagaris, WSEAS 2004). Where the chi^2 valley
    is long and curved, trf's scaling by the distance to the bounds shrinks its steps along
    it: the saturation law's exponents against M_b/M_s on labsim's Langevin law (seed 3 at
    800 samples a period) took trf its 300 evaluations, still 1.4 of chi^2 short of the
    optimum, and dogbox 35 to it. Where the optimum lies on a bound, dogbox crawls and trf
    does not (the saturation law on smeha.synthetic's saturated rod, seed 3, most runs
    without a sense voltage: dogbox alone ended after 300 evaluations 143 of chi^2 above
    the optimum trf reached in 71); the two in turn reach that optimum in 60 + 27.
    """
    return "dogbox" if any(m.fit.method == "dogbox" for m in cand.members) else "trf"


def _dogbox_start(fun, jac, z0, lo, hi) -> np.ndarray:
    """Where at most :data:`FIRST_EVALUATIONS` of scipy's dogbox from ``z0`` end (z0 where
    they fail)."""
    try:
        first = least_squares(fun, z0, jac=jac, bounds=(lo, hi), x_scale="jac",
                              method="dogbox", max_nfev=FIRST_EVALUATIONS, xtol=1e-10,
                              ftol=1e-10)
    except UNEVALUATED:
        return z0
    return first.x if np.isfinite(first.cost) else z0


def fit_candidate(ev: Evaluator, train: Batch, cand: Candidate, base0, starts=None,
                  problem=None, max_evaluations=MAX_EVALUATIONS) -> tuple:
    """Least squares on the training features: (base, x, chi^2, residuals, cov).

    ``base0`` is (K_h, n, K_e, K_ex, s) to start from; ``starts`` replaces the
    candidate's own start
    vectors (e.g. a combination started from its members' fitted values).
    ``cov`` is the covariance (J^T J)^-1 of the unknowns (the base ones over
    :func:`base_factor`, then the candidate's), [-]. ``problem`` replaces the training
    residuals of ``cand``: an object with ``residuals(base, x)`` and ``stacked(points)``
    (one row per (base, x); the linear family's fit holds its weights in it,
    :mod:`smeha.diagnose.linearfit`). The Jacobian is scipy's forward differences
    ('2-point'), its columns evaluated together (:mod:`smeha.diagnose.differences`); the
    method :func:`solver_method`'s.
    """
    nb = len(BASE_LOWER)
    factor = base_factor(base0)
    b0 = np.clip(np.asarray(base0, float), BASE_LOWER, BASE_UPPER) / factor
    b0[1] = min(max(base0[1], 1.0 + 1e-6), 3.0 - 1e-6)
    lo = np.concatenate((BASE_LOWER[:nb], cand.lower)).astype(float)
    hi = np.concatenate((BASE_UPPER[:nb], cand.upper)).astype(float)
    problem = _Training(ev, train, cand) if problem is None else problem

    def fun(z):
        return problem.residuals(*_split(z, nb, base0, factor))

    def stacked(zs):
        return problem.stacked([_split(z, nb, base0, factor) for z in zs])

    def jac(z):
        return jacobian(stacked, z, scipy_steps(z, lo, hi))[0]

    best = None
    for start in (starts if starts is not None else cand.starts()):
        z0 = np.concatenate((b0[:nb], np.asarray(start, float)))
        pad = 1e-9 * (1.0 + np.abs(np.where(np.isfinite(lo), lo, 0.0)))
        z0 = np.minimum(np.maximum(z0, lo + pad), np.where(np.isfinite(hi), hi - pad, np.inf))
        if solver_method(cand) == "dogbox":
            z0 = _dogbox_start(fun, jac, z0, lo, hi)
        try:
            sol = least_squares(fun, z0, jac=jac, bounds=(lo, hi), x_scale="jac",
                                max_nfev=max_evaluations, xtol=1e-10, ftol=1e-10)
        except UNEVALUATED:
            continue
        if not np.isfinite(sol.cost):
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise ValueError(f"{cand.label}: no start of the fit gave a finite chi^2")
    base, x = _split(best.x, nb, base0, factor)
    cov = np.linalg.pinv(best.jac.T @ best.jac)
    return base, x, float(2.0 * best.cost), int(best.fun.size), cov


def drive_levels(amplitudes) -> list:
    """[(I_m of the level [A], indices of its runs)] of current amplitudes ``amplitudes``
    [A], the levels rising: sorted, a new level where an amplitude exceeds the one before
    by more than :data:`LEVEL_GAP` of it; a level's I_m is its runs' mean."""
    order = np.argsort(amplitudes, kind="stable")
    groups = []
    for i in order:
        a = float(amplitudes[i])
        if groups and a <= amplitudes[groups[-1][-1]] * (1.0 + LEVEL_GAP):
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
    return [(float(np.mean([amplitudes[i] for i in g])), g) for g in groups]


def predictive_chi2(ev: Evaluator, held: Batch, cand: Candidate, base, x, cov) -> float:
    """chi^2 of the held-out residuals with the fit's own uncertainty (module docstring)."""
    factor = base_factor(base)
    nb = cov.shape[0] - len(x)
    z0 = np.concatenate((np.asarray(base[:nb]) / factor[:nb], np.asarray(x, float)))
    upper = np.concatenate((BASE_UPPER[:nb], cand.upper))

    def stacked(zs):
        return ev.residuals_stacked(held, [_split(z, nb, base, factor) for z in zs], cand)

    # an unknown the fit held (a density's weight at zero: its row and column of cov are
    # zero, smeha.diagnose.linearfit) adds nothing to J Cov J^T: its column is not needed
    # (most of a density's weights; each column costs a held-out evaluation); steps into
    # the allowed range
    jac, r = jacobian(stacked, z0, relative_steps(z0, upper),
                      columns=np.flatnonzero(np.any(cov != 0.0, axis=1)))
    jac = np.ascontiguousarray(jac)  # C order: the products round as before the stacking
    c = np.eye(r.size) + jac @ cov @ jac.T
    return float(r @ np.linalg.solve(c, r))


def score(ev: Evaluator, cand: Candidate, base, x, chi2_train, n_train, held: Batch,
          cov=None, k=None) -> Fit:
    """The held-out score and RMS of a fitted candidate (module docstring); ``k`` the
    effective number of its added parameters when it is not their count."""
    predicted = ev.predict(held, base, cand, x)
    y, b, s_off, s_y1 = predicted
    cy, cb, cd = parts_of(held, *predicted)
    n_runs = np.array([ev.n_features(rf) for rf in held.runs], float)
    n_parts = tuple(int(v) for v in np.sum(n_runs, axis=0))
    n = sum(n_parts)
    run_excess = tuple(tuple(float(v) for v in row)
                       for row in np.column_stack((cy, cb, cd)) - n_runs)
    higher = slice(HIGHER_FROM - 1, None)
    chi_higher = float(sum(np.sum(c[:, higher]) for c in harmonic_chi2(held, y, b)))
    n_higher = 2 * y[:, higher].shape[1] * (len(held) + int(np.sum(held.has_b)))
    span = np.array([rf.time[-1] - rf.time[0] for rf in held.runs])
    misfit2 = (0.5 * np.sum(np.abs(y - held.y) ** 2, axis=1)
               + (np.abs(s_off - held.drift) ** 2 + 0.5 * np.abs(s_y1 - held.y1_slope) ** 2)
               * span ** 2 / 12.0)
    noise2 = (np.sum(held.y_sd ** 2, axis=1)
              + (held.drift_sd ** 2 + held.y1_slope_sd ** 2) * span ** 2 / 12.0)
    m = held.y.shape[1] * 2 + 3
    floor2 = float(np.mean(noise2)) * math.sqrt(2.0 / (m * len(held)))
    sq, ns = 0.0, 0
    for rf in held.runs:
        r = rf.displacement - ev.samples(rf, base, cand, x)
        sq += float(r @ r)
        ns += r.size
    chi = float(cy.sum() + cb.sum() + cd.sum())
    pred = chi if cov is None else predictive_chi2(ev, held, cand, base, x, cov)
    return Fit(candidate=cand, base=tuple(base), x=tuple(x), train_chi2=chi2_train, train_n=n_train,
               heldout_chi2=chi, heldout_predictive_chi2=pred, heldout_n=n,
               heldout_chi2_y=float(cy.sum()),
               heldout_chi2_b=float(cb.sum()), heldout_chi2_drift=float(cd.sum()),
               heldout_rms=math.sqrt(sq / max(ns, 1)),
               heldout_misfit=math.sqrt(max(float(np.mean(misfit2 - noise2)), floor2)),
               heldout_noise_misfit=math.sqrt(float(np.mean(noise2))),
               score=chi + (cand.n_params if k is None else k) * math.log(max(n, 2)),
               parameters=cand.parameters(x, ev.context), at_bounds=cand.at_bounds(x),
               effective_params=k, heldout_n_parts=n_parts,
               heldout_chi2_higher=chi_higher, heldout_n_higher=n_higher,
               heldout_run_amplitudes=tuple(float(rf.current_amplitude) for rf in held.runs),
               heldout_run_excess=run_excess)


def fit_and_score(ev, train, held, cand, base0, starts=None, screen=False) -> Fit:
    """:func:`fit_candidate` (or, for a linear family, :func:`smeha.diagnose.linearfit.fit_linear`)
    then :func:`score`; ``screen``: a linear family's screen (fit_linear), scored without
    the fit's own uncertainty (its predictive chi^2 is its chi^2)."""
    began = time.process_time()
    if linear_member(cand) is not None:
        base, x, chi2, n, cov, k = fit_linear(ev, train, cand, base0, fit_candidate,
                                              start=starts[0] if starts else None,
                                              screen=screen)
        out = score(ev, cand, base, x, chi2, n, held, cov, k=k)
    else:
        base, x, chi2, n, cov = fit_candidate(ev, train, cand, base0, starts)
        out = score(ev, cand, base, x, chi2, n, held, cov)
    return replace(out, seconds=time.process_time() - began)


def _fit_or_reason(ev, train, held, cand, base0, starts, screen=False):
    """:func:`fit_and_score`, or the reason (the candidate's label and the ValueError's
    message) when the fit fails."""
    try:
        return fit_and_score(ev, train, held, cand, base0, starts=starts, screen=screen)
    except ValueError as exc:
        reason = str(exc)
        return reason if reason.startswith(cand.label) else f"{cand.label}: {reason}"


_UNFITTED = contextvars.ContextVar("unfitted", default=None)


@contextlib.contextmanager
def unfitted_kept():
    """Within it, the reason of every fit of :func:`fit_all` that failed is kept, in the
    order of the batches, in the list it yields (a diagnosis reports the candidates and
    combinations it could not fit; the selection goes on without them)."""
    kept = []
    token = _UNFITTED.set(kept)
    try:
        yield kept
    finally:
        _UNFITTED.reset(token)


def fit_all(ev, train, held, jobs, workers=None, costs=None) -> list:
    """:func:`fit_and_score` of independent candidates, side by side in ``workers``
    processes (:func:`smeha.pool.run_jobs`; default :func:`smeha.pool.default_workers`).

    ``jobs`` holds (candidate, base0, starts) tuples, or (candidate, base0, starts,
    screen) for a linear family's screen (:func:`fit_and_score`); the result holds, in
    job order, each one's :class:`Fit` or, where its fit failed, the reason (str; kept
    also where :func:`unfitted_kept` collects them). The
    fits do not depend on each other, so the result does not depend on ``workers``.
    ``costs`` (one number a job, e.g. the seconds of an earlier fit of its candidate):
    the jobs are handed to the workers the costliest first (the longest-processing-time
    rule; Graham, SIAM J. Appl. Math. 17 (1969) 416-429), which ends a batch sooner than
    a long fit handed out last; the result stays in job order.
    """
    from ..pool import default_workers, run_jobs
    from .progress import bar_settings

    workers = default_workers() if workers is None else workers
    order = (list(range(len(jobs))) if costs is None
             else sorted(range(len(jobs)), key=lambda i: -costs[i]))
    desc, quiet = bar_settings()
    done = run_jobs(_fit_or_reason, [(ev, train, held) + tuple(jobs[i]) for i in order],
                    workers, desc=desc, unit="fit", quiet=quiet)
    out = [None] * len(jobs)
    for i, result in zip(order, done):
        out[i] = result
    kept = _UNFITTED.get()
    if kept is not None:
        kept.extend(r for r in out if not isinstance(r, Fit) and r not in kept)
    return out

