"""The saturation candidate fits a law of which the paper's M is the tangent at the bias.

The paper's linear model is the small-signal model about the transducer's operating
point, so a rod's anhysteretic curve may have the paper's susceptibility as its slope at
the bias rather than at zero (gmt.extensions.saturation: k and d). labsim's arctangent law
(tests/labsim/alternatives.py, written apart from the candidates) is built that way; the
candidate holds it only with the bias's place on the curve, d, among its unknowns: without
it the held-out chi^2/n stayed at 1.18e4 on seed 0 at 800 samples a period (the pairs
holding it lost their second cause: 11 of 25 named at 800 a period, seeds 0-4).

Data: labsim's arctangent law alone at 400 samples a period (the outside lab files' clock),
seed 224, fixed before any result was seen; and at the 20 kHz lab clock, seed 0, where the
fit with the shift allowed up to d = +1 ended on that bound from both starts (k = 0.5,
d = 1, held-out chi^2/n 9.1e4; the report: named, but weak, gain 1.84); and at strength 1.5
(the bias at 0.65 M_s, k = 3.7, d = -1.36), seed 0 at 800 a period, reached from neither of
the two starts before the third (chi^2/n 1.9e6). labsim's Froehlich-Kennelly law at strength
1 sits at k = 4, d = -1: with k up to 4 and d down to -1 its fit was reported weak.
"""
from __future__ import annotations

import gmt
import pytest
from labsim_runs import runs

from smeha.diagnose.candidates import PAPER, candidates
from smeha.diagnose.fit import fit_and_score
from smeha.diagnose.rules import WITHIN_NOISE
from smeha.diagnose.workflow import _prepared


@pytest.mark.integration
@pytest.mark.parametrize("law, strength, seed, clock", [
    ("arctangent", 1.0, 224, {"samples_per_cycle": 400}),
    ("arctangent", 1.0, 0, {"sample_rate": 20e3}),
    ("arctangent", 1.5, 0, {"samples_per_cycle": 800}),
    ("froehlich_kennelly", 1.0, 0, {"samples_per_cycle": 800})])
def test_a_law_tangent_to_the_paper_at_the_bias_is_fitted_to_within_noise(law, strength, seed,
                                                                          clock):
    data = runs({"magnetization_saturation": strength}, seed=seed, noise_um=0.05,
                formulations={"magnetization_saturation": law}, **clock)
    *_, ev, base0, train, held = _prepared(data, None, gmt.TransducerParameters())
    paper = fit_and_score(ev, train, held, PAPER, base0)
    cand = next(c for c in candidates() if c.label == "magnetization_saturation")
    fit = fit_and_score(ev, train, held, cand, paper.base)
    # within noise on the held-out runs by the diagnosis' own rule (reduced chi^2 at most
    # WITHIN_NOISE, the threshold of "none": what is left is the noise's)
    assert fit.heldout_chi2 / fit.heldout_n <= WITHIN_NOISE
    # the bias sits off the law's zero: d < 0 and k > 1, as the tangent at the bias asks
    # (labsim's arctangent law at M_s = 450 kA/m: k = 2.42, d = -0.59; at strength 1.5:
    # 3.7, -1.36; its Froehlich-Kennelly law: 4, -1)
    assert fit.parameters["bias_shift"] < -0.2 and fit.parameters["initial_slope"] > 1.5
    # inside the ranges: a law the family holds is not reported weak
    assert not fit.weak
