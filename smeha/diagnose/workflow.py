"""The diagnosis from runs to answer: :func:`diagnose` and its result :class:`Diagnosis`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

import gmt
from gmt.errors import InputError

from ..measured import DataError
from ..plausibility import check_plausible
from .candidates import CAUSES, PAPER, Batch, Evaluator, candidates
from .decision import also_consistent, select
from .rules import CONFUSABLE_WITHOUT_B, within_noise
from .features import extract
from .fit import Fit, fit_all, fit_and_score, unfitted_kept

__all__ = ["Diagnosis", "default_holdout", "propagate_errors",
           "diagnose"]



@dataclass
class Diagnosis:
    """Result of :func:`diagnose`.

    ``cause`` is "none", "unexplained" or the first named cause; ``causes``
    every named cause in the order of contribution (empty for "none" and
    "unexplained"); ``extended`` the chosen model's fit (the paper's for
    "none"/"unexplained"); ``fits`` every single candidate, ``combinations``
    the combinations forward selection tried; ``skipped`` the runs not used,
    with the reason.
    """

    cause: str
    evidence: list
    heldout_runs: list
    training_runs: list
    paper: Fit
    extended: Fit
    fits: list
    noise_um: float
    characterisation: dict
    context: dict = field(repr=False, default=None)
    also_consistent: list = field(default_factory=list)
    combinations: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    #: the named causes in the order forward selection added them
    order: list = field(default_factory=list)
    #: why forward selection named no further cause (smeha.diagnose.decision.Selection)
    stopped: str = ""
    #: the channels the first cause was judged in where it did not pass the rule over all
    #: (smeha.diagnose.decision.Selection.first_in), else ()
    first_in: tuple = ()
    #: the combinations beside the density screened and not fitted in full
    #: (smeha.diagnose.joins.screened_round)
    screened: tuple = ()

    @property
    def causes(self) -> list:
        """Every named cause, in the order forward selection added them."""
        return list(self.order) if self.cause in CAUSES else []

    @property
    def form(self) -> str:
        """The form of the first named cause ("" when it has one form or none is named)."""
        if self.cause not in CAUSES:
            return ""
        return next(m.form for m in self.extended.candidate.members if m.cause == self.cause)

    @property
    def weak(self) -> bool:
        """True when the named model's parameters sit on bounds (a weak finding)."""
        return self.cause in CAUSES and self.extended.weak

    @property
    def sense(self) -> bool:
        """True when a training run has a sense voltage: the fit's B pins the strain
        scale, and the decision's rules with B apply (:func:`diagnose`)."""
        feats = self.context["features"]
        return any(feats[name].has_b for name in self.training_runs)

    @property
    def runs_without_sense_voltage(self) -> list:
        """Names of the runs without a sense voltage (B_m from the displacement)."""
        return [name for name, rf in self.context["features"].items() if not rf.has_b]

    @property
    def gain(self):
        """Held-out misfit of the paper's model over the extended one's (smeha.diagnose.fit)."""
        return self.paper.heldout_misfit / self.extended.heldout_misfit

    def variant(self) -> gmt.ModelVariant:
        """The extended model as a :class:`gmt.ModelVariant` (the paper's for none/unexplained)."""
        if self.cause not in CAUSES:
            return gmt.ModelVariant()
        comps = self.extended.candidate.components(self.extended.x, self.context["evaluator"]
                                                   .context)
        singles = [gmt.ModelVariant(cls.cause, values, cls.form) for cls, values in comps]
        return singles[0] if len(singles) == 1 else gmt.ModelVariant.combine(*singles)

    def as_dict(self) -> dict:
        """JSON-able report (the ``--json`` output; :mod:`smeha.diagnose.report`)."""
        from .report import as_dict

        return as_dict(self)


def default_holdout(runs) -> list[str]:
    """Names of the default held-out runs: every run at the held-out frequencies.

    Of the n sorted distinct frequencies: with at least seven, the
    second-lowest, the middle one (index (n - 1) // 2) and the second-highest;
    with five or six, the middle and the second-highest; with three or four,
    the middle one; fewer needs ``holdout`` explicitly. The held-out runs lie
    inside the trained range, and with seven or more frequencies a long
    low-frequency record is among them too (a drift shows over time, so in the
    long records of the low frequencies).
    """
    freqs = sorted({float(r.frequency) for r in runs})
    n = len(freqs)
    if n >= 7:
        chosen = {freqs[1], freqs[(n - 1) // 2], freqs[-2]}
    elif n >= 5:
        chosen = {freqs[(n - 1) // 2], freqs[-2]}
    elif n >= 3:
        chosen = {freqs[(n - 1) // 2]}
    else:
        raise InputError(f"{n} distinct frequencies: the default hold-out needs at "
                         "least 3; name the held-out runs (holdout=...)")
    return [r.name for r in runs if float(r.frequency) in chosen]


def _loss_start(train_runs, params):
    """Start values of the loss coefficients: the paper's procedure (smeha.identify)."""
    from .. import identify as identify_mod

    try:
        ident = identify_mod.identify(train_runs, params)
        loss0 = ident.loss_fit.values if ident.loss_fit is not None else None
    except (ValueError, gmt.ParameterError):
        loss0 = None
    if loss0 is None or not all(math.isfinite(v) for v in loss0):
        loss0 = (params.hysteresis_coefficient, params.steinmetz_exponent,
                 params.eddy_coefficient, params.excess_coefficient)
    return (max(loss0[0], 0.0), loss0[1], max(loss0[2], 0.0), max(loss0[3], 0.0))


def propagate_errors(ev, feats, base):
    """Carry the errors of what drives the model into the variances of the features.

    Per run: B_m's (measured, eq 22) into y's harmonics; the current's amplitude
    I_m (which sets H_m) into y's and B's; the current's phase phi, to which every
    feature is referred, as a rotation of the k-th harmonic X_k by k phi (error
    k |X_k| sigma_phi, split evenly between the real and imaginary parts). Each
    through the paper's model at the start values of the loss coefficients.
    Without a sense voltage B_m comes from y's own fundamental, whose error is
    y's noise, already counted.
    """
    for rf in feats:
        one = Batch([rf])
        k = np.arange(1, rf.y.size + 1)
        y0, b0, _, _ = ev.predict(one, base)
        y_var = 0.5 * (k * np.abs(rf.y) * math.sqrt(rf.current_phase_var)) ** 2
        b_var = np.zeros(rf.y.size)
        if rf.has_b:
            b_var = b_var + 0.5 * (k * np.abs(rf.b) * math.sqrt(rf.current_phase_var)) ** 2
            d = 1e-3 * rf.flux_density_amplitude
            y1 = ev.predict(one, base, flux=[rf.flux_density_amplitude + d])[0]
            y_var = y_var + 0.5 * (np.abs(y1[0] - y0[0]) / d * rf.flux_density_stderr) ** 2
        di = 1e-3 * rf.current_amplitude
        shifted = Batch([replace(rf, current_amplitude=rf.current_amplitude + di)])
        y2, b2, _, _ = ev.predict(shifted, base, flux=[rf.flux_density_amplitude])
        si = math.sqrt(rf.current_amplitude_var) / di
        y_var = y_var + 0.5 * (np.abs(y2[0] - y0[0]) * si) ** 2
        if rf.has_b:
            b_var = b_var + 0.5 * (np.abs(b2[0] - b0[0]) * si) ** 2
        rf.y_prop_var = y_var
        rf.b_prop_var = b_var


def _check_arguments(runs, holdout, causes):
    """ValueError for names that are not unique, unknown causes, unknown held-out runs."""
    names = [r.name for r in runs]
    if len(set(names)) != len(names):
        raise InputError("run names must be unique")
    unknown_c = [c for c in causes if c not in CAUSES]
    if unknown_c:
        raise InputError(f"unknown cause(s) {unknown_c}; choose from {CAUSES}")
    if holdout:
        unknown = [h for h in holdout if h not in names]
        if unknown:
            raise InputError(f"held-out run(s) {', '.join(map(repr, unknown))} not in the "
                             f"data (runs: {', '.join(names)})")


def _usable_features(runs, params):
    """The usable runs' features and the skipped runs (:func:`.features.extract`);
    DataError when no run is usable."""
    feats, skipped = extract(runs, params)
    if not feats:
        where = runs[0].source.rsplit(":", 1)[0] if runs and runs[0].source else "the data"
        raise DataError(f"{where}: no usable run: " + "; ".join(
            f"{n}: {why}" for n, why in skipped))
    return feats, skipped


def _heldout_and_training(runs, feats, skipped, holdout):
    """Names of the held-out runs (``holdout`` or :func:`default_holdout`) and the usable
    training runs; ValueError for a skipped held-out run or fewer than 4 training runs."""
    usable = [r for r in runs if r.name in feats]
    reasons = dict(skipped)
    if holdout:
        gone = [h for h in holdout if h in reasons]
        if gone:
            raise InputError("held-out run(s) cannot be used: " + "; ".join(
                f"{h!r} ({reasons[h]})" for h in gone))
        holdout = list(holdout)
    else:
        holdout = default_holdout(usable)
    train_runs = [r for r in usable if r.name not in holdout]
    if len(train_runs) < 4:
        raise InputError(f"{len(train_runs)} training run(s); the four loss coefficients of "
                         "eq 16 need at least 4 (hold out fewer runs)")
    return holdout, train_runs


def diagnose(runs, holdout=None, params: gmt.TransducerParameters | None = None,
             causes=CAUSES, workers: int | None = None) -> Diagnosis:
    """Fit, characterise, name the cause(s) and measure the gain (:mod:`smeha.diagnose`).

    Parameters
    ----------
    runs : sequence of Run
        Measured runs with current and displacement, and the sense voltage
        where measured (a run without it is compared on y alone).
    holdout : sequence of str, optional
        Names of the held-out runs; default :func:`default_holdout` of the
        usable runs.
    params : TransducerParameters, optional
        Rod, coil, magnetostriction and mechanics (default Table 2); its loss
        coefficients are only the fallback start values.
    causes : sequence of str
        Candidates to try (default all six).
    workers : int, optional
        Processes that fit independent candidates side by side (default
        :func:`smeha.pool.default_workers`: 2 on Linux); 1 fits them in this
        process. The answer does not depend on it.

    Raises
    ------
    DataError
        Implausible magnitudes (:func:`smeha.plausibility.check_plausible`), or
        no usable run.
    ValueError
        Unknown or skipped held-out names, too few training runs (fewer than
        4: the four loss coefficients).
    """
    from ..pool import one_blas_thread

    params = params or gmt.TransducerParameters()
    runs = list(runs)
    _check_arguments(runs, holdout, causes)
    # the fits run side by side, one a process: one BLAS thread each (smeha.pool)
    with one_blas_thread():
        return _diagnose(runs, holdout, params, causes, workers)


def _prepared(runs, holdout, params) -> tuple:
    """What every fit of a diagnosis shares, from plausible runs: (features by run name,
    skipped runs, held-out names, training runs, the evaluator, the base start values
    (K_h, n, K_e, K_ex, s), the training batch, the held-out batch)."""
    feats, skipped = _usable_features(runs, params)
    holdout, train_runs = _heldout_and_training(runs, feats, skipped, holdout)
    hmax = max(params.field_per_ampere * rf.current_amplitude for rf in feats.values())
    ev = Evaluator(params, hmax)
    base0 = _loss_start(train_runs, params) + (1.0,)
    propagate_errors(ev, feats.values(), base0)
    train = Batch([feats[r.name] for r in train_runs])
    held = Batch([feats[h] for h in holdout])
    return feats, skipped, holdout, train_runs, ev, base0, train, held


def _diagnose(runs, holdout, params, causes, workers) -> Diagnosis:
    """:func:`diagnose` on checked arguments."""
    from .progress import step
    from .report import characterise, evidence

    check_plausible(runs, params)
    feats, skipped, holdout, train_runs, ev, base0, train, held = _prepared(runs, holdout,
                                                                           params)
    context = {"params": params, "field_max": ev.field_max, "evaluator": ev,
               "features": feats}
    # the strain scale s is fitted with or without a sense voltage: without one each run's
    # B_m follows y's fundamental, and s shows in the harmonics' ratio to it (eq 25's
    # square law: Y_2 / Y_1^2 goes as 1 / s; smeha.diagnose.fit). The rules of the
    # decision differ with B present (sense)
    sense = bool(train.has_b.any())
    paper = fit_and_score(ev, train, held, PAPER, base0)
    step("single causes")
    # within noise the answer is "none" whatever the candidates give (decision.select's
    # first rule): they are not fitted
    tried = () if within_noise(paper) else candidates()[1:]
    jobs = [(cand, paper.base, None) for cand in tried if cand.cause in causes]
    # a candidate or combination that cannot be fitted is left out, and said so
    with unfitted_kept() as unfitted:
        done = fit_all(ev, train, held, jobs, workers)
        fits = [f for f in done if isinstance(f, Fit)]
        sel = select(ev, train, held, paper, fits, sense, workers)
    cause, chosen = sel.answer, sel.chosen
    character = characterise(ev, list(feats.values()), paper.base)
    noise = float(np.median([rf.noise_y for rf in feats.values()])) * 1e6
    diag = Diagnosis(cause=cause, evidence=[], heldout_runs=holdout,
                     training_runs=[r.name for r in train_runs], paper=paper,
                     extended=chosen, fits=fits, noise_um=noise,
                     characterisation=character, context=context,
                     also_consistent=also_consistent(paper, fits, chosen, cause),
                     combinations=sel.tried, skipped=skipped, order=sel.order,
                     stopped=sel.stopped, first_in=sel.first_in, screened=sel.screened)
    diag.evidence = evidence(diag) + [f"not fitted, left out: {why}" for why in unfitted]
    return diag
