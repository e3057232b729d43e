"""The text report's table reads true (smeha.diagnose.report.candidate_table).

The named model's row comes first and is the model the headline's figures are of; every
other model follows once (its best-scored fit), labels whole, no empty form "()", and a
note says what k counts. Fits are built by hand (test_decision's helper): the table is
formatting, independent of any fit.
"""
from __future__ import annotations

from types import SimpleNamespace

from test_decision import _cls, fit

from smeha.diagnose.report import candidate_table


def _diagnosis():
    density = _cls("rate_independent_hysteresis", "preisach")
    plays = _cls("rate_independent_hysteresis", "")
    delay, sat = _cls("transport_delay"), _cls("magnetization_saturation")
    one = _cls("mechanical_resonance", "one_dof")
    named = fit((density, delay), y=50.0)
    # the same model fitted again (continued) with a worse score, a better-scored
    # combination that was refused, and a long three-cause label
    again = fit((density, delay), y=80.0)
    refused = fit((density, one), y=40.0)
    long = fit((density, sat, delay), y=45.0)
    singles = [fit((density,), y=300.0), fit((plays,), y=900.0), fit((sat,), y=1000.0)]
    return SimpleNamespace(cause="rate_independent_hysteresis", extended=named,
                           paper=fit((), y=5000.0), fits=singles,
                           combinations=[again, refused, long])


def test_the_named_model_comes_first_and_each_model_once():
    d = _diagnosis()
    lines = candidate_table(d)
    rows = lines[2:lines.index(next(ln for ln in lines if ln.startswith("misfit, RMS")))]
    assert rows[0].startswith("rate_independent_hysteresis (preisach) + transport_delay ")
    assert "named" in rows[0].split()
    names = [r.split("  ")[0].strip() for r in rows]
    assert len(names) == len(set(names)) == 7  # named, 2 combinations, 3 singles, paper
    # the runners-up by held-out score: the refused pair (excess 40) before the long one (45)
    assert names[1] == "rate_independent_hysteresis (preisach) + mechanical_resonance (one_dof)"
    assert names[2] == ("rate_independent_hysteresis (preisach) + magnetization_saturation + "
                        "transport_delay")
    assert "rate_independent_hysteresis (play_operators)" in names
    assert not any("()" in r for r in rows) and names[-1] == "paper (none)"
    assert "effective degrees of freedom" in " ".join(lines[len(rows) + 2:])


def test_without_a_named_cause_no_row_is_marked_named():
    d = _diagnosis()
    d.cause, d.extended = "unexplained", d.paper
    lines = candidate_table(d)
    rows = lines[2:lines.index(next(ln for ln in lines if ln.startswith("misfit, RMS")))]
    assert rows[0].startswith("paper (none)") and not any(" named " in r for r in rows)
