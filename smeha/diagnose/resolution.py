"""A later cause must be its own: it must beat the first causes' richer form.

A form with a finite description leaves a misfit that is the description's, not the
physics': the Preisach density (:mod:`gmt.extensions.preisach`) is fitted on a grid of
nodes, and what falls between them (a population narrower than their spacing) is the
grid's; the saturation law (:mod:`gmt.extensions.saturation`) holds the measured
anhysteretic curve to its family, and what the family cannot hold is the law's. A later
cause that acts on the same channels can take that misfit up and pass every rule of
:mod:`smeha.diagnose.decision`, against the noise, without being there.

So a cause that joins a model holding such a form, and acts on B and y as that form does,
is admitted only where it predicts the held-out runs better than the model before it with
that form made richer (``Extension.finer``: the density on a grid 1.5 times as fine, the
saturation law with the next even term of its susceptibility). Where it does not, the
data are also consistent with a richer first cause, which is said, and the cause is not
named. The rule :func:`smeha.diagnose.rules.beyond_forms` applies to the causes' other
forms, this one to their richer form. The richer model is fitted only where a cause is
about to be named beside such a form, once per round, from the fit it refines carried
over; tests/test_resolution.py checks that each richer form so fitted describes the
training runs at least as well as the form it refines (else the check would ask nothing).

The causes acting on y alone (a sensor's delay, the mechanics) are not asked: with a
sense voltage B pins the magnetic form, and the richer form cannot remove from y what B
does not allow it to.
"""
from __future__ import annotations

from .candidates import Candidate
from .fit import Fit, fit_all
from .progress import step

__all__ = ["richer_form", "finer_candidate", "finer_job", "Refinement"]


def richer_form(member) -> str:
    """What ``member``'s richer form adds, in words."""
    grid = getattr(member.finer, "grid", None)
    if grid is not None:  # (coercive, interaction) axes as (low, high, nodes)
        return f"{member.cause} on a grid of {grid[0][2]} x {grid[1][2]} nodes"
    return f"{member.cause} with {', '.join(member.finer.fit.names[member.fit.size:])} added"


def finer_candidate(cand: Candidate):
    """``cand`` with each member that has a finer discretisation on it, or None when no
    member has one."""
    if not any(m.finer for m in cand.members):
        return None
    return Candidate(tuple(m.finer or m for m in cand.members))


def finer_job(fit: Fit) -> tuple:
    """The fit job (candidate, base0, starts) of ``fit``'s model in its richer form: one
    start, ``fit``'s values with each member that has a richer form carried to it (its
    ``finer_start``: the density's output held, :func:`gmt.extensions.preisach.
    projected_weights`; the saturation law as it is, c = 0).

    Fitted from its own starts, as every single is, the richer fit may end worse than the
    fit it refines, and the check then asks nothing a cause does not already pass; from
    the projected fit it ends at least as well (pinned by tests/test_resolution.py::
    test_the_finer_density_fits_the_training_runs_at_least_as_well)."""
    cand = finer_candidate(fit.candidate)
    start = tuple(v for m, x in zip(fit.candidate.members, fit.candidate.split(fit.x))
                  for v in (m.finer_start(x) if m.finer else x))
    return cand, fit.base, [start]


class Refinement:
    """The check of the module docstring for the causes that may join ``current``: the
    richer model is fitted once, on the first call that needs it."""

    def __init__(self, ev, train, held, current: Fit, workers=None):
        self._args = (ev, train, held)
        self.current = current
        self.workers = workers
        self._finer = None

    @property
    def pending(self) -> bool:
        """True while the richer model is not fitted and ``current`` has one."""
        return self._finer is None and finer_candidate(self.current.candidate) is not None

    def job(self) -> tuple:
        """The richer model's fit job, for a caller that fits it beside others
        (:func:`smeha.diagnose.joins.screened_round`), then hands it over (:meth:`given`)."""
        return finer_job(self.current)

    def given(self, fit) -> None:
        """The richer model's fit (or the reason it failed) of :meth:`job`, fitted elsewhere."""
        self._finer = fit

    @property
    def finer(self):
        """The richer model's fit (or the reason its fit failed), fitted on first use."""
        if self._finer is None:
            step(f"richer form of {self.current.label}")
            self._finer = fit_all(*self._args, [self.job()], self.workers)[0]
        return self._finer

    def passed_by(self, new: Fit, added) -> bool:
        """True when ``added`` (the member ``new`` adds to ``current``) needs no check (it
        acts on y only, or ``current`` holds no form with a richer one) or ``new`` predicts the
        held-out runs better than the richer model (score lower)."""
        if added.signals != "B and y" or finer_candidate(self.current.candidate) is None:
            return True
        finer = self.finer
        return not isinstance(finer, Fit) or new.score < finer.score

    def refusal(self, new: Fit, added) -> str:
        """"" when :meth:`passed_by`, else why not, in words with the scores."""
        if self.passed_by(new, added):
            return ""
        richer = [m for m in self.current.candidate.members if m.finer]
        return (f"it must predict the held-out runs better than the model before it in its "
                f"richer form ({'; '.join(richer_form(m) for m in richer)}), which does "
                f"as well without it (score {self.finer.score:.4g} against {new.score:.4g}): "
                "also consistent with a richer "
                + " + ".join(m.cause for m in richer))
