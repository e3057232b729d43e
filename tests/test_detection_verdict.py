"""The detection study's verdict on one dataset (benchmarks/diagnose_detection.py).

The issue's "done when": clean data are right when answered ``none``; an effect outside
the six causes alone when answered ``unexplained`` (or ``none``: within noise), never with
a cause; a known cause beside an outside effect when that cause, and no other, is named.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "diagnose_detection.py"
_spec = importlib.util.spec_from_file_location("diagnose_detection", _PATH)
detection = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(detection)

OUTSIDE = ("joint_backlash", "mains_hum")


def _record(effects, cause, causes=()):
    return {"effects": list(effects), "cause": cause, "causes": list(causes)}


def test_clean_data_are_right_answered_none_only():
    assert detection._verdict(_record((), "none"), OUTSIDE) == "named"
    assert detection._verdict(_record((), "unexplained"), OUTSIDE) == "missed"
    assert detection._verdict(_record((), "transport_delay", ["transport_delay"]),
                              OUTSIDE) == "misnamed"


def test_an_outside_effect_alone_is_right_unexplained_or_none_never_a_cause():
    backlash = ("joint_backlash",)
    assert detection._verdict(_record(backlash, "unexplained"), OUTSIDE) == "named"
    assert detection._verdict(_record(backlash, "none"), OUTSIDE) == "named"
    assert detection._verdict(_record(backlash, "mechanical_resonance",
                                      ["mechanical_resonance"]), OUTSIDE) == "misnamed"


def test_a_known_cause_beside_an_outside_effect_must_be_named_alone():
    pair = ("eddy_current_diffusion", "joint_backlash")
    eddy = "eddy_current_diffusion"
    assert detection._verdict(_record(pair, eddy, [eddy]), OUTSIDE) == "named"
    assert detection._verdict(_record(pair, "unexplained"), OUTSIDE) == "missed"
    assert detection._verdict(_record(pair, eddy, [eddy, "mechanical_resonance"]),
                              OUTSIDE) == "misnamed"


def test_the_summary_groups_an_outside_effect_alone_apart():
    rows = [dict(_record(("joint_backlash",), "unexplained"), rate="800", seed=0,
                 sense_voltage=True, strength=1.0, noise_um=0.05, gain=1.0)]
    table = detection.summary_table(rows, OUTSIDE)
    assert "| outside effect alone | 1/1 (100 %) |" in table
