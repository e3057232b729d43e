"""Fitting a candidate whose family is linear in many unknowns: penalised NNLS.

A Preisach density (:class:`gmt.extensions.PreisachForm`) has one weight per
node of its grid, dozens of them, and the model's magnetisation is linear in
them. Fitting them one by one as nonlinear unknowns would be slow and would
count every node as a parameter. Here instead, alternately until the training
chi^2 settles:

1. the residuals are linearised in the weights w about the current fit,
   r(w') ~ r + J (w' - w) (J by finite differences: the magnetisation is
   linear in w, the force of eq 25 quadratic and the paper's part is solved for
   the measured B_m, so the linearisation is refreshed each round);
2. the weights solve the penalised nonnegative least-squares problem
   min ||r + J (w' - w)||^2 + lambda ||D w'||^2, w' >= 0 (NNLS, Lawson & Hanson,
   *Solving Least Squares Problems*, 1974, ch. 23; D the second differences
   over the grid, a Tikhonov smoothness penalty), the step halved while it does
   not lower chi^2;
3. the nonlinear unknowns (the base ones, eq 16's loss coefficients and the
   strain scale, and the other members' of a combination) are refitted by
   :func:`smeha.diagnose.fit.fit_candidate` with the weights held.

lambda is chosen once, in the first round, from a grid of
:data:`PENALTY_GRID` times trace(J^T J)/trace(D^T D), by the training BIC
of the linearised solution, chi^2 + df ln n, where the effective number of
parameters is df = trace(J_f (J_f^T J_f + lambda D_f^T D_f)^-1 J_f^T) over the
free weights (those not held at zero by the constraint): the trace of the
penalised fit's hat matrix (Hastie, Tibshirani & Friedman, *The Elements of
Statistical Learning*, 2nd ed., 2009, sec. 7.6). That df, plus the other
members' unknowns, is the candidate's k in the score
(:attr:`smeha.diagnose.fit.Fit.k`), so a density with many nodes is charged for
what the data let it fit, not for its node count.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

from . import differences
from .baseunknowns import BASE_LOWER, BASE_UPPER, base_factor
from .boxsolve import bounded_least_squares
from .candidates import Batch, Candidate, Evaluator

__all__ = ["PENALTY_GRID", "COMBINATION_ROUNDS", "WEIGHT_STEP", "ROUND_EVALUATIONS",
           "linear_member", "effective_dof", "fit_linear"]

#: Penalty weights tried, times trace(J^T J) / trace(D^T D).
PENALTY_GRID = (1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2)
#: Rounds of the alternation at most, and the relative change of chi^2 that ends it; a
#: combination starts from its members' fitted values and takes fewer.
ROUNDS, SETTLED = 4, 1e-4
COMBINATION_ROUNDS = 2
#: Joint damped Gauss-Newton steps at most after the alternation (:func:`_joint`).
JOINT_ROUNDS = 10
#: Tenfold raises of the joint steps' damping before the steps end.
DAMPING_TRIES = 8
#: Least damping scale of a joint step's unknown, times the largest column norm of the
#: nonlinear unknowns' Jacobian (Marquardt's column scaling leaves an unknown the data
#: barely see, e.g. a rate factor's corner frequency while its exponent is 0, undamped).
DAMPING_FLOOR = 1e-3
#: Finite-difference step of the weights' Jacobian, [A/m].
WEIGHT_STEP = 50.0
#: Function evaluations of one refit of the nonlinear unknowns within a round: each round
#: starts from the last one's values, so a few steps suffice (the last round is the fit).
ROUND_EVALUATIONS = 40


def linear_member(cand: Candidate):
    """Index of the member whose unknowns are linear (``linear`` True), or None."""
    for k, m in enumerate(cand.members):
        if getattr(m, "linear", False):
            return k
    return None


def _slices(cand: Candidate, lin: int):
    """Index arrays of the linear member's linear unknowns (its ``linear_unknowns``) and of
    all the other unknowns within x."""
    sizes = [m.fit.size for m in cand.members]
    start = sum(sizes[:lin])
    lin_idx = np.arange(start, start + sizes[lin])[cand.members[lin].linear_unknowns]
    other = np.setdiff1d(np.arange(sum(sizes)), lin_idx)
    return lin_idx, other


def effective_dof(jac, penalty, lam, free):
    """df = trace of the penalised hat matrix over the free columns (module docstring)."""
    if not np.any(free):
        return 0.0
    j = jac[:, free]
    d = penalty[:, free]
    a = j.T @ j + lam * (d.T @ d)
    return float(np.trace(np.linalg.solve(a + 1e-12 * np.trace(a) * np.eye(a.shape[0]),
                                          j.T @ j)))


class _Problem:
    """The training residuals as a function of (base, x), with the weights apart."""

    def __init__(self, ev: Evaluator, train: Batch, cand: Candidate, lin: int):
        self.ev, self.train, self.cand = ev, train, cand
        self.lin_idx, self.other_idx = _slices(cand, lin)
        self.penalty = cand.members[lin].smoothness()

    def x_of(self, w, other):
        x = np.zeros(self.lin_idx.size + self.other_idx.size)
        x[self.lin_idx] = w
        x[self.other_idx] = other
        return tuple(float(v) for v in x)

    def residuals(self, base, w, other):
        return self.ev.residuals(self.train, base, self.cand, self.x_of(w, other))

    def stacked(self, points, w):
        """:meth:`residuals` at each (base, other) of ``points``, the weights ``w``, one row
        each."""
        return self.ev.residuals_stacked(
            self.train, [(b, self.x_of(w, o)) for b, o in points], self.cand)

    def jacobian(self, base, w, other, r0):
        """d r / d w by finite differences, every column in one evaluation: the training
        runs stacked once per weight, each copy with that weight stepped (the density's
        weights may be given per run, PreisachForm.periodic_output)."""
        runs, nw = self.train.runs, w.size
        comps = list(self.cand.components(self.x_of(w, other), self.ev.context))
        lin = [k for k, (cls, _) in enumerate(comps) if getattr(cls, "linear", False)][0]
        cls, values = comps[lin]
        rows = np.repeat(np.eye(nw) * WEIGHT_STEP + w, len(runs), axis=0)
        comps[lin] = (cls, dict(values, weights_A_per_m=rows))
        r = self.ev.residuals_stacked(self.train, [(base, ())] * nw, self.cand,
                                      components=tuple(comps))
        return ((r - r0[None, :]) / WEIGHT_STEP).T

    def row_runs(self):
        """The training run of each residual (the order of :meth:`residuals`)."""
        n = len(self.train.runs)
        k = self.train.y.shape[1]
        y = np.repeat(np.arange(n), k)
        b = np.repeat(np.flatnonzero(self.train.has_b), k)
        runs = np.arange(n)
        return np.concatenate((y, y, b, b, runs, runs, runs))

    def solve(self, jac, r0, w, lam):
        """The penalised NNLS weights for the linearisation (module docstring, step 2)."""
        a = np.vstack((jac, np.sqrt(lam) * self.penalty))
        b = np.concatenate((jac @ w - r0, np.zeros(self.penalty.shape[0])))
        scale = np.sqrt(np.sum(a * a, axis=0))
        scale = np.where(scale > 0, scale, 1.0)
        sol, _ = nnls(a / scale, b, maxiter=50 * a.shape[1])
        return sol / scale


def fit_linear(ev: Evaluator, train: Batch, cand: Candidate, base0, fit_candidate,
               start=None, screen=False) -> tuple:
    """Fit a candidate with a linear member (module docstring).

    Returns (base, x, chi^2, n, cov, k): as :func:`smeha.diagnose.fit.fit_candidate`
    plus the effective number of the candidate's parameters k. ``screen``: one round of
    the alternation and no joint steps, cov None (a combination's screen,
    :func:`smeha.diagnose.joins.screened_round`).
    """
    lin = linear_member(cand)
    prob = _Problem(ev, train, cand, lin)
    starts = [np.asarray(s, float) for s in ([start] if start is not None else cand.starts())]
    if start is None and len(cand.members) == 1:
        starts = [_screened(prob, base0, starts[0])]
    elif start is not None and len(cand.members) > 1:
        starts = [_screened_members(prob, base0, starts[0])]
    best = None
    rounds = 1 if screen else ROUNDS if start is None else COMBINATION_ROUNDS
    for x0 in starts:
        out = _alternate(ev, train, prob, base0, x0, fit_candidate, rounds)
        if not screen:
            out = _joint(prob, *out)
        if best is None or out[2] < best[2]:
            best = out
    base, w, chi2, other, lam = best
    r0 = prob.residuals(base, w, other)
    jac = prob.jacobian(base, w, other, r0)
    free = w > 0
    k = effective_dof(jac, prob.penalty, lam, free) + other.size
    cov = None if screen else _covariance(ev, train, cand, prob, base, w, other, jac, lam)
    return base, prob.x_of(w, other), float(r0 @ r0), int(r0.size), cov, k


def _alternate(ev, train, prob, base0, x0, fit_candidate, rounds=ROUNDS):
    """The alternation of the module docstring from ``x0``: (base, w, chi^2, other, lambda)."""
    w = np.maximum(x0[prob.lin_idx], 0.0)
    other = x0[prob.other_idx]
    held = _HeldWeights(prob)
    base = tuple(base0)
    lam = None
    chi2_prev = np.inf
    jac = None
    for _ in range(rounds):
        # step 3: the nonlinear unknowns with the weights held
        held.w = w
        base, other, _, _, _ = fit_candidate(ev, train, held.unknowns(), base,
                                             starts=[tuple(other)],
                                             problem=held,
                                             max_evaluations=ROUND_EVALUATIONS)
        other = np.asarray(other, float)
        r0 = prob.residuals(base, w, other)
        chi2 = float(r0 @ r0)
        if chi2_prev - chi2 <= SETTLED * chi2 and jac is not None:
            break
        chi2_prev = chi2
        # steps 1-2: linearise in the weights, solve the penalised NNLS
        jac = prob.jacobian(base, w, other, r0)
        if lam is None:
            lam = _choose_penalty(prob, jac, r0, w)
        w_new = prob.solve(jac, r0, w, lam)
        if not np.any(w_new > 0) and not np.any(w > 0):
            break  # no density the data want: the paper's model with the others
        for _ in range(6):  # halve the step while chi^2 does not fall
            r1 = prob.residuals(base, w_new, other)
            if float(r1 @ r1) < chi2:
                break
            w_new = 0.5 * (w + w_new)
        else:
            break
        w = w_new
    r0 = prob.residuals(base, w, other)
    return base, w, float(r0 @ r0), other, lam


def _joint(prob, base, w, chi2, other, lam, rounds=None):
    """Step 4: damped Gauss-Newton steps on all unknowns together from the alternation's
    result, (base, w, chi^2, other, lambda) as :func:`_alternate`.

    Each step linearises the residuals in the weights (:meth:`_Problem.jacobian`) and in
    the other unknowns (forward differences, the base ones scaled as in
    :func:`smeha.diagnose.fit.fit_candidate`) and solves the penalised problem of step 2
    for all of them at once, bounded (weights >= 0, the others within their bounds), with
    Marquardt's damping (Marquardt, J. SIAM 11 (1963) 431-441: mu times each column's
    squared norm, floored at :data:`DAMPING_FLOOR` of the largest, on every unknown, the
    weights included) raised tenfold while chi^2 does not fall. The alternation alone
    moves along the valley where the weights and the base trade off (eq 16's loss against
    the density's loop area) a little a round.

    The damping holds every unknown, the weights included: a rate factor's corner frequency,
    unseen by the data while its exponent is 0, would otherwise step to its bound at every
    damping and no step would ever be kept
    (tests/test_diagnose_labsim.py exercises it on labsim's Preisach hysteresis)."""

    rounds = JOINT_ROUNDS if rounds is None else rounds
    nb = len(BASE_LOWER)
    factor = base_factor(base)
    lo, hi = _unknown_bounds(prob)
    pen = np.sqrt(lam) * prob.penalty

    def unpack(z):
        b = np.array(base, float)
        b[:nb] = z[:nb] * factor[:nb]
        return tuple(float(v) for v in b), np.asarray(z[nb:], float)

    def objective(r):
        # a step is kept when it lowers chi^2, as the alternation's are: the penalty
        # regularises the steps; kept in the objective, it would trade chi^2 for a smoother
        # density, with a lambda chosen where the alternation started
        return float(r @ r)

    z = np.concatenate((np.asarray(base[:nb], float) / factor[:nb], other))
    r0 = prob.residuals(base, w, other)
    f0 = objective(r0)
    mu = 1e-3
    for _ in range(rounds):
        jw = prob.jacobian(base, w, other, r0)
        jz = _unknowns_jacobian(prob, base, w, other, factor[:nb], r0, upper=hi)
        a = np.hstack((jz, jw))
        nz = z.size
        floored = _floored_norms(a, nz)
        # ||a v - rhs|| reduced to its triangular factor (QR): the same minimiser, with as
        # many rows as unknowns
        a, rhs = _reduced(a, jw @ w - r0)
        for _ in range(DAMPING_TRIES):  # raise the damping while the objective does not fall
            sol = _damped_step(a, rhs, pen, floored, mu, w, lo - z, hi - z)
            z_new = np.clip(z + sol[:nz], lo, hi)
            w_new = np.maximum(sol[nz:], 0.0)
            b_new, o_new = unpack(z_new)
            r1 = prob.residuals(b_new, w_new, o_new)
            f1 = objective(r1)
            if np.isfinite(f1) and f1 < f0:
                break
            mu *= 10.0
        else:
            break
        settled = f0 - f1 <= SETTLED * f1
        z, w, r0, f0 = z_new, w_new, r1, f1
        base, other = b_new, o_new
        mu = max(mu / 3.0, 1e-6)
        if settled:
            break
    return base, w, float(r0 @ r0), other, lam


def _floored_norms(a, nz):
    """The columns' norms of ``a``, the first ``nz`` (the nonlinear unknowns') floored at
    :data:`DAMPING_FLOOR` of their largest; a zero column counts as 1."""
    norms = np.sqrt(np.sum(a * a, axis=0))
    norms = np.where(norms > 0, norms, 1.0)
    return np.maximum(norms, DAMPING_FLOOR * norms[:nz].max()) if nz else norms


def _damped_step(a, rhs, pen, floored, mu, w, below, above):
    """One bounded Marquardt step of :func:`_joint`: the steps of the nonlinear unknowns
    (within ``below``/``above`` of them) and the new weights (>= 0), minimising
    ``|a v - rhs|^2`` with the density's penalty ``pen`` on the weights and every unknown
    damped towards its value by ``sqrt(mu)`` times its floored column norm.

    Each column is scaled by its floored norm, so that every damping entry is
    ``sqrt(mu)``: scaled by its own norm, the column of a node whose relays barely switch
    in the data (norm ~1e-13 of the rest) would carry damping and penalty entries 1e13
    times the others' and make the problem singular to working precision. The bounded
    problem is solved exactly by an active-set method
    (:func:`smeha.diagnose.boxsolve.bounded_least_squares`; Stark & Parker, Comput. Stat.
    10 (1995) 129-141); benchmarks/bounded_solve.py compares it with scipy's solvers."""
    nz = below.size
    damp = np.diag(np.sqrt(mu) * floored)
    big = np.vstack((a, np.hstack((np.zeros((pen.shape[0], nz)), pen)), damp))
    rhs_big = np.concatenate((rhs, np.zeros(pen.shape[0] + nz), np.sqrt(mu) * floored[nz:] * w))
    lower = np.concatenate((below, np.zeros(w.size))) * floored
    upper = np.concatenate((above, np.full(w.size, np.inf))) * floored
    return bounded_least_squares(big / floored, rhs_big, np.minimum(lower, 0.0),
                                 np.maximum(upper, 0.0)) / floored


def _unknown_bounds(prob) -> tuple:
    """(lower, upper) of the base's first unknowns (scaled as in
    :func:`smeha.diagnose.fit.fit_candidate`) and the other unknowns, as :func:`_joint` and
    :func:`_unknowns_jacobian` order them."""
    nb = len(BASE_LOWER)
    other = prob.other_idx
    return (np.concatenate((BASE_LOWER[:nb], np.asarray(prob.cand.lower, float)[other])),
            np.concatenate((BASE_UPPER[:nb], np.asarray(prob.cand.upper, float)[other])))


def _unknowns_jacobian(prob, base, w, other, factor, r0, upper):
    """d r / d (z, other) by forward differences, the weights ``w`` held: z the base's first
    ``factor.size`` unknowns over ``factor`` (as :func:`smeha.diagnose.fit.fit_candidate`
    scales them), then the other unknowns; a step of 1e-6 of the value (at least 1e-9)
    that would pass ``upper`` (bounds of z and other) is taken backwards
    (:func:`smeha.diagnose.differences.relative_steps`), the base columns evaluated
    together. ``r0``: the residuals at (base, w, other)."""
    nb = factor.size
    z0 = np.concatenate((np.asarray(base[:nb]) / factor, other))

    def split(z):
        if np.array_equal(z[:nb], z0[:nb]):  # a step in the other unknowns: base as it is
            return tuple(base), z[nb:]
        b = np.array(base, float)
        b[:nb] = z[:nb] * factor
        return tuple(b), z[nb:]

    def stacked(zs):
        return prob.stacked([split(z) for z in zs], w)

    jac, _ = differences.jacobian(stacked, z0, differences.relative_steps(z0, upper), r0=r0)
    return np.ascontiguousarray(jac)


def _reduced(a, b):
    """(R, Q^T b) of a = Q R: ||a v - b|| and ||R v - Q^T b|| differ by a constant."""
    q, r = np.linalg.qr(a, mode="reduced")
    return r, q.T @ b


def _screened(prob, base0, x0):
    """The start of a single linear family, its nonlinear unknowns screened (step 0).

    A member whose nonlinear unknowns only scale its whole output per run by a factor
    (``output_factor``, e.g. the Preisach family's rate factor g(f)) has them screened over
    its grid (``screen_starts``): the weights' Jacobian at zero weights and factor 1
    (evaluated once) has its rows scaled by each grid point's factor of their run, the
    penalised NNLS solved for it, and the point with the least linearised chi^2 starts the
    alternation. Other members keep ``x0``."""
    member = prob.cand.members[0]
    if not hasattr(member, "output_factor"):
        return x0
    w0 = np.zeros(prob.lin_idx.size)
    # the Jacobian at the unknowns' upper bounds (a factor near 1), divided by that factor
    ref = np.asarray(member.fit.upper, float)[prob.other_idx]
    r0 = prob.residuals(base0, w0, ref)
    rows = prob.row_runs()
    freqs = np.array([rf.frequency for rf in prob.train.runs])
    jac = prob.jacobian(base0, w0, ref, r0) / member.output_factor(ref, freqs)[rows][:, None]
    lam = _choose_penalty(prob, jac, r0, w0)
    best = None
    for point in member.screen_starts():
        jg = jac * member.output_factor(point, freqs)[rows][:, None]
        w = prob.solve(jg, r0, w0, lam)
        r = r0 + jg @ w
        chi2 = float(r @ r)
        if best is None or chi2 < best[0]:
            best = (chi2, point, w)
    x = np.array(x0, float)
    x[prob.other_idx] = best[1]
    x[prob.lin_idx] = best[2]
    return x


def _screened_members(prob, base0, x0):
    """The start of a combination with a linear member, the other members' starts
    screened (step 0 of a combination).

    A combination starts from its members' fitted values (``x0``), the density's fitted
    alone. Where the added member changes what the density's relays see (an eddy field
    form: they switch on the lagging field inside), the density fitted alone has taken
    up what the added member does, and the alternation from there stays by it (pinned by
    tests/test_diagnose_textbook.py::
    test_hysteresis_beside_eddy_currents_that_shield_the_field_gives_both). So ``x0``
    and, for each member that shields the field (``shields_field``), ``x0`` with that
    member's unknowns at each of its own starts (its ``FitSpec.starts``) are tried: at
    each, the weights are re-solved once (the penalised NNLS of step 2 about ``x0``'s
    weights, the penalty chosen as in step 2) and the chi^2 evaluated; the least starts
    the alternation."""
    x0 = np.asarray(x0, float)
    if not any(m.shields_field for m in prob.cand.members):
        return x0
    options = [x0]
    k = 0
    for m in prob.cand.members:
        if m.shields_field:
            for s in m.fit.starts:
                x = x0.copy()
                x[k:k + m.fit.size] = s
                options.append(x)
        k += m.fit.size
    best = None
    for x in options:
        w, other = np.maximum(x[prob.lin_idx], 0.0), x[prob.other_idx]
        r0 = prob.residuals(base0, w, other)
        jac = prob.jacobian(base0, w, other, r0)
        w_new = prob.solve(jac, r0, w, _choose_penalty(prob, jac, r0, w))
        r1 = prob.residuals(base0, w_new, other)
        for chi2, weights in ((float(r0 @ r0), w), (float(r1 @ r1), w_new)):
            if best is None or chi2 < best[0]:
                best = (chi2, x, weights)
    x = best[1].copy()
    x[prob.lin_idx] = best[2]
    return x


def _choose_penalty(prob, jac, r0, w):
    """lambda of :data:`PENALTY_GRID` with the least training BIC (module docstring)."""
    d = prob.penalty
    unit = np.trace(jac.T @ jac) / max(np.trace(d.T @ d), 1e-300)
    n = r0.size
    best = None
    for f in PENALTY_GRID:
        lam = f * unit
        sol = prob.solve(jac, r0, w, lam)
        r = r0 + jac @ (sol - w)
        df = effective_dof(jac, d, lam, sol > 0)
        bic = float(r @ r) + df * np.log(max(n, 2))
        if best is None or bic < best[0]:
            best = (bic, lam)
    return best[1]


def _covariance(ev, train, cand, prob, base, w, other, jac_w, lam):
    """(J^T J + P)^-1 of all unknowns (base scaled as in the fit, then x), the weights'
    block penalised as in the fit and the weights held at zero pinned."""

    nb = len(BASE_LOWER)
    factor = base_factor(base)
    r0 = prob.residuals(base, w, other)
    jz = _unknowns_jacobian(prob, base, w, other, factor[:nb], r0, _unknown_bounds(prob)[1])
    # the columns in the order of x: base, then x's linear and other unknowns in place
    nx = prob.lin_idx.size + prob.other_idx.size
    jx = np.zeros((r0.size, nx))
    jx[:, prob.lin_idx] = jac_w
    jx[:, prob.other_idx] = jz[:, nb:]
    j_all = np.hstack((jz[:, :nb], jx))
    pen = np.zeros((nb + nx, nb + nx))
    li = nb + prob.lin_idx
    pen[np.ix_(li, li)] = lam * prob.penalty.T @ prob.penalty
    a = j_all.T @ j_all + pen
    cov = np.linalg.pinv(a)
    pinned = li[w <= 0]
    cov[pinned, :] = 0.0
    cov[:, pinned] = 0.0
    return cov


class _HeldWeights:
    """The nonlinear unknowns alone, the weights held, for the nonlinear fit."""

    def __init__(self, prob: _Problem):
        self.prob, self.w = prob, None
        cand = prob.cand
        self.label = cand.label  # for fit_candidate's messages
        self.members = cand.members  # and its method (fit.solver_method)
        self.lower = tuple(np.asarray(cand.lower, float)[prob.other_idx])
        self.upper = tuple(np.asarray(cand.upper, float)[prob.other_idx])

    def unknowns(self):
        """What :func:`smeha.diagnose.fit.fit_candidate` reads of a candidate: the bounds
        (and the members)."""
        return self

    def residuals(self, base, x_other):
        return self.prob.residuals(base, self.w, np.asarray(x_other, float))

    def stacked(self, points):
        return self.prob.stacked([(b, np.asarray(o, float)) for b, o in points], self.w)
