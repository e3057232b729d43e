"""A model plus one cause: the fit jobs of the combinations forward selection tries.

Read by :mod:`smeha.diagnose.decision` (each round's joins, the pairs named at once) and
:mod:`smeha.diagnose.exchange` (the exchange step): a combination starts from its
members' fitted values, the added cause from the better of its value fitted alone and its
form's own starts.

Beside a model that holds a linear family (the Preisach density) a round's combinations
are screened first and only the few that fit the training runs best are fitted in full
(:func:`screened_round`): a combination's full fit (two rounds of the density's
alternation and its joint steps, :mod:`smeha.diagnose.linearfit`) costs some 500
evaluations of the model and a round joins every form of every cause.
"""
from __future__ import annotations

import math

from .candidates import Candidate
from .fit import UNEVALUATED, Fit, fit_all
from .rules import added_member

__all__ = ["SCREEN_KEEP", "ranked_forms", "refit_job", "joined", "join_jobs", "join_start",
           "start_vector", "screened_round"]

#: Combinations of a screened round fitted in full (:func:`screened_round`): the best by
#: the screen's training chi^2.
SCREEN_KEEP = 3
#: A screened round fits the density on its finer grid beside the combinations it fits in
#: in full (:func:`screened_round`) when a kept combination's screen lowered the training
#: chi^2 of the reference by more than this share, with a cause that acts on B and y: the
#: case in which the round may name a cause the finer grid must be asked about
#: (:class:`smeha.diagnose.resolution.Refinement`). A guess at what the round will need,
#: read for the time only: the finer fit is the same fit whichever call makes it. It pays
#: where a cause is then admitted beside the density (labsim's Preisach + eddy at 800
#: samples a period, seed 3: 2.8 s of 23 s sooner) and costs where the rules refuse every
#: try before the finer grid is asked (the density alone: a slab screen 3.5 % lower,
#: refused; 2 s later).
SPECULATE_FINER = 0.01


def ranked_forms(fits, count) -> dict:
    """{cause: its best-ranked ``count`` fits in ``fits``, least total_score first}, the
    causes in the order of their best fit's rank."""
    out = {}
    for f in sorted(fits, key=lambda f: f.total_score):
        forms = out.setdefault(f.cause, [])
        if len(forms) < count:
            forms.append(f)
    return out


def refit_job(current: Fit) -> tuple:
    """The fit job of ``current``'s model started from its own fitted values."""
    return (current.candidate, current.base, [current.x])


def joined(ev, train, held, joins, workers=None) -> list:
    """The fits of each (current, keep, single) in ``joins`` (:func:`join_jobs`) side by
    side (:func:`smeha.diagnose.fit.fit_all`); those whose fit fails are left out."""
    return [f for f in fit_all(ev, train, held, join_jobs(ev, train, joins), workers)
            if isinstance(f, Fit)]


def join_jobs(ev, train, joins) -> list:
    """The fit jobs of each (current, keep, single) in ``joins``: ``current``'s members
    ``keep`` (all of them when empty) plus ``single``'s extension, started from their
    fitted values, the added one's from the better of its value fitted alone and its
    form's own starts (:func:`join_start`); those that cannot combine are left out."""
    return [(cand, current.base, [join_start(ev, train, cand, current, member, single.x)])
            for current, cand, member, single in _combinations(joins)]


def _combinations(joins):
    """(current, the combination's candidate, the member it adds, single) of each
    (current, keep, single) in ``joins`` whose extension can join ``current``'s members
    ``keep`` (all of them when empty)."""
    for current, keep, single in joins:
        member = single.candidate.members[0]
        members = tuple(keep) or current.candidate.members
        if member in members or member.cause in {m.cause for m in members}:
            continue
        cand = Candidate(members)
        if cand.combinable(member):
            yield current, cand.plus(member), member, single


def join_start(ev, train, cand: Candidate, current: Fit, added, alone) -> tuple:
    """The start vector of ``cand`` (:func:`start_vector`) whose training chi^2 is least, the
    member ``added`` at its value fitted ``alone`` beside the paper's model or at one of its
    form's start vectors: one evaluation each, no fit.

    A value fitted alone is the added cause's best imitation of everything the paper's
    model misses, which beside another cause may be far from its own part (an eddy form
    fitted alone takes the loop's opening with the paper's loss coefficients, and beside
    a Preisach density that opening is the density's); pinned by tests/test_decision.py::
    test_a_joined_cause_starts_where_the_training_chi2_is_least. The least chi^2 at the
    start does not promise the best basin, only a cheap better one."""
    best, least = None, math.inf
    for values in (tuple(alone),) + tuple(tuple(v) for v in added.fit.starts):
        x = start_vector(cand, current, added, values)
        try:
            r = ev.residuals(train, current.base, cand, x)
        except UNEVALUATED:
            continue
        chi2 = float(r @ r)
        if math.isfinite(chi2) and chi2 < least:
            best, least = x, chi2
    return best if best is not None else start_vector(cand, current, added, alone)


def start_vector(cand: Candidate, fit: Fit, added=None, values=()) -> tuple:
    """The start vector of ``cand``: ``fit``'s fitted values for the members it holds,
    ``values`` for the member ``added`` (none: ``cand`` holds only members of ``fit``)."""
    own = dict(zip(fit.candidate.members, fit.candidate.split(fit.x)))
    if added is not None:
        own[added] = tuple(values)
    return tuple(v for m in cand.members for v in own[m])


def screened_round(ev, train, held, current: Fit, reference: Fit, singles,
                   workers=None, refinement=None) -> tuple:
    """(the fits in full, the fits screened only) of a round's combinations beside
    ``current``, a model holding a linear family, ``reference`` current refitted from its
    own values (the better of the two, smeha.diagnose.decision._settled).

    Each combination (current plus one form of one other cause, :func:`join_jobs`) is
    screened: fitted by one round of the density's alternation, without the joint steps
    (:func:`smeha.diagnose.linearfit.fit_linear` with ``screen``), from the reference's
    values with the added cause at its neutral values (``FitSpec.neutral``: the reference
    itself, so the screen ends no worse than the model it is judged against; a form
    without neutral values from its join start). The :data:`SCREEN_KEEP` with the least
    training chi^2, and the best-ranked cause with an evidence channel of its own (the
    drift, judged in its drift terms), are fitted in full from where their screens ended.

    A screen costs one round of the alternation where a full fit costs its joint steps,
    and a full fit from the join start that ends worse than the reference is fitted again
    from the neutral values (:func:`smeha.diagnose.decision._rescued`): screening first
    fits in full only the few a round may name (pinned by tests/test_decision.py::
    test_beside_the_density_the_combinations_are_screened_and_the_best_fitted_in_full).

    ``refinement`` (a :class:`smeha.diagnose.resolution.Refinement` of ``reference``):
    where a kept combination's screen suggests a cause may be named
    (:data:`SPECULATE_FINER`), its finer model is fitted first in the same batch as the
    full fits, side by side with them, and handed to it; fitted alone, later, it keeps
    one worker idle (:data:`SPECULATE_FINER`)."""
    screens = []
    for _, cand, added, single in _combinations([(reference, (), s) for s in singles]):
        start = (start_vector(cand, reference, added, added.fit.neutral)
                 if added.fit.neutral is not None
                 else join_start(ev, train, cand, reference, added, single.x))
        screens.append((cand, reference.base, [start], True))
    screened = sorted((f for f in fit_all(ev, train, held, screens, workers)
                       if isinstance(f, Fit)), key=lambda f: f.train_chi2)
    keep = screened[:SCREEN_KEEP]
    evident = [f for f in screened if added_member(reference, f).evidence]
    if evident and all(evident[0] is not f for f in keep):
        keep.append(evident[0])
    jobs = [refit_job(f) for f in keep]
    speculate = refinement is not None and refinement.pending and any(
        added_member(reference, f).signals == "B and y"
        and f.train_chi2 < (1.0 - SPECULATE_FINER) * reference.train_chi2 for f in keep)
    # handed out the costliest first: the finer model (a density on twice the nodes), then
    # by the seconds of each one's screen
    done = fit_all(ev, train, held, ([refinement.job()] if speculate else []) + jobs, workers,
                   costs=([math.inf] if speculate else []) + [f.seconds for f in keep])
    if speculate:
        refinement.given(done.pop(0))
    full = [f for f in done if isinstance(f, Fit)]
    return full, [f for f in screened if all(f is not k for k in keep)]
