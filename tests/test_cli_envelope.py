"""The flow study's options off their defaults: one declaration per range, the likely
mistake named, long runs announced, and no warning at the defaults.

The defects the tests guard against: ``simulate --frequency 0.001`` starting
80,000,000 steps without a word; ``--load nan`` reported as "outside the allowed range
(-inf, inf)"; ``--cycles 2.5`` refused with no reason; the main job reporting "not settled"
on 6 of 8 rows (8 of 8 at ``--cycles 40``).
"""
from __future__ import annotations

import argparse

import pytest

import gmt
from smeha import cli
from smeha.settings import Setting
from smeha.studies import flow, flowsettings


class WorkStarted(BaseException):
    """Raised in place of the co-simulation (main() must not catch it)."""


@pytest.fixture
def tripwire(monkeypatch):
    def trip(*args, **kwargs):
        raise WorkStarted
    for name in ("run_case", "run_cases", "ensure_fmu"):
        monkeypatch.setattr(flow, name, trip)


def _one_line(capsys, argv):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


def test_a_frequency_in_the_wrong_unit_is_refused_with_the_likely_mistake(capsys):
    # 0.001 Hz: eight cycles are 8,000 s, 80,000,000 steps (about 40 min), started silently
    err = _one_line(capsys, ["simulate", "--frequency", "0.001", "--mode", "compensated"])
    assert "argument --frequency: 0.001 is outside the allowed range: in [1, 1000] Hz" in err
    assert "a period in seconds" in err


def test_a_long_run_is_announced_before_it_starts(tripwire, capsys):
    # 3,000 cycles at 1 Hz: 3,000 s simulated, 30,000,000 steps: estimated ~15 min
    with pytest.raises(WorkStarted):
        cli.main(["simulate", "--frequency", "1", "--cycles", "3000", "--mode",
                  "compensated", "--backend", "direct"])
    err = capsys.readouterr().err
    assert err.startswith("smeha simulate: warning: this run is estimated at up to about 15 min")
    assert "30,000,000 steps" in err
    with pytest.raises(WorkStarted):  # the default run: no word
        cli.main(["simulate", "--frequency", "50", "--mode", "compensated", "--backend",
                  "direct"])
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("argv, words", [
    (["flow", "--load", "nan"], "argument --load: nan is not a number (allowed: in "
                                "(-1e+07, 1e+07) N)"),
    (["flow", "--load", "inf"], "argument --load: inf is not finite"),
    (["flow", "--frequencies", "50,nan"], "argument --frequencies: nan is not a number"),
    (["flow", "--cycles", "2.5"], "argument --cycles: 2.5 is outside the allowed range: at "
                                  "least 4 cycles (the flow check discards the first 2 "
                                  "compression strokes"),
    (["simulate", "--frequency", "50", "--mode", "compensated", "--seed", "1.5",
      "--measurement", "m.csv"], "argument --seed: 1.5 is not a whole number"),
])
def test_messages_say_what_is_wrong(argv, words, capsys):
    assert words in _one_line(capsys, argv)


def _setting_options():
    parser = cli.build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for command in ("simulate", "flow"):
        for action in sub.choices[command]._actions:
            setting = getattr(action.type, "setting", None)
            if isinstance(setting, Setting) and setting.name not in ("value", "count"):
                yield command, action, setting


def test_help_parser_and_study_read_one_declaration():
    # each declared option's --help shows the range its parser checks; the study (Case)
    # refuses outside it with the same range
    options = list(_setting_options())
    assert {s.name for _, _, s in options} >= {"frequency", "load", "cycles", "step",
                                               "amplitude"}
    for command, action, setting in options:
        assert setting.interval() in " ".join(action.help.split()), (command, action.help)
    for name, value in (("frequency", 0.5), ("cycles", 2.5), ("load", float("nan")),
                        ("amplitude", 2000.0)):
        setting = getattr(flowsettings, name.upper())
        kwargs = {"frequency": 100.0, "mode": "compensated", name: value}
        with pytest.raises(gmt.ParameterError) as info:
            flow.Case(**kwargs)
        assert str(info.value).startswith(f"{name} = ")
        assert setting.interval() in str(info.value)


def test_settled_is_judged_at_the_printed_precision():
    # the realistic circuit's flow trends by 2-5e-4 a cycle while the piston travels
    # (measured: up to 4.2e-4 at the default 8 cycles, 4.6e-4 at 40); the table prints its
    # ratios with three decimals, which one more cycle (drift / 2) leaves unchanged
    for drift in (4.2e-4, -4.6e-4, 1e-3):
        assert flow.settled(drift)
    assert not flow.settled(3.75e-3)  # time-domain magnetics, square drive: 0.375 % a cycle


@pytest.mark.integration  # the main job's eight co-simulations in-process (~2 s)
def test_the_main_job_prints_no_warning(capsys):
    assert cli.main(["flow", "--backend", "direct", "--workers", "1"]) == 0
    out, err = capsys.readouterr()
    assert "not settled" not in out and "warning" not in err


def test_a_long_sweep_is_announced(tmp_path, tripwire, capsys):
    spec = tmp_path / "long.toml"
    spec.write_text('[grid]\nfrequency = [1, 2]\nmode = ["compensated"]\n'
                    '[settings]\nbackend = "direct"\ncycles = 3000\n')
    with pytest.raises(WorkStarted):
        cli.main(["sweep", str(spec), "--workers", "1"])
    assert "smeha sweep: warning: this run is estimated at up to about" in capsys.readouterr().err
