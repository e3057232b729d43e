"""The extended model a diagnosis names, as a gmt.ModelVariant.

Reading the diagnosis' JSON is smeha's (:func:`smeha.diagnose.variant_from_diagnosis`);
gmt reads only the variant itself (a combination's stepping: tests/test_variants.py).
"""
from __future__ import annotations

import math

import pytest

import gmt
from gmt import extensions as ext
from smeha.diagnose import variant_from_diagnosis

P = gmt.TransducerParameters()
CONTEXT = {"params": P, "field_max": P.field_per_ampere}
#: internal unknowns of each extension for the tests below: its fit's first start vector
INTERNAL = {(e.cause, e.form): e.fit.starts[0] for e in ext.EXTENSIONS}


def single(cause, form=""):
    cls = ext.lookup(cause, form)
    return gmt.ModelVariant(cause, cls.from_fit(INTERNAL[cause, form], CONTEXT), form)


# ------------------------------------------------------------------ reading the diagnosis


def _candidates():
    return [{"cause": c, "form": f, "score": 100.0,
             "parameters": ext.lookup(c, f).from_fit(x, CONTEXT)}
            for (c, f), x in INTERNAL.items()]


def test_from_diagnosis_takes_the_winner_none_and_a_named_candidate():
    d = {"cause": "transport_delay", "form": "", "candidates": _candidates(), "gain": 3.0}
    assert variant_from_diagnosis(d) == single("transport_delay")
    assert variant_from_diagnosis(d, cause="mechanical_resonance", form="two_dof") == single(
        "mechanical_resonance", "two_dof")
    assert variant_from_diagnosis(dict(d, cause="none")).is_paper
    with pytest.raises(gmt.ParameterError, match="unexplained.*explicitly"):
        variant_from_diagnosis(dict(d, cause="unexplained"))
    assert variant_from_diagnosis(dict(d, cause="unexplained"),
                                  cause="thermal_drift").cause == "thermal_drift"


def test_a_cause_with_several_formulations_takes_the_named_or_best_one():
    lag = {"cause": "eddy_current_diffusion", "form": "lag", "score": 90.0,
           "parameters": {"time_constant_s": 1e-3, "order": 0.5}}
    slab = {"cause": "eddy_current_diffusion", "form": "slab", "score": 80.0,
            "parameters": {"time_constant_s": 2e-3}}
    d = {"cause": "eddy_current_diffusion", "form": "lag", "candidates": [slab, lag]}
    v = variant_from_diagnosis(d)
    assert (v.form, v.parameters["order"]) == ("lag", 0.5) and v.name == "eddy_current_diffusion"
    # the winner's form, even when its score is not the cause's best
    won = variant_from_diagnosis(dict(d, form="slab", candidates=[lag, dict(slab, score=95.0)]))
    assert won == gmt.ModelVariant("eddy_current_diffusion", {"time_constant_s": 2e-3}, "slab")
    # without the winner's form the best score wins
    assert variant_from_diagnosis({k: d[k] for k in ("cause", "candidates")}).form == "slab"
    # a candidate without "form" is its cause's first form (diagnoses written before forms)
    old = {"cause": "eddy_current_diffusion", "form": "lag",
           "candidates": [{k: lag[k] for k in ("cause", "parameters")}, slab]}
    assert variant_from_diagnosis(old) == v
    with pytest.raises(gmt.ParameterError, match=r"form = 'sphere' is not a form of "
                                                 r"'eddy_current_diffusion'"):
        variant_from_diagnosis(dict(d, form="sphere"))
    with pytest.raises(gmt.ParameterError, match="no candidate of form 'cylinder'"):
        variant_from_diagnosis(dict(d, form="cylinder"))


def test_the_model_of_a_diagnosis_with_two_causes():
    # smeha diagnose --json carries the extended model itself ("model"): a combination
    pair = gmt.ModelVariant.combine(single("transport_delay"),
                                    single("magnetization_saturation"))
    d = {"cause": "magnetization_saturation", "form": "", "causes":
         ["magnetization_saturation", "transport_delay"], "model": pair.as_dict(),
         "candidates": _candidates()}
    assert variant_from_diagnosis(d) == pair
    # a named single candidate is still available
    assert variant_from_diagnosis(d, cause="transport_delay") == single("transport_delay")
