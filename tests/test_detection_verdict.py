"""The detection study's verdict on one dataset (benchmarks/diagnose_detection.py).

The scoring: clean data are right when answered ``none``; an effect outside
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


def _run(code, causes, seed=0, strength=1.0):
    return {"code": code, "effects": ["transport_delay"], "seed": seed, "rate": "800",
            "strength": strength, "noise_um": 0.05, "sense_voltage": True,
            "labsim_options": {}, "cause": causes[0] if causes else "none",
            "causes": list(causes)}


def test_latest_keeps_each_datasets_result_of_the_newest_commit(monkeypatch):
    # --summary --latest: of one dataset run by several codes only the newest commit's
    # result counts (commit times as git gives them; here given), whatever the files'
    # order; a code not in the history counts as the oldest; other datasets stay apart
    monkeypatch.setattr(detection, "_commit_times", lambda: {"aaaaaaa": 100, "bbbbbbb": 200})
    old = _run("aaaaaaa", ["mechanical_resonance"])
    new = _run("bbbbbbb-dirty", ["transport_delay"])
    stranger = _run("ccccccc", ["thermal_drift"])
    other_seed = _run("aaaaaaa", ["transport_delay"], seed=1)
    weak = _run("aaaaaaa", [], strength=0.01)
    out = detection.latest([new, stranger, old, other_seed, weak])
    assert len(out) == 3
    assert new in out and other_seed in out and weak in out


def test_the_summary_keeps_the_threshold_strengths_apart():
    # a weak effect answered none (the threshold study) is not a miss of the full-strength
    # row
    table = detection.summary_table([_run("a", ["transport_delay"]),
                                     _run("a", [], strength=0.01)], OUTSIDE)
    assert "| first forms | yes | transport_delay | 1/1 (100 %) |" in table
    assert "| first forms | yes | transport_delay at strength 0.01 | 0/1 (0 %) |" in table
