"""The models the diagnosis compares: the paper's, one extension, or several.

A :class:`Candidate` is a set of extensions of :data:`gmt.extensions.REGISTRY`
(empty: the paper's model). Its unknowns are its members' (each extension's
:class:`gmt.extensions.FitSpec`), shared by all runs; the paper's own
unknowns are fitted with them (:mod:`smeha.diagnose.fit`): the loss
coefficients of eq 16 and the strain scale s, K_lambda of eq 25 over Table 2's
(a transducer's magnetostriction coefficient is its own, as its losses are:
without it every static gain difference between a user's transducer and
Table 2 would be blamed on an effect). The *base* unknowns are
(K_h, n, K_e, K_ex, s).

The :class:`Evaluator` gives a candidate's features for a batch of runs: the
periodic steady state of the paper's model plus the members
(:func:`gmt.extensions.steady.steady_state`, the **continuous** model of
eq 27: the features do not depend on how the data were sampled), the drift
slopes of the thermal drift, and, for a run without a sense voltage, B_m
as that run's own unknown: started from y's fundamental through the
candidate's own path from M to y
(:func:`gmt.extensions.steady.flux_density_from_ratio`), it takes one
Gauss-Newton step (in ln B_m) on the run's y harmonics, so that a candidate
that changes the fundamental in a way the path does not (saturation's bias)
is judged on the rest. The step is held within a trust region
(:data:`LN_FLUX_STEP`): where y is flat in B_m (a Preisach density that adds
most of the fundamental) one linearised step overshoots, and a run predicted
at three times its measured stroke decided the fit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gmt import extensions as ext
from gmt.extensions.steady import flux_density_from_ratio, steady_state

from .features import HARMONICS

__all__ = ["CAUSES", "FORMS", "label", "Candidate", "PAPER", "candidates", "Batch",
           "harmonic_chi2", "parts_of", "Evaluator"]

CAUSES = ext.CAUSES
#: The forms of the causes with several (the first is the default).
FORMS = ext.FORMS


#: The display name of a cause's form that the registry leaves unnamed (its default form).
DEFAULT_FORM_NAMES = {"rate_independent_hysteresis": "play_operators"}


def label(cls) -> str:
    """Display name of an extension: the cause, with its form when it has several (a
    default form by :data:`DEFAULT_FORM_NAMES`)."""
    if cls.cause not in FORMS:
        return cls.cause
    return f"{cls.cause} ({cls.form or DEFAULT_FORM_NAMES.get(cls.cause, 'default')})"


@dataclass(frozen=True)
class Candidate:
    """The paper's model plus ``members`` (extension classes, in stage order)."""

    members: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "members", ext.ordered(self.members))

    @property
    def cause(self) -> str:
        """"none" for the paper's model, else the first member's cause."""
        return self.members[0].cause if self.members else "none"

    @property
    def causes(self) -> tuple:
        return tuple(m.cause for m in self.members)

    @property
    def form(self) -> str:
        return self.members[0].form if self.members else ""

    @property
    def label(self) -> str:
        return " + ".join(label(m) for m in self.members) if self.members else "paper"

    @property
    def names(self) -> tuple:
        """The unknowns, prefixed by their member's cause for a combination."""
        if len(self.members) == 1:
            return self.members[0].fit.names
        return tuple(f"{m.cause}.{n}" for m in self.members for n in m.fit.names)

    @property
    def n_params(self) -> int:
        return sum(m.fit.size for m in self.members)

    @property
    def lower(self) -> tuple:
        return tuple(v for m in self.members for v in m.fit.lower)

    @property
    def upper(self) -> tuple:
        return tuple(v for m in self.members for v in m.fit.upper)

    def starts(self) -> list:
        """Start vectors: every start of each member, the others at their first start."""
        if not self.members:
            return [()]
        firsts = [m.fit.starts[0] for m in self.members]
        out = []
        for k, m in enumerate(self.members):
            for s in m.fit.starts:
                vec = tuple(v for j, f in enumerate(firsts) for v in (s if j == k else f))
                if vec not in out:
                    out.append(vec)
        return out

    def split(self, x) -> list:
        """``x`` cut into the members' unknowns."""
        out, k = [], 0
        for m in self.members:
            out.append(tuple(x[k:k + m.fit.size]))
            k += m.fit.size
        return out

    def components(self, x, context) -> tuple:
        """(extension class, SI parameters) of each member for unknowns ``x``."""
        return tuple((m, m.from_fit(xm, context)) for m, xm in zip(self.members, self.split(x)))

    def stacked_components(self, xs, context, runs):
        """:meth:`components` for a batch of ``runs`` runs stacked once per x of ``xs``, copy
        after copy (:meth:`Evaluator.residuals_stacked`): a member whose unknowns are the same
        in every x as usual, one whose unknowns differ in its values per run
        (``stack_values``), or None where such a member's form cannot take them per run."""
        out = []
        parts = [self.split(x) for x in xs]
        for k, m in enumerate(self.members):
            mine = [p[k] for p in parts]
            if all(v == mine[0] for v in mine):
                out.append((m, m.from_fit(mine[0], context)))
                continue
            values = m.stack_values([m.from_fit(v, context) for v in mine], runs)
            if values is None:
                return None
            out.append((m, values))
        return tuple(out)

    def unstacked_part(self, x, context) -> tuple:
        """The unknowns in ``x`` of the members whose form takes its parameters for all
        runs only (``stack_values`` of one copy is None): points that share them are
        evaluated stacked (:meth:`Evaluator.residuals_stacked`)."""
        return tuple(xm for m, xm in zip(self.members, self.split(x))
                     if m.stack_values([m.from_fit(xm, context)], 1) is None)

    def parameters(self, x, context) -> dict:
        """The SI parameters: the member's, or by member variant name for a combination."""
        comps = self.components(x, context)
        if len(comps) == 1:
            return comps[0][1]
        return {ext.variant_name(m.cause, m.form): v for m, v in comps}

    def at_bounds(self, x) -> tuple:
        """The unknowns on a bound the fit pressed on
        (:meth:`gmt.extensions.Extension.at_bounds`)."""
        if len(self.members) == 1:
            return self.members[0].at_bounds(x)
        return tuple(f"{m.cause}.{n}" for m, xm in zip(self.members, self.split(x))
                     for n in m.at_bounds(xm))

    def plus(self, member) -> "Candidate":
        """This candidate with one more extension (raises ParameterError if they cannot combine)."""
        return Candidate(self.members + (member,))

    def combinable(self, member) -> bool:
        """True when ``member`` may join (another cause, a stage with room)."""
        try:
            ext.ordered(self.members + (member,))
        except ext.ParameterError:
            return False
        return True


PAPER = Candidate()


def candidates() -> tuple:
    """The paper's model and every single extension (every form of every cause)."""
    return (PAPER,) + tuple(Candidate((e,)) for e in ext.EXTENSIONS)


class Batch:
    """Features of several runs as arrays, for one vectorised evaluation."""

    def __init__(self, feats):
        self.runs = list(feats)
        self.frequency = np.array([rf.frequency for rf in feats])
        self.current_amplitude = np.array([rf.current_amplitude for rf in feats])
        self.flux_density_amplitude = np.array([rf.flux_density_amplitude for rf in feats])
        self.has_b = np.array([rf.has_b for rf in feats], dtype=bool)
        self.ratio = np.array([rf.magnetization_ratio if rf.magnetization_ratio is not None
                               else 0.0 for rf in feats], dtype=complex)
        self.y = np.array([rf.y for rf in feats])
        self.b = np.array([rf.b if rf.has_b else np.zeros_like(rf.y) for rf in feats])
        self.y_sd = self.b_sd = None
        self.drift = np.array([rf.offset_slope for rf in feats])
        self.drift_sd = np.array([math.sqrt(rf.offset_slope_var) for rf in feats])
        self.y1_slope = np.array([rf.y1_slope for rf in feats])
        self.y1_slope_sd = np.array([math.sqrt(rf.y1_slope_var) for rf in feats])
        self.refresh()

    def refresh(self):
        """Re-read the variances (after the drive's errors were carried into them)."""
        def extra(v):
            return 0.0 if v is None else v

        self.y_sd = np.array([np.sqrt(rf.y_var + extra(rf.y_prop_var)) for rf in self.runs])
        self.b_sd = np.array([np.sqrt(rf.b_var + extra(rf.b_prop_var)) if rf.has_b
                              else np.ones(rf.y.size) for rf in self.runs])
        self.__dict__.pop("_stacks", None)

    def __len__(self):
        return len(self.runs)

    #: Stacked batches kept (:meth:`stacked`), the most recently made.
    STACKS_KEPT = 8

    def stacked(self, copies: int) -> "Batch":
        """These runs ``copies`` times over, copy after copy (one evaluation of several
        parameter vectors, :meth:`Evaluator.residuals_stacked`); the last
        :data:`STACKS_KEPT` sizes are kept for the next calls."""
        if copies == 1:
            return self
        cache = self.__dict__.setdefault("_stacks", {})
        if copies not in cache:
            while len(cache) >= self.STACKS_KEPT:
                cache.pop(next(iter(cache)))
            out = Batch.__new__(Batch)
            out.runs = self.runs * copies
            for name in ("frequency", "current_amplitude", "flux_density_amplitude", "has_b",
                         "ratio", "drift", "drift_sd", "y1_slope", "y1_slope_sd"):
                setattr(out, name, np.tile(getattr(self, name), copies))
            for name in ("y", "b", "y_sd", "b_sd"):
                setattr(out, name, np.tile(getattr(self, name), (copies, 1)))
            cache[copies] = out
        return cache[copies]

    def __getstate__(self):
        # the stacked copies are rebuilt where needed, not sent to the workers
        return {k: v for k, v in self.__dict__.items() if k != "_stacks"}


#: Largest change of ln B_m of the Gauss-Newton step of a run without B (predict).
LN_FLUX_STEP = 0.3
#: Relative step of B_m for that step's derivative: well above the error left by the
#: iteration that solves the paper's part for B_m (gmt.extensions.paperpart.
#: paper_permeability), whose count depends on the other runs evaluated with it; at 1e-6
#: the derivative of one run changes with the batch it is evaluated in.
FLUX_DIFFERENCE_STEP = 1e-4


def harmonic_chi2(batch: Batch, y, b) -> tuple:
    """chi^2 of each harmonic of each run, (runs, K), of y and of B (0 for runs without
    B), of the predicted harmonics ``y`` [m] and ``b`` [T] against ``batch``'s."""
    dy = np.abs((y - batch.y) / batch.y_sd) ** 2
    db = np.where(batch.has_b[:, None], np.abs((b - batch.b) / batch.b_sd) ** 2, 0.0)
    return dy, db


def parts_of(batch: Batch, y, b, s_off, s_y1) -> tuple:
    """chi^2 per run of y (harmonics), of B (0 without B), of the drift features, of a
    prediction (:meth:`Evaluator.predict`'s tuple)."""
    dy, db = harmonic_chi2(batch, y, b)
    ds = np.abs((s_y1 - batch.y1_slope) / batch.y1_slope_sd) ** 2
    cd = ((s_off - batch.drift) / batch.drift_sd) ** 2 + ds
    return np.sum(dy, axis=1), np.sum(db, axis=1), cd


def _residual_rows(batch: Batch, predicted, copies: int) -> np.ndarray:
    """(copies, n): the residuals of :meth:`Evaluator.residuals` of each copy of a batch
    stacked ``copies`` times (:meth:`Batch.stacked`; 1: ``batch`` itself), from
    :meth:`Evaluator.predict`'s tuple."""
    y, b, s_off, s_y1 = predicted
    dy = ((y - batch.y) / batch.y_sd).reshape(copies, -1)
    parts = [dy.real, dy.imag]
    if batch.has_b.any():
        db = ((b - batch.b) / batch.b_sd)[batch.has_b].reshape(copies, -1)
        parts += [db.real, db.imag]
    ds = ((s_y1 - batch.y1_slope) / batch.y1_slope_sd).reshape(copies, -1)
    parts += [((s_off - batch.drift) / batch.drift_sd).reshape(copies, -1), ds.real, ds.imag]
    return np.hstack(parts)


class Evaluator:
    """Periodic steady state of candidates for batches of runs (module docstring)."""

    def __init__(self, params, field_max, harmonics=HARMONICS):
        """``field_max``: the largest field amplitude of the data, [A/m] (the play grid)."""
        self.params = params
        self.field_max = float(field_max)
        self.k = np.arange(1, harmonics + 1)
        self.context = {"params": params, "field_max": self.field_max}

    def predict(self, batch: Batch, base, cand: Candidate = PAPER, x=(), flux=None,
                components=None):
        """(Y_k [m], B_k [T], offset slope [m/s], Y_1 slope [m/s]) of the model, per run.

        ``base`` is (K_h, n, K_e, K_ex[, s]) (module docstring; s = 1 if absent):
        the force, and so y, scales with s (eqs 25, 28).
        """
        loss, scale = tuple(base[:4]), (base[4] if len(base) > 4 else 1.0)
        # base's entries may be arrays, one value per run (residuals_stacked)
        per_run = np.ndim(scale) > 0
        comps = cand.components(x, self.context) if components is None else components
        bm = batch.flux_density_amplitude if flux is None else np.asarray(flux, float)

        def evaluate(bm):
            res = steady_state(self.params, batch.frequency, batch.current_amplitude, bm,
                               loss, comps, harmonics=self.k.size)
            return (res.displacement * (np.asarray(scale)[:, None] if per_run else scale),
                    res.flux_density)

        if flux is None and not batch.has_b.all():
            nob = ~batch.has_b
            bm = bm.copy()
            bm[nob] = flux_density_from_ratio(self.params, batch.frequency[nob],
                                              batch.current_amplitude[nob],
                                              batch.ratio[nob] / (
                                                  np.asarray(scale)[nob] if per_run
                                                  else scale), comps)
            # B_m of a run without B is its own unknown: one Gauss-Newton step in ln B_m on
            # that run's y harmonics from the path's estimate (module docstring)
            y0, _ = evaluate(bm)
            step = np.where(nob, FLUX_DIFFERENCE_STEP, 0.0)
            y1, _ = evaluate(bm * (1.0 + step))
            sd = batch.y_sd if batch.y_sd is not None else np.ones_like(y0.real)
            r = (y0 - batch.y) / sd
            jac = (y1 - y0) / sd / np.where(nob, FLUX_DIFFERENCE_STEP, 1.0)[:, None]
            num = np.sum((np.conj(jac) * r).real, axis=1)
            den = np.sum(np.abs(jac) ** 2, axis=1)
            step = np.where(nob & (den > 0), -num / np.where(den > 0, den, 1.0), 0.0)
            # a step off the linear range (y flat in B_m) is bounded: at most a factor
            # LN_FLUX_STEP's exponential either way
            bm = bm * np.exp(np.clip(step, -LN_FLUX_STEP, LN_FLUX_STEP))
        y, b = evaluate(bm)
        s_off = np.zeros(len(batch))
        s_y1 = np.zeros(len(batch), complex)
        for cls, values in comps:
            if cls.stage == "strain":
                # the drift's terms depend on the run, not on the base: once per run of a
                # stacked batch (its Y_1 slope is linear in Y_1)
                seen = {}
                for j, rf in enumerate(batch.runs):
                    if id(rf) not in seen:
                        seen[id(rf)] = cls.feature_drift(
                            values, rf.time, rf.t_start, rf.t_mid, rf.current_amplitude, 1.0,
                            rf.frequency)
                    gain, s_off[j], per_y1 = seen[id(rf)]
                    s_y1[j] = per_y1 * y[j, 0]
                    y[j] = y[j] * gain
        return y, b, s_off, s_y1

    def residuals(self, batch: Batch, base, cand: Candidate = PAPER, x=(), components=None):
        """Model minus data over each feature's standard deviation, all runs, flat.

        y's harmonics (real, imaginary), B's for the runs that have them, then
        the three drift features of each run.
        """
        predicted = self.predict(batch, base, cand, x, components=components)
        return _residual_rows(batch, predicted, 1)[0]

    def residuals_stacked(self, batch: Batch, points, cand: Candidate = PAPER,
                          components=None):
        """:meth:`residuals` at each (base, x) of ``points``, one row each, (len(points), n):
        in one evaluation of the runs stacked (:meth:`Batch.stacked`), which costs little
        more than one of ``batch`` (the work is per call, not per run: the finite
        differences of :mod:`smeha.diagnose.differences`). The base vectors enter per run;
        so do the unknowns of a member whose form takes its parameters per run
        (``stack_values``: :meth:`Candidate.stacked_components`); where the points differ in
        another member's unknowns, one stacked evaluation per distinct x. ``components``:
        as :meth:`predict`'s, for the stacked runs (per-run weights of a density; the
        points' x are then not read)."""
        copies = len(points)
        bases = [tuple(b) for b, _ in points]
        xs = [tuple(x) for _, x in points]
        if components is None:
            components = (cand.components(xs[0], self.context) if len(set(xs)) == 1
                          else cand.stacked_components(xs, self.context, len(batch)))
        if components is None:
            # the points grouped by the unknowns of the members that take no parameters
            # per run (each group one stacked evaluation), else by their whole x
            keys = [cand.unstacked_part(x, self.context) for x in xs]
            if len(set(keys)) == 1:
                keys = xs
            out = None
            for key in dict.fromkeys(keys):
                idx = [i for i, k in enumerate(keys) if k == key]
                rows = self.residuals_stacked(batch, [points[i] for i in idx], cand)
                if out is None:
                    out = np.empty((copies, rows.shape[1]))
                out[idx] = rows
            return out
        stack = batch.stacked(copies)
        if len(set(bases)) == 1:
            base = bases[0]
        else:
            base = tuple(np.repeat(np.asarray(col, float), len(batch)) for col in zip(*bases))
        predicted = self.predict(stack, base, cand, (), components=components)
        return _residual_rows(stack, predicted, copies)

    def parts(self, batch: Batch, base, cand: Candidate = PAPER, x=()):
        """chi^2 per run of y (harmonics), of B (0 without B), of the drift features."""
        return parts_of(batch, *self.predict(batch, base, cand, x))

    def n_features(self, rf) -> tuple:
        """Number of features of y, of B (0 without a sense voltage), of the drift."""
        return 2 * self.k.size, 2 * self.k.size * rf.has_b, 3

    def samples(self, rf, base, cand: Candidate = PAPER, x=()):
        """Model y at the run's samples, best constant offset fitted, [m]."""
        batch = Batch([rf])
        y, _, _, _ = self.predict(batch, base, cand, x)
        th = rf.phase(rf.time)
        out = np.real(np.exp(1j * np.outer(th, self.k)) @ y[0])
        for cls, values in cand.components(x, self.context):
            if cls.stage == "strain":
                out = cls.apply_samples(values, out, rf.time - rf.t_start, rf.current_amplitude,
                                        rf.frequency)
        return out + float(np.mean(rf.displacement - out))
