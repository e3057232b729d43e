"""Bad input on the command line: every command, every option of a kind, one rule.

The project's standard: bad input gives exit status 2 and a one-line message
on stderr naming the argument, with no traceback, before any long work starts. The cases of
the first tests are derived from the parser itself (:func:`smeha.cli.build_parser`): each
option built from a :mod:`smeha.cliargs` type -- input file, output file or folder, number --
is driven with a missing file, a directory, an unwritable path and a negative number. A new
command or option built from those types is covered without editing this file.

"Before any work" is checked by replacing the run function of every command with a recorder:
the refusals below happen while parsing, so no command body runs at all. The rules
that need two options or a file's content run at the start of the command body; their tests
replace the work itself (the co-simulation, the FMU build) with a tripwire.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
from pathlib import Path

import pytest

from smeha import cli, cliargs
from smeha.studies import flowcommands


#: A file that exists in every checkout (its content does not matter where it is used).
VARIANT = str(Path(__file__).resolve().parents[1] / "data" / "paper_variant.json")


class WorkStarted(BaseException):
    """Raised by a tripwire in place of long work (BaseException: main() must not catch it)."""


# -- the parser's options, by kind ----------------------------------------------------------
def _subparsers():
    parser = cli.build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return action.choices


def _options(kind):
    """(command, option string or positional name, action) for every option of a kind."""
    for command, sub in _subparsers().items():
        for action in sub._actions:
            if _kind(action.type) == kind:
                yield command, (action.option_strings or [action.metavar])[-1], action


def _kind(convert):
    if convert in (cliargs.input_file, cliargs.fmu_file):
        return "input"
    if convert in (cliargs.output_file, cliargs.plot_file, cliargs.output_dir):
        return "output"
    if getattr(convert, "numeric", False):
        return "number"
    return None


def _ids(cases):
    return [f"{c}-{o}" for c, o, _ in cases]


INPUTS, OUTPUTS, NUMBERS = (list(_options(k)) for k in ("input", "output", "number"))


def test_the_derivation_finds_the_file_and_number_options():
    # the derivation above finds the options it should (a renamed type would empty a list):
    # those a user met first, at least; a command without a file or a number has no such case
    inputs = {(c, o) for c, o, _ in INPUTS}
    assert {("identify", "DATA.csv"), ("diagnose", "DATA.csv"), ("sweep", "SPEC"),
            ("flow", "--variant"), ("simulate", "--fmu"), ("flow", "--fmu"),
            ("sweep", "--fmu")} <= inputs
    outputs = {(c, o) for c, o, _ in OUTPUTS}
    assert {("simulate", "--csv"), ("simulate", "--plot"), ("flow", "--plot"),
            ("sweep", "--out"), ("sweep", "--plot"), ("diagnose", "--report"),
            ("paper", "--plots"), ("build", "--out")} <= outputs
    numbers = {(c, o) for c, o, _ in NUMBERS}
    assert {("simulate", "--load"), ("flow", "--load"), ("flow", "--loads"),
            ("flow", "--workers"), ("sweep", "--workers"), ("simulate", "--duration"),
            ("simulate", "--step"), ("flow", "--cycles")} <= numbers


@pytest.fixture
def calls(monkeypatch):
    """Every command body replaced by a recorder; returns the list of (command, args)."""
    seen = []
    build = cli.build_parser

    def recording_parser():
        parser = build()
        (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        for name, sub in action.choices.items():
            sub.set_defaults(run=lambda args, name=name: seen.append((name, args)) or 0)
        return parser
    monkeypatch.setattr(cli, "build_parser", recording_parser)
    return seen


@pytest.fixture
def valid(tmp_path):
    """A function giving a command's shortest valid argv (required arguments filled)."""
    data = tmp_path / "valid.csv"
    data.write_text("run,frequency_Hz,time_s,current_A,displacement_um\n")

    def argv_for(command, leave_out=None):
        argv = [command]
        for action in _subparsers()[command]._actions:
            if not action.required or action is leave_out:
                continue
            if action.type is cliargs.input_file:
                value = str(data)
            elif action.choices:
                value = list(action.choices)[0]
            else:
                value = "50"
            argv += [value] if not action.option_strings else [action.option_strings[-1],
                                                                 value]
        return argv
    return argv_for


def _refused(capsys, argv, name):
    """Run argv; assert exit 2 with one line naming ``name`` and no traceback."""
    status = cli.main(argv)
    out, err = capsys.readouterr()
    assert status == 2, (argv, out, err)
    assert err.count("\n") == 1 and err.startswith("smeha "), err
    assert name in err and "Traceback" not in err, err
    return err


def _with(argv, option, action, value):
    """argv with ``option`` set to ``value`` (replacing a positional it already fills)."""
    if action.option_strings:
        return [*argv, option, value]
    return [argv[0], value, *argv[1:]]


# -- input files -----------------------------------------------------------------------------
@pytest.mark.parametrize("command, option, action", INPUTS, ids=_ids(INPUTS))
def test_missing_input_file(command, option, action, tmp_path, calls, valid, capsys):
    missing = str(tmp_path / "nowhere" / "missing.txt")
    err = _refused(capsys, _with(valid(command, action), option, action, missing), option)
    assert "no such file" in err and missing in err
    assert calls == []


@pytest.mark.parametrize("command, option, action", INPUTS, ids=_ids(INPUTS))
def test_directory_as_input_file(command, option, action, tmp_path, calls, valid, capsys):
    err = _refused(capsys, _with(valid(command, action), option, action, str(tmp_path)),
                   option)
    assert "is a directory, not a file" in err
    assert calls == []


# -- outputs ---------------------------------------------------------------------------------
@pytest.mark.parametrize("command, option, action", OUTPUTS, ids=_ids(OUTPUTS))
def test_unwritable_output(command, option, action, tmp_path, calls, valid, capsys):
    # a folder cannot be made inside a regular file, whoever runs the test (root included)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    err = _refused(capsys, [*valid(command), option, str(blocker / "sub" / "out.png")], option)
    assert "is a file, not a folder" in err
    assert calls == []


@pytest.mark.parametrize("command, option, action", OUTPUTS, ids=_ids(OUTPUTS))
def test_an_output_under_a_missing_folder_is_refused(command, option, action, tmp_path,
                                                      calls, valid, capsys):
    # as cp refuses it: nothing is created outside the path named (no folder, nor any of
    # its parents, is made on the way)
    root = tmp_path / "outputs"
    root.mkdir()
    target = root / "new" / "deeper" / "out.png"
    err = _refused(capsys, [*valid(command), option, str(target)], option)
    assert "no such folder" in err
    assert calls == [] and list(root.iterdir()) == []


@pytest.mark.parametrize("command, option, action", OUTPUTS, ids=_ids(OUTPUTS))
def test_outputs_in_an_existing_folder_are_accepted_untouched(command, option, action,
                                                              tmp_path, calls, valid):
    # a new folder in an existing one is accepted (the command makes it when it writes);
    # parsing writes nothing
    root = tmp_path / "outputs"
    root.mkdir()
    assert cli.main([*valid(command), option, str(root / "new.png")]) == 0
    assert [c for c, _ in calls] == [command]
    assert list(root.iterdir()) == []


@pytest.mark.parametrize("command, option, action", INPUTS + OUTPUTS,
                         ids=_ids(INPUTS + OUTPUTS))
def test_empty_path(command, option, action, calls, valid, capsys):
    # an empty path would silently mean the current folder
    _refused(capsys, _with(valid(command, action), option, action, ""), "an empty path")
    assert calls == []


@pytest.mark.parametrize("option", ["--csv", "--plot"])
def test_directory_as_output_file(option, tmp_path, calls, valid, capsys):
    err = _refused(capsys, [*valid("simulate"), option, str(tmp_path)], option)
    assert "is a directory; give a file name" in err


# -- numbers ---------------------------------------------------------------------------------
@pytest.mark.parametrize("command, option, action", NUMBERS, ids=_ids(NUMBERS))
def test_negative_number(command, option, action, calls, valid, capsys):
    # "-1e2" is the form Python 3.11's argparse takes for an option ("expected one argument");
    # each numeric option either accepts the value (a load may assist) or names its range
    status = cli.main([*valid(command, action), option, "-1e2"])
    out, err = capsys.readouterr()
    if status == 0:
        ((_, args),) = calls
        assert getattr(args, action.dest) in (-100.0, [-100.0]), option
        assert err == ""
    else:
        assert status == 2 and err.count("\n") == 1, err
        assert f"argument {option}: -1e2 is outside the allowed range" in err, err
        assert calls == []


@pytest.mark.parametrize("argv, dest, value", [
    (["simulate", "--frequency", "50", "--mode", "compensated", "--load", "-100"], "load",
     -100.0),
    (["flow", "--load", "-100"], "load", -100.0),
    (["flow", "--loads", "-200,-100,0,100"], "loads", [-200.0, -100.0, 0.0, 100.0]),
    (["flow", "--loads", "-.5,1e2"], "loads", [-0.5, 100.0]),
])
def test_assisting_loads_in_the_natural_form(argv, dest, value, calls):
    assert cli.main(argv) == 0
    ((_, args),) = calls
    assert getattr(args, dest) == value


@pytest.mark.parametrize("argv, option", [
    (["flow", "--workers", "0"], "--workers"),
    (["sweep", "SPEC", "--workers", "0"], "--workers"),
    (["flow", "--cycles", "2"], "--cycles"),
    (["simulate", "--frequency", "50", "--mode", "compensated", "--cycles", "3.5"], "--cycles"),
    (["flow", "--frequencies", "50,2000"], "--frequencies"),
    (["simulate", "--frequency", "0", "--mode", "compensated"], "--frequency"),
    (["simulate", "--frequency", "50", "--mode", "compensated", "--step", "nan"], "--step"),
])
def test_one_rule_per_option(argv, option, tmp_path, calls, capsys):
    # the same option has the same range in every command that takes it
    spec = tmp_path / "s.toml"
    spec.write_text("")
    argv = [str(spec) if a == "SPEC" else a for a in argv]
    _refused(capsys, argv, f"argument {option}")
    assert calls == []


@pytest.mark.parametrize("address", ["bogus", "tcp://host", "tcp://host:port", ""])
def test_scheduler_address(address, tmp_path, calls, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text("")
    _refused(capsys, ["sweep", str(spec), "--scheduler", address], "argument --scheduler")
    assert cli.main(["sweep", str(spec), "--scheduler", "tcp://10.0.0.5:8786"]) == 0
    assert calls[0][1].scheduler == "tcp://10.0.0.5:8786"


def test_an_option_without_a_value_refuses_a_number(calls, capsys):
    _refused(capsys, ["flow", "--ideal", "-5"], "--ideal")


def test_unknown_option_is_one_line(calls, capsys):
    _refused(capsys, ["flow", "--frequency", "50", "--bogus"], "--bogus")


def _fake_fmu(folder):
    """A zip archive shaped like an FMU (what the parser checks; it is never run)."""
    import zipfile
    path = folder / "fake.fmu"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    return path


@pytest.mark.parametrize("content, words", [
    (b"a,b\n1,2\n", "not a zip archive"), (None, "without modelDescription.xml")])
def test_an_fmu_option_refuses_other_files(content, words, tmp_path, calls, capsys):
    # flow --fmu notcsv.csv was a zipfile.BadZipFile traceback
    path = tmp_path / "notcsv.csv"
    if content is None:
        import zipfile
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("other.txt", "")
    else:
        path.write_bytes(content)
    for command in (["flow"], ["simulate", "--frequency", "50", "--mode", "compensated"]):
        err = _refused(capsys, [*command, "--fmu", str(path)], "argument --fmu")
        assert f"{path} is not an FMU (" in err and words in err
    assert calls == []


# -- rules between options, checked before the work --------------------------------------------
@pytest.fixture
def tripwire(monkeypatch):
    """The co-simulation and the FMU build replaced by WorkStarted."""
    from smeha.studies import flow

    def trip(*args, **kwargs):
        raise WorkStarted
    for module, name in ((flow, "run_case"), (flow, "run_cases"),
                         (flow, "ensure_fmu")):
        monkeypatch.setattr(module, name, trip)


@pytest.mark.parametrize("argv, words", [
    # 1 ms at 50 Hz is 0.05 cycles: the message speaks of --duration, not of "cycles ="
    (["simulate", "--frequency", "50", "--mode", "compensated", "--duration", "0.001"],
     ["--duration 0.001 s is 0.05 cycles at 50 Hz", "--duration >= 0.08 s"]),
    (["simulate", "--frequency", "50", "--mode", "compensated", "--duration", "0.1",
      "--cycles", "5"], ["give --duration or --cycles, not both"]),
    # the retired fast path: refused with the reason, whatever comes with it
    (["flow", "--fast"], ["--fast is retired: the default co-simulation replaced",
                          "is faster"]),
    (["flow", "--fast", "--backend", "direct", "--json"], ["--fast is retired"]),
    (["simulate", "--frequency", "50", "--mode", "compensated", "--backend", "direct",
      "--fmu", "FMU"], ["--fmu FMU has no use"]),
    (["flow", "--backend", "direct", "--fmu", "FMU"], ["has no use"]),
])
def test_rules_between_options(argv, words, tripwire, capsys, tmp_path):
    fmu = str(_fake_fmu(tmp_path))
    argv = [fmu if a == "FMU" else a for a in argv]
    err = _refused(capsys, argv, words[0].replace("FMU", fmu))
    for word in words[1:]:
        assert word in err


def test_coarse_step_warns_in_the_users_terms(tripwire, capsys):
    # 1 ms at 50 Hz: 20 steps a cycle, far below the 250 whose convergence was measured
    # (benchmarks/README.md, Convergence); a warning, not a refusal: the run goes on.
    # Uncompensated: compensated, the master cuts each step at the compensator's samples
    # and no warning is due (tests/test_study_fixes.py)
    with pytest.raises(WorkStarted):
        cli.main(["simulate", "--frequency", "50", "--mode", "uncompensated", "--step",
                  "1e-3", "--backend", "direct"])
    err = capsys.readouterr().err
    assert err.startswith("smeha simulate: warning: --step 0.001 s is 20 steps a cycle at 50 Hz")
    with pytest.raises(WorkStarted):  # the default step is 1000 steps a cycle at 50 Hz
        cli.main(["simulate", "--frequency", "50", "--mode", "compensated",
                  "--backend", "direct"])
    assert "warning" not in capsys.readouterr().err


def test_bad_variant_content_before_the_work(tmp_path, tripwire, capsys):
    bad = tmp_path / "v.json"
    bad.write_text("{not json")
    _refused(capsys, ["flow", "--variant", str(bad)], f"--variant {bad}: not valid JSON")


def test_flow_variant_with_a_none_diagnosis_says_so(tmp_path, monkeypatch, capsys):
    # smeha diagnose --json on data the paper's model explains: cause "none"
    from smeha.studies import flow

    path = tmp_path / "none.json"
    path.write_text(json.dumps({"cause": "none", "gain": 1.0, "candidates": []}))
    seen = []
    monkeypatch.setattr(flow, "run_cases", lambda cases, *a, **k: seen.extend(cases) or [])
    monkeypatch.setattr(flow, "ensure_fmu", lambda **k: None)
    from smeha.studies import flowtables
    monkeypatch.setattr(flowtables, "format_table", lambda rows: "")
    assert cli.main(["flow", "--variant", str(path), "--frequencies", "100"]) == 0
    out, err = capsys.readouterr()
    assert "names no extension" in err and "cause 'none'" in err
    assert "names no extension" in out  # stated with the results as well
    assert {c.model for c in seen} == {"paper"}
    assert cli.main(["flow", "--variant", str(path), "--frequencies", "100", "--json"]) == 0
    variant = json.loads(capsys.readouterr().out)["variant"]
    assert variant["cause"] == "none" and "names no extension" in variant["note"]


def test_sweep_table_is_named_after_the_spec(tmp_path, monkeypatch, capsys):
    # two specs in one folder write two tables, not one appended table
    from smeha.studies import sweep

    outs = []

    def fake_run_sweep(points, out, *args, **kwargs):
        outs.append(out)
        return sweep.SweepResult(rows=[], skipped=0, failed=0, ran=0, kept=[])
    monkeypatch.setattr(sweep, "run_sweep", fake_run_sweep)
    for name in ("low.toml", "high.toml"):
        (tmp_path / name).write_text('[grid]\nfrequency = [100]\nmode = ["compensated"]\n'
                                     '[settings]\nbackend = "direct"\ncycles = 4\n')
        assert cli.main(["sweep", str(tmp_path / name), "--json"]) == 0
    assert outs == [tmp_path / "low.csv", tmp_path / "high.csv"]
    assert flowcommands.default_sweep_table(tmp_path / "odd.csv") == tmp_path / "odd.csv.csv"


# -- start-up and help -----------------------------------------------------------------------
def test_help_imports_no_heavy_module():
    # smeha --help must answer at once (benchmarks/cli_startup.py prints the time): the
    # parser of every command is built without numpy, scipy, control, fmpy or matplotlib
    import subprocess
    import sys

    # (system_models.defaults, the co-simulation's default numbers, imports nothing)
    code = ("import sys; from smeha import cli; cli.build_parser(); "
            "print(sorted(m for m in ('numpy', 'scipy', 'control', 'fmpy', 'matplotlib', "
            "'numba', 'system_models.cosim', 'system_models.kernel') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("command", sorted(_subparsers()))
def test_every_command_has_help_for_every_option(command, capsys):
    sub = _subparsers()[command]
    for action in sub._actions:
        assert action.help, f"smeha {command} {action.option_strings or action.dest}"
    assert cli.main([command, "--help"]) == 0
    assert capsys.readouterr().out.startswith(f"usage: smeha {command}")


def test_build_states_where_the_fmu_goes(capsys):
    from smeha.fmu import build as fmu_build
    from smeha.studies import flow

    cli.main(["build", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "dist/ of the smeha source tree" in out and "simulate, flow and sweep" in out
    assert flow.default_fmu_path().parent == fmu_build.DIST


def test_build_options_reach_the_builder(tmp_path, monkeypatch):
    from smeha.fmu import build as fmu_build

    seen = []
    monkeypatch.setattr(fmu_build, "build_all",
                        lambda fmi, out, validate: seen.append((fmi, out, validate)) or 0)
    assert cli.main(["build", "--fmi", "3", "--out", str(tmp_path / "d"), "--no-validate"]) == 0
    assert cli.main(["build"]) == 0
    assert seen == [("3", tmp_path / "d", False), ("2", fmu_build.DIST, True)]
    # build_fmu.py is the same command line
    script = importlib.util.spec_from_file_location(
        "build_fmu", Path(__file__).resolve().parents[1] / "build_fmu.py")
    build_fmu = importlib.util.module_from_spec(script)
    script.loader.exec_module(build_fmu)
    assert build_fmu.main(["--fmi", "both", "--out", str(tmp_path / "e")]) == 0
    assert seen[-1] == ("both", tmp_path / "e", True)


@pytest.mark.parametrize("value", ["50,,100", "50,", ",100"])
def test_a_list_with_an_empty_item_is_refused(value, capsys):
    # "--frequencies 50,,100" ran 50 and 100 Hz as if the middle one were not
    # asked for; a number left out is a mistake to name, not a shorter list
    assert cli.main(["flow", "--frequencies", value]) == 2
    err = capsys.readouterr().err
    assert "empty item" in err and "Traceback" not in err
