"""The decision: none, the cause(s), or unexplained.

The rules and their constants (:data:`WITHIN_NOISE`, :func:`passes`, ... below) live in
:mod:`smeha.diagnose.rules`; this module is the procedure that applies them.

* ``none`` when the paper's model is within noise: reduced chi^2 at most
  :data:`WITHIN_NOISE` on the training fit and on the held-out runs (the
  predictive chi^2 there, :mod:`smeha.diagnose.fit`);
* otherwise **forward selection** (:func:`select`): the best single
  candidate (every form of every cause whose single shows its form's signature against
  the paper's model, a hysteresis the loop's higher harmonics: :func:`showing`; ranked
  over all the data by
  :attr:`smeha.diagnose.fit.Fit.total_score`, unless another predicts the held-out
  runs better by more than the rule's margin: :func:`leader`; a lookalike with fewer
  unknowns the data do not separate from it takes its place: :func:`simplest_lookalike`)
  is named when it passes the rule
  against the paper's model on the held-out runs (:func:`passes`): it lowers
  the held-out score by more than :data:`MIN_BIC_DROP` **and** removes at
  least :data:`MIN_EXPLAINED` of the paper's held-out excess chi^2 (chi^2 - n); a linear
  filter on y does so at every drive level (:func:`smeha.diagnose.rules.passes_first`).
  Then every extension that can join it is fitted together with it (all
  unknowns and the loss coefficients refitted; beside the Preisach density each such
  combination is screened first and the few that fit best are fitted in full:
  :func:`smeha.diagnose.joins.screened_round`), and the best-ranked such
  combination is kept when it passes the same rule against the model before
  it, that model refitted from its own values by the same steps (:func:`_settled`; a
  combination that fits the training runs worse than that model, which it holds, is
  refitted from it with the added cause where it does nothing: :func:`_rescued`; its
  share of the excess counted in the channels the added cause acts on: a sensor's delay
  cannot remove what the first cause's form leaves in B; a thermal drift is judged in the
  drift terms, its evidence channel, by the rule within them, :func:`passes_in_own`, and
  only where the drift terms go with time rather than with the drive's cycles,
  :func:`smeha.diagnose.driftlaw.goes_with_time`) and,
  removes a significant share of the paper's excess in those channels
  (:func:`significant`: :data:`MIN_SHARE` without a sense voltage,
  :data:`MIN_SHARE_WITH_B` with one), and a cause acting on y only (a drift aside) joins
  a magnetic one only when that one misses B no more than y
  (:func:`downstream_identifiable`), and no
  channel it acts on may be predicted worse (:func:`no_channel_worse`), and it must
  predict better than the causes before it in any other form (:func:`beyond_forms`) and
  than the model before it in its richer form (the Preisach density on a finer grid, the
  saturation law with a further term: :mod:`smeha.diagnose.resolution`; else the data
  are "also consistent with a richer" first cause), and its unknowns must be off their bounds
  (:func:`firm_in`: with a sense voltage the round's leader is chosen among the
  combinations whose added cause is firm, and when that one is not admitted the leader of
  all, if weak, may be, as a weak finding; without one a weak leader ends the selection);
  and so on, up to :data:`MAX_CAUSES` causes,
  while the model is still outside noise on the held-out runs; after each added cause, an
  exchange step
  (:func:`smeha.diagnose.exchange.exchange`) may replace a member by another cause that
  ranks better with the rest
  (a lookalike with more unknowns only where the data separate the two:
  :func:`smeha.diagnose.exchange.earned`),
  after which the causes added after the member that went out must earn their place again
  (:func:`smeha.diagnose.exchange.pruned`);
* where no single candidate passes the rule, a drift that passes it in the drift terms
  (:func:`_evident_first`), else two causes named at once (:func:`_pair_first`: a pair
  that passes the rule, each of its causes admitted against the other alone; then the
  exchange step, as after an added cause), else, with a sense voltage, a magnetic cause
  that passes the rule in B and predicts y no worse (:func:`_magnetic_first`);
* ``unexplained`` when none of these does
  (structure beyond noise that no candidate removes).

The causes are reported in the order they were added, which is the order of
their contribution. A model whose unknowns sit on a bound the fit pressed on
(:attr:`smeha.diagnose.fit.Fit.at_bounds`) is a **weak** finding: it predicts
better, but its parameters are not a physical result.

Other causes that pass the same rule against the paper and score within
:data:`MIN_BIC_DROP` of the first named one are reported as "also consistent"
(:func:`also_consistent`): the data prefer the named cause, but not by the
margin the rule asks of a name.
"""
from __future__ import annotations

from typing import NamedTuple

from .candidates import Batch
from .driftlaw import goes_with_time
from .exchange import FORMS_TRIED, SWAP_CANDIDATES, exchange, lookalike_margin
from .fit import Fit, fit_all
from .joins import (join_jobs, joined, ranked_forms, refit_job, screened_round,
                    start_vector)
from .linearfit import linear_member
from .progress import step
from .resolution import Refinement
from .rules import (MIN_BIC_DROP, added_member, admitted, evidence_channels, firm_in,
                    no_channel_worse, passes, passes_first, passes_in_own, refusal,
                    shows_signature, within_noise)

__all__ = ["MAX_CAUSES", "CONTINUATIONS", "CONTINUE_SETTLED", "Selection", "leader",
           "simplest_lookalike", "select", "showing", "also_consistent"]

#: Most causes forward selection names.
MAX_CAUSES = 3
#: A combination holding the Preisach density whose fit stopped on its round limit
#: (:data:`smeha.diagnose.linearfit.COMBINATION_ROUNDS`) and is not admitted is refitted
#: from its own values, with the model it extends, up to this many times while that
#: lowers its training chi^2 by more than :data:`CONTINUE_SETTLED` (:func:`_continued`).
CONTINUATIONS = 2
#: ... the relative fall of the training chi^2 below which a continued fit has settled.
CONTINUE_SETTLED = 0.01


class Selection(NamedTuple):
    """The result of :func:`select`."""

    #: "none", "unexplained" or the first cause
    answer: str
    #: the chosen model's fit (the paper's for "none" and "unexplained")
    chosen: Fit
    #: the combinations tried
    tried: list
    #: the named causes in the order they were added (a combination's members are in the
    #: order of the model's chain, gmt.extensions.ordered, which is not this one)
    order: list
    #: why no further cause was named, in words (each model tried and the rule it
    #: failed, smeha.diagnose.rules.refusal), or "" where the model came within noise or
    #: no cause was named
    stopped: str = ""
    #: the channels the first cause was judged in where it did not pass the rule over all
    #: of them (the drift terms: :func:`_evident_first`; B: :func:`_magnetic_first`), else ()
    first_in: tuple = ()
    #: the combinations beside the density screened and not fitted in full
    #: (smeha.diagnose.joins.screened_round), as their screens left them
    screened: tuple = ()


def select(ev, train, held, paper: Fit, singles: list, sense=True, workers=None) -> Selection:
    """Forward selection (module docstring), in its steps:

    1. the single causes (fitted by the caller) that show their form's signature;
    2. the first cause (:func:`_first`): the best single that passes the rule against the
       paper's model, else a drift judged in its own channel, else two causes at once,
       else, with B, a magnetic cause judged in B;
    3. while the model is outside noise and holds fewer than :data:`MAX_CAUSES` causes,
       one round (:func:`_next_cause`): join each further cause to the model (screened
       first beside the density), choose the tries, admit the first that passes the rules
       of a later cause and beats the first causes' richer form, then the exchange step;
    4. stop: within noise, at :data:`MAX_CAUSES`, or with the rule the best try failed.

    ``sense``: whether the training runs have a sense voltage (the rules for a later
    cause differ without B)."""
    if within_noise(paper):
        return Selection("none", paper, [], [])
    # a form with a signature (a hysteresis: the loop's higher harmonics) that its single
    # does not show against the paper's model is not the cause, first, paired or exchanged
    # in (smeha.diagnose.rules.shows_signature); as a later cause the rounds ask it again
    singles = showing(paper, singles)
    # a drift judged in the drift terms must go with time, as heating does, not with the
    # drive's cycles (smeha.diagnose.driftlaw)
    timelike = goes_with_time(Batch(train.runs + held.runs), MIN_BIC_DROP)
    current, order, tried, first_in = _first(ev, train, held, paper, singles, sense,
                                             timelike, workers)
    if current is None:
        return Selection("unexplained", paper, tried, [])
    stopped, screened_only = "", []
    while not within_noise(current):
        if len(current.causes) >= MAX_CAUSES:
            stopped = f"at most {MAX_CAUSES} causes are named"
            break
        current, order, tried, stopped, screened = _next_cause(
            ev, train, held, paper, singles, current, order, tried, sense, timelike, workers)
        screened_only += screened
        if stopped:
            break
    # a screened combination fitted in full later (the exchange step) is not screened only
    full = {frozenset(f.candidate.members) for f in tried + [current]}
    screened_only = tuple(f for f in screened_only
                          if frozenset(f.candidate.members) not in full)
    return Selection(order[0], current, tried, order, stopped, first_in, screened_only)


def _first(ev, train, held, paper: Fit, singles, sense: bool, timelike: bool,
           workers=None) -> tuple:
    """The first cause(s): (model, causes in order, combinations tried, the channels the
    first cause was judged in where not over all); model None for ``unexplained``."""
    best = simplest_lookalike(leader(singles), singles)
    if passes_first(paper, best):
        return best, [best.cause], [], ()
    best = _evident_first(paper, singles, timelike)
    if best is not None:
        return best, [best.cause], [], evidence_channels(best.candidate.members[0])
    step("two causes at once")
    best, order, tried = _pair_first(ev, train, held, paper, singles, sense, timelike,
                                     workers)
    if best is not None:
        # the exchange step after the pair, as after every cause added later: the pairs
        # hold the best-ranked causes only, and a lookalike ranked behind them (a delay
        # behind a one-mass mechanics that imitates it) is tried there
        best, order = exchange(ev, train, held, paper, best, order, singles, tried, sense,
                               workers, timelike)
        return best, order, tried, ()
    # with B, a magnetic cause judged in B, where an effect on y alone outside the
    # candidates holds most of y's excess
    best = _magnetic_first(paper, singles) if sense else None
    return best, ([best.cause] if best is not None else []), tried, ("B",)


def _round_fits(ev, train, held, current: Fit, singles, workers=None) -> tuple:
    """One round's combinations of ``current`` with each further cause: (reference, fits,
    the richer-form check, the combinations screened only). The reference is ``current``
    refitted from its own values by the same steps (:func:`_settled`); beside the density
    the combinations are screened from it first, the few that fit best fitted in full
    (smeha.diagnose.joins.screened_round)."""
    if linear_member(current.candidate) is not None:
        reference = _settled(current, fit_all(ev, train, held, [refit_job(current)],
                                              workers)[0])
        finer = Refinement(ev, train, held, reference, workers)
        fits, screened = screened_round(ev, train, held, current, reference, singles,
                                        workers, finer)
        return reference, fits, finer, screened
    out = fit_all(ev, train, held, [refit_job(current)] + join_jobs(
        ev, train, [(current, (), s) for s in singles]), workers)
    reference = _settled(current, out[0])
    fits = [f for f in out[1:] if isinstance(f, Fit)]
    return reference, fits, Refinement(ev, train, held, reference, workers), []


def _tries(current: Fit, round_fits, sense: bool) -> list:
    """The round's tries, in order: the leader of the combinations whose added cause is
    firm; with B the leader of all where it is weak (a weak finding, said so); and the
    leader of those whose added cause has an evidence channel of its own (the drift
    terms), judged there rather than ranked against the periodic causes."""
    top = leader(round_fits)
    firm = [f for f in round_fits if firm_in(f, added_member(current, f).cause)]
    tries = [leader(firm)] if firm else []
    if sense and top.weak:
        tries.append(top)
    evident = [f for f in firm if added_member(current, f).evidence]
    evident_leader = leader(evident) if evident else None
    if evident_leader is not None and all(evident_leader is not f for f in tries):
        tries.append(evident_leader)
    return tries


def _next_cause(ev, train, held, paper: Fit, singles, current: Fit, order, tried,
                sense: bool, timelike: bool, workers=None) -> tuple:
    """One round of :func:`select`: (model, causes in order, combinations tried, why the
    selection stops or "", the combinations screened only)."""
    step(f"cause {len(current.causes) + 1} beside {current.label}")
    reference, fits, finer, screened = _round_fits(ev, train, held, current, singles,
                                                   workers)
    round_fits = _rescued(ev, train, held, current, reference, fits, workers)
    tried = tried + round_fits
    if not round_fits:
        return (_better(current, reference), order, tried,
                "no further cause could be fitted beside the model", screened)
    # without a sense voltage a weak leader ends the selection: from y alone what it
    # takes is read as the form of the causes before it
    top = leader(round_fits)
    if not sense and not firm_in(top, added_member(current, top).cause):
        return (_better(current, reference), order, tried,
                f"{top.label}, the best-ranked with a further cause, has "
                f"{', '.join(top.at_bounds)} on a bound: without a sense voltage what it "
                "takes is read as the form of the causes before it", screened)
    tries = _tries(current, round_fits, sense)
    # the causes named so far in their other forms (singles or earlier rounds' fits)
    other_forms = [f for f in list(singles) + tried
                   if set(f.causes) == set(current.causes) and f is not current]

    def refused(f, reference):
        # the rules of a later cause, then the first causes' richer form
        # (smeha.diagnose.resolution; `finer`, made with the round's reference)
        return (refusal(paper, reference, f, other_forms, sense, timelike)
                or finer.refusal(f, added_member(reference, f)))

    nxt = next((f for f in tries if not refused(f, reference)), None)
    if nxt is None and any(_stops_short(f) for f in tries):
        reference, continued = _continued(ev, train, held, reference, tries, workers)
        tried = [continued.get(id(f), f) for f in tried]
        tries = [continued.get(id(f), f) for f in tries]
        nxt = next((f for f in tries if not refused(f, reference)), None)
    if nxt is None:
        return (_better(current, reference), order, tried,
                "; ".join(f"{f.label}: {refused(f, reference)}" for f in tries), screened)
    order = order + [c for c in nxt.causes if c not in order]
    current, order = exchange(ev, train, held, paper, nxt, order, singles, tried, sense,
                              workers, timelike)
    return current, order, tried, "", screened


def showing(paper: Fit, singles) -> list:
    """The single fits in ``singles`` that show their form's signature against ``paper``
    (:func:`smeha.diagnose.rules.shows_signature`; a form without one always does)."""
    return [s for s in singles if shows_signature(paper, s, s.candidate.members[0])]


def _evident_first(paper: Fit, singles, timelike: bool):
    """The first cause judged in its evidence channel where none passes the rule over all
    channels: the best-ranked firm single with an evidence channel that passes the rule
    there against the paper (:func:`passes_in_own`; for the drift terms, ``timelike``),
    or None. A drift beside an effect outside the candidates (a joint's backlash, mains
    hum) removes most of the drift terms' excess and too little of y's, which is the other
    effect's, to pass over all channels; its own evidence is the drift terms (pinned by
    tests/test_decision.py::
    test_a_first_drift_is_judged_in_the_drift_terms_when_nothing_passes_over_all)."""
    if not timelike:
        return None
    evident = [f for f in singles if not f.weak and f.candidate.members[0].evidence
               and passes_in_own(paper, f, evidence_channels(f.candidate.members[0]))]
    return leader(evident) if evident else None


def _magnetic_first(paper: Fit, singles):
    """With a sense voltage, where no single cause, drift or pair passes the rule: the
    best-ranked firm magnetic single (one that acts on B and y) that passes the rule in B
    against the paper (:func:`passes_in_own`) and predicts y no worse
    (:func:`smeha.diagnose.rules.no_channel_worse`), or None.

    B is the magnetic causes' own channel: the effects that act on y alone (the
    mechanics, the sensor, or one outside the candidates: a joint's backlash) leave it as
    the paper's model predicts it. Where such an effect outside the candidates holds most
    of y's excess, a magnetic cause that removes most of B's cannot remove half of the
    whole; judged in B it is named, and the rest is reported unexplained (pinned by
    tests/test_decision.py::
    test_a_magnetic_cause_is_judged_in_b_where_an_effect_on_y_alone_holds_y; end to end
    by tests/test_diagnose_textbook.py::
    test_a_magnetic_cause_beside_an_effect_on_y_alone_is_judged_in_b). An effect outside
    the candidates alone changes B not at all, so no magnetic form passes there. Without B
    features no cause passes the rule there (its drop in B is 0)."""
    ok = [f for f in singles if not f.weak and f.candidate.members[0].signals != "y only"
          and not f.candidate.members[0].evidence
          and passes_in_own(paper, f, ("B",))
          and no_channel_worse(paper, f, f.candidate.members[0])]
    return leader(ok) if ok else None


def _pair_first(ev, train, held, paper: Fit, singles, sense: bool, timelike: bool,
                workers=None) -> tuple:
    """Two causes named at once where no single one passes the rule against the paper:
    (the pair's fit, its causes in the order of their singles' rank, the pairs tried), or
    (None, [], tried).

    Forward selection names one cause at a time, each first alone; two effects that act
    on different channels can each leave more than half of the paper's excess to the
    other (a resonance takes y's excess and makes B worse, an eddy form takes B's and
    leaves y's; pinned by tests/test_diagnose_textbook.py::
    test_two_effects_that_neither_explains_alone_are_named_together). Here the
    :data:`SWAP_CANDIDATES` best-ranked causes are paired with each other (fitted
    together from their own values), and a pair is named when it passes the rule against
    the paper over all channels and each of its causes passes the rules of a later cause
    (:func:`admitted`) against the other alone: neither is there only to make up for the
    other's form. Each cause comes in its :data:`FORMS_TRIED` best-ranked forms, weak
    ones too (a form that is weak alone, making up for the other effect, may be firm
    beside it): alone, a two-mass mechanics may sit on a bound and rank behind its
    one-mass form, which beside the other cause's form is the one pushed to a bound."""
    forms = ranked_forms(singles, FORMS_TRIED)
    causes = list(forms)[:SWAP_CANDIDATES]
    pairs = [(a, (), b) for i, c in enumerate(causes) for d in causes[i + 1:]
             for a in forms[c] for b in forms[d]]
    tried = joined(ev, train, held, pairs, workers)
    named = []
    for fit in tried:
        if not passes(paper, fit):
            continue
        members = [next(s for s in singles if s.candidate.members == (m,))
                   for m in fit.candidate.members]
        if all(admitted(paper, alone, fit, [], sense, timelike) for alone in members):
            named.append((fit, sorted(members, key=lambda f: f.total_score)))
    # a firm pair first; with B a weak one may be named, as a weak finding, as in the
    # rounds of select (with B pinning the magnetic cause, a form beside the other cause's
    # may sit on a bound, as above); without B, not. Beside a discretised form (the
    # density) the other cause must beat that form on a finer grid
    # (smeha.diagnose.resolution), asked from the best-ranked pair on: the finer model is
    # fitted only where a pair that holds the density would otherwise be named
    firm = [t for t in named if not t[0].weak]
    weak = [t for t in named if t[0].weak] if sense else []
    finer = {}
    for group in (firm, weak):
        for fit, members in sorted(group, key=lambda t: t[0].total_score):
            if all(finer.setdefault(id(alone), Refinement(ev, train, held, alone, workers))
                   .passed_by(fit, added_member(alone, fit)) for alone in members):
                return fit, [m.cause for m in members], tried
    return None, [], tried


def leader(fits) -> Fit:
    """The best-ranked of ``fits`` (least :attr:`~smeha.diagnose.fit.Fit.total_score`),
    unless another predicts the held-out runs better by more than :data:`MIN_BIC_DROP`:
    then the best on the held-out runs. A flexible family (a Preisach density) can rank
    first on the strength of the training runs it fits and predict the runs it never saw
    worse (pinned by tests/test_decision.py::
    test_the_best_ranked_model_gives_way_to_a_clearly_better_prediction). A fit with an
    unknown on a bound (weak) overrides a firm leader no more than it may enter in the
    exchange step: a form pushed to its bounds can predict the held-out runs better by
    chance and describe all the data worse."""
    ranked = min(fits, key=lambda f: f.total_score)
    rivals = fits if ranked.weak else [f for f in fits if not f.weak]
    held = min(rivals, key=lambda f: f.score)
    return held if held.score < ranked.score - MIN_BIC_DROP else ranked


def simplest_lookalike(best: Fit, fits) -> Fit:
    """Of ``best`` (one cause) and the firm single forms that leave the same signature
    (the same ``lookalike``: a delay and a re-identified mechanics, linear filters on y)
    whose held-out score is within :data:`MIN_BIC_DROP` times ``best``'s dispersion in
    the channels they act on (held-out chi^2 per feature, at least 1), the one with the
    fewest parameters (then the better score).

    Where the model is far outside noise its chi^2 differences are the misfit's, scaled by
    the dispersion (quasi-likelihood, McCullagh & Nelder 1989, sec. 9.2, as in
    :func:`no_channel_worse`), and two lookalikes the data do not separate on that scale
    are told apart by parsimony (pinned by tests/test_decision.py::
    test_lookalikes_the_data_do_not_separate_are_told_apart_by_parsimony)."""
    member = best.candidate.members[0] if len(best.candidate.members) == 1 else None
    if member is None or not member.lookalike:
        return best
    margin = lookalike_margin(best, member)
    alike = [f for f in fits if len(f.candidate.members) == 1 and not f.weak
             and f.candidate.members[0].lookalike == member.lookalike
             and f.score - best.score <= margin]
    return min(alike + [best], key=lambda f: (f.k, f.score))


def _settled(current: Fit, again) -> Fit:
    """``again`` (``current``'s model refitted from its own values by the steps a
    combination takes from them, or the reason its fit failed) where it fits the
    training runs better, else ``current``.

    A combination is judged against the model it extends as far as the same steps take
    that model: where current's fit has not converged (a Preisach density's joint polish
    ends on its round limit), the combination's gain is otherwise in part the refit's:
    the same steps move the model alone too (pinned by tests/test_decision.py::
    test_a_combination_is_judged_against_the_model_refitted_by_the_same_steps)."""
    if isinstance(again, Fit) and again.train_chi2 < current.train_chi2:
        return again
    return current


def _rescued(ev, train, held, current: Fit, reference: Fit, fits, workers=None) -> list:
    """The round's combinations ``fits``, each that fits the training runs worse than
    ``reference`` (``current``'s model as its refit left it) refitted from reference's
    values with the added cause where it does nothing (its ``fit.neutral``), the better
    of the two fits kept.

    A combination holds the model it extends (its added cause at its neutral values), so
    at its optimum it fits the training runs no worse; where it does, its fit stopped
    short, started from the added cause's values fitted alone beside the paper's model,
    which imitate all the paper's model misses and may lie in another basin than the
    cause's own part. From its neutral values the combination starts at the model it
    extends (the neutral values leave the paper's model: tests/test_diagnose_forms.py::
    test_neutral_values_leave_the_paper_model_as_nearly_as_the_bounds_allow)."""
    short = [i for i, f in enumerate(fits) if f.train_chi2 > reference.train_chi2
             and added_member(current, f).fit.neutral is not None]
    if not short:
        return fits
    jobs = []
    for i in short:
        cand, added = fits[i].candidate, added_member(current, fits[i])
        jobs.append((cand, reference.base,
                     [start_vector(cand, reference, added, added.fit.neutral)]))
    out = list(fits)
    for i, again in zip(short, fit_all(ev, train, held, jobs, workers)):
        if isinstance(again, Fit) and again.train_chi2 < fits[i].train_chi2:
            out[i] = again
    return out


def _stops_short(fit: Fit) -> bool:
    """True for a combination whose fit ends on a round limit rather than where it has
    settled: one holding a linear family (the Preisach density) beside another cause
    (:data:`smeha.diagnose.linearfit.COMBINATION_ROUNDS`)."""
    return len(fit.causes) > 1 and linear_member(fit.candidate) is not None


def _continued(ev, train, held, reference: Fit, fits, workers=None) -> tuple:
    """(reference, {id(fit): continued fit}): each of ``fits`` that stops short
    (:func:`_stops_short`) refitted from its own values, with ``reference`` refitted from
    its own beside them (:func:`_settled`: each is judged against the model it extends as
    far as the same steps take that one), the better of each pair kept; again, up to
    :data:`CONTINUATIONS` times, while a combination's training chi^2 falls by more than
    :data:`CONTINUE_SETTLED`.

    A density's combination fit ends on its round limit (2 rounds of the alternation, 10
    joint steps), which costs little where the added cause is plain in the data and stops
    short where it is not: a cause near the rule's half may pass only once refitted from
    its own values (pinned by tests/test_decision.py::
    test_a_density_combination_that_stopped_short_is_continued_while_it_gains). Only the
    combinations the selection would name, if admitted, are continued, and only when none
    is: the extra fits are paid where the decision turns on them."""
    current = {id(f): f for f in fits if _stops_short(f)}
    for _ in range(CONTINUATIONS):
        keys = list(current)
        jobs = [refit_job(reference)] + [refit_job(current[k]) for k in keys]
        out = fit_all(ev, train, held, jobs, workers)
        reference = _settled(reference, out[0])
        gained = False
        for k, again in zip(keys, out[1:]):
            before = current[k]
            if isinstance(again, Fit) and again.train_chi2 < before.train_chi2:
                current[k] = again
                gained |= before.train_chi2 - again.train_chi2 > (CONTINUE_SETTLED
                                                                  * again.train_chi2)
        if not gained:
            break
    return reference, {id(f): current[id(f)] for f in fits
                       if current.get(id(f), f) is not f}


def _better(current: Fit, reference: Fit) -> Fit:
    """Of a model and its refit, the better-ranked (:attr:`Fit.total_score`)."""
    return reference if reference.total_score < current.total_score else current


def also_consistent(paper: Fit, fits, chosen: Fit, first_cause: str) -> list:
    """Other causes the held-out data do not separate from the first named one.

    The best form of each other cause that passes the rule against the paper
    (:func:`smeha.diagnose.rules.passes_first`), shows its form's signature
    (:func:`showing`) and whose score is within :data:`MIN_BIC_DROP` of the named single
    cause's. Empty for ``none`` and ``unexplained``.
    """
    if not chosen.causes:
        return []
    first = [f for f in fits if f.causes == (first_cause,)]
    ref = min(first, key=lambda f: f.score) if first else chosen
    best = {}
    for f in showing(paper, [f for f in fits if len(f.causes) == 1]):
        if f.cause in chosen.causes:
            continue
        if passes_first(paper, f) and f.score - ref.score <= MIN_BIC_DROP:
            if f.cause not in best or f.score < best[f.cause].score:
                best[f.cause] = f
    return sorted(best.values(), key=lambda f: f.score)
