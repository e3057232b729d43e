"""A richer form fits no worse than the form it refines (smeha.diagnose.resolution).

The finer grid holds 1.5 times the nodes along each axis over the same range, so the
density it can represent includes, to within its quadrature, every density of the coarse
grid: fitted from the coarse fit carried over (gmt.extensions.preisach.projected_weights),
it must describe the training runs at least as well. Fitted from its own starts it ended
above the coarse fit on two of three labsim datasets (seed 3 at 800 samples a period:
2 210 against 1 778), which let the check pass any cause. The richer saturation law holds
the law it refines (c = 0) and starts from its fit.

Data: labsim's general Preisach densities (tests/labsim, written apart from the
candidates), at 400 samples a period (the outside lab files' clock), seeds 221 and 222,
fixed before any result was seen and unused in developing the projection (seeds 3, 103
and 108 at 800 were).
"""
from __future__ import annotations

import gmt
import pytest
from labsim_runs import TEXTBOOK_FORMULATIONS, runs

from smeha.diagnose import resolution
from smeha.diagnose.candidates import PAPER, candidates
from smeha.diagnose.fit import fit_and_score
from smeha.diagnose.workflow import _prepared


@pytest.mark.integration
@pytest.mark.parametrize("seed", [221, 222])
def test_the_finer_density_fits_the_training_runs_at_least_as_well(seed):
    data = runs({"rate_independent_hysteresis": 1.0}, seed=seed, noise_um=0.05,
                samples_per_cycle=400, formulations=TEXTBOOK_FORMULATIONS)
    *_, ev, base0, train, held = _prepared(data, None, gmt.TransducerParameters())
    paper = fit_and_score(ev, train, held, PAPER, base0)
    density = next(c for c in candidates() if c.label == "rate_independent_hysteresis (preisach)")
    coarse = fit_and_score(ev, train, held, density, paper.base)
    finer = fit_and_score(ev, train, held, *resolution.finer_job(coarse))
    # no tolerance: the finer fit starts within 0.3 % of the coarse loops and only takes
    # steps that lower its training chi^2; ending above the coarse fit is the failure it guards
    # against. Measured: seed 221 318.7 against 369.0, seed 222 398.7 against 1 307.2; from
    # its own starts instead of the coarse loops seed 221 ends at 881.2 and fails here
    assert finer.train_chi2 <= coarse.train_chi2


@pytest.mark.integration
def test_the_richer_saturation_law_fits_the_training_runs_at_least_as_well():
    # the richer form holds the law it refines (shoulder c = 0) and starts from its fit, so
    # it may only lower the training chi^2. Data: labsim's mean-field Langevin saturation
    # (a knee outside the candidate's family), 100 samples a period, seed 223, fixed
    # before any result was seen
    data = runs({"magnetization_saturation": 1.0}, seed=223, noise_um=0.05,
                samples_per_cycle=100,
                formulations={"magnetization_saturation": "mean_field_langevin"})
    *_, ev, base0, train, held = _prepared(data, None, gmt.TransducerParameters())
    paper = fit_and_score(ev, train, held, PAPER, base0)
    law = next(c for c in candidates() if c.label == "magnetization_saturation")
    fitted = fit_and_score(ev, train, held, law, paper.base)
    richer = fit_and_score(ev, train, held, *resolution.finer_job(fitted))
    assert richer.candidate.members[0] is law.members[0].finer
    assert richer.train_chi2 <= fitted.train_chi2
