"""No traceback from any command line: a property-based test over every command.

Hypothesis builds command lines from the parser itself (:func:`smeha.cli.build_parser`):
each option gets a valid value, an edge value, NaN, infinities, an empty list item, a value
in a likely wrong unit, or -- for paths -- a missing file, a folder, a file of the wrong
kind, a file under a missing folder or under a file. The invariant, for every command line:

* exit status 0, or 2 with one line on stderr that starts ``smeha`` and names an option or
  argument given, never a traceback;
* nothing written outside the paths named: the long work of each command is replaced by a
  tripwire (:class:`WorkStarted`), so a command line that reaches it has passed every
  check that comes before the work, and the sandbox it ran in holds nothing new but a
  path the command line names (an output folder made for the work).

Bounded for CI: in-process, the work mocked, a fixed number of examples a command
(:data:`EXAMPLES`), derandomized so a failure repeats.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from smeha import cli, cliargs
from smeha.coreloss.commands import material_or_file

#: Command lines tried per command (SMEHA_CLI_EXAMPLES raises it for a deeper local search).
EXAMPLES = int(os.environ.get("SMEHA_CLI_EXAMPLES", "50"))


class WorkStarted(BaseException):
    """Raised in place of a command's long work (not an Exception: main() must not catch it)."""


def _trip(*args, **kwargs):
    raise WorkStarted


#: The commands whose long work :data:`WORK` lists; another command's body is not run.
COMMANDS_WITH_WORK_LISTED = {"paper", "simulate", "flow", "sweep", "position", "timedomain",
                             "identify", "diagnose", "build", "losses"}
#: The long work of every command: (module, function) replaced by the tripwire.
WORK = [("smeha.studies.flow", "run_case"), ("smeha.studies.flow", "run_cases"),
        ("smeha.studies.flow", "ensure_fmu"), ("smeha.studies.sweep", "run_sweep"),
        ("smeha.studies.paper", "compensated_runs"), ("smeha.identify", "identify"),
        ("smeha.diagnose", "diagnose"), ("smeha.fmu.build", "build_all"),
        ("smeha.fmu.ssp", "build_system"), ("smeha.studies.timedomain", "compare_rows"),
        ("smeha.studies.timedomain", "waveform_rows"),
        ("smeha.studies.timedomain", "gain_rows"), ("smeha.studies.position", "run_study"),
        ("smeha.studies.position", "flow_table_velocity"),
        ("smeha.coreloss.study", "run"), ("smeha.coreloss.measurements", "read_magnet"),
        ("system_models.kernel", "ensure_compiled")]


@pytest.fixture(scope="module")
def no_work():
    import importlib
    import sys
    parser = cli.build_parser()  # built once: parsing does not change it
    for name, sub in _subparsers(parser).items():
        if name not in COMMANDS_WITH_WORK_LISTED:  # a command this file does not know yet:
            sub.set_defaults(run=_trip)           # its parser is tested, its body is not run
    saved = [(cli, "build_parser", cli.build_parser)]
    cli.build_parser = lambda: parser
    for module_name, name in WORK:
        module = importlib.import_module(module_name)
        if hasattr(module, name):
            saved.append((module, name, getattr(module, name)))
            setattr(module, name, _trip)
    # a safety net below the studies, wherever a study imported them: the co-simulation,
    # the force port's loop and the transducers (a renamed study function still trips)
    for module_name in ("smeha.studies.positionloop", "smeha.studies.timedomain"):
        importlib.import_module(module_name)
    from system_models import cosim, forceport
    core = {id(f) for f in (cosim.cosimulate, forceport.run_force_port, cosim.FmuTransducer,
                            cosim.DirectTransducer)}
    for module in [m for n, m in list(sys.modules.items())
                   if n.split(".")[0] in ("smeha", "system_models") and m is not None]:
        for name, value in list(vars(module).items()):
            if id(value) in core:
                saved.append((module, name, value))
                setattr(module, name, _trip)
    yield
    for module, name, function in saved:
        setattr(module, name, function)


def _subparsers(parser=None):
    parser = parser or cli.build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return action.choices


COMMANDS = sorted(_subparsers())

_INPUTS = {getattr(cliargs, n, None) for n in ("input_file", "fmu_file")} - {None}
#: ``smeha losses``' MATERIAL|FILE: a material name or a core-loss file.
_MATERIAL_OR_FILE = material_or_file
_OUTPUTS = {getattr(cliargs, n, None) for n in ("output_file", "plot_file", "output_dir")} \
    - {None}

#: Numbers: valid, edges, not finite, wrong units, malformed, lists with empty items.
NUMBERS = ["50", "100", "1", "0", "-0", "-1e2", "1000", "1000.5", "1e4", "2.5", "4", "8",
           "0.001", "1e-9", "nan", "NaN", "inf", "-inf", "1e309", "", " ", "abc", "5mm",
           "50,100", "50,,100", "50,", ",", "-100,0,100", "0x10", "1_000"]
#: Other free text (addresses, run names, "auto").
TEXTS = ["tcp://127.0.0.1:8786", "bogus", "", "auto", "run1", "run1,,run2", "50,100"]
#: Paths, relative to the sandbox: what they are is made before the run (_make_paths).
PATHS = ["data.csv", "spec.toml", "model.fmu", "variant.json", "notes.txt", "folder",
         "missing.csv", "nowhere/out.png", "out.png", "out.txt", "out.csv", "newdir",
         "notes.txt/out.png", "", "folder/out.png"]
#: Core-loss sources: a material, a name of none, files that are no core-loss CSV (binary,
#: not gzip, a bad outlier column) and the paths above. Reading the shipped MagNet files
#: counts as work (:data:`WORK`); a user's file is read for real.
CORE_LOSS_SOURCES = ["3E6", "N99", "model.csv", "bad.csv.gz", "outlier.csv", *PATHS]


def _make_paths(root: Path) -> None:
    (root / "data.csv").write_text("run,frequency_Hz,time_s,current_A,displacement_um\n"
                                   "a,50,0.0,1.0,0.0\na,50,0.001,0.9,1.0\n")
    (root / "spec.toml").write_text('[grid]\nfrequency = [100]\nmode = ["compensated"]\n'
                                    '[settings]\nbackend = "direct"\ncycles = 4\n')
    import zipfile
    with zipfile.ZipFile(root / "model.fmu", "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    (root / "variant.json").write_text('{"cause": "none"}')
    (root / "notes.txt").write_text("not data\n")
    (root / "folder").mkdir()
    (root / "model.csv").write_bytes((root / "model.fmu").read_bytes())
    (root / "bad.csv.gz").write_text("frequency_Hz,loss_W_m3\n")
    (root / "outlier.csv").write_text("frequency_Hz,loss_W_m3,flux_samples_T,"
                                      "outlier_factor_pct\n100,1,0.1,abc\n")


def _values(action):
    """A strategy for one option's value, by its kind."""
    if action.type is _MATERIAL_OR_FILE:
        return st.sampled_from(CORE_LOSS_SOURCES)
    if action.type in _INPUTS or action.type in _OUTPUTS:
        return st.sampled_from(PATHS)
    if action.choices:
        return st.sampled_from([*map(str, action.choices), "bogus", ""])
    if getattr(action.type, "numeric", False):
        return st.sampled_from(NUMBERS)
    return st.sampled_from(TEXTS + NUMBERS[:3])


@st.composite
def command_lines(draw, command):
    sub = _subparsers()[command]
    argv = [command]
    for action in sub._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if not action.option_strings:  # a positional: usually given
            if draw(st.integers(0, 9)) > 0:
                argv.append(draw(_values(action)))
            continue
        if not action.required and not draw(st.booleans()):
            continue
        flag = action.option_strings[-1]
        if action.nargs == 0:
            argv.append(flag)
        elif action.nargs == "?" and draw(st.booleans()):
            argv.append(flag)
        else:
            argv += [flag, draw(_values(action))]
    return argv


def _snapshot(root: Path):
    return sorted((str(p.relative_to(root)), p.is_dir()) for p in root.rglob("*"))


@contextlib.contextmanager
def sandbox():
    """A folder holding the files :data:`PATHS` names; yields (folder, its listing)."""
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        _make_paths(root)
        yield root, _snapshot(root)


def check_command_line(argv, root, before):
    """Run ``argv`` in the sandbox ``root`` (listed ``before``); assert the invariant of the
    module docstring. The sandbox stays as it was, so the next command line can reuse it."""
    cwd = os.getcwd()
    out, err = io.StringIO(), io.StringIO()
    os.chdir(root)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = cli.main(argv)
            except WorkStarted:
                status = 0  # every check before the work passed
    finally:
        os.chdir(cwd)
    err = err.getvalue()
    assert "Traceback" not in err, (argv, err)
    assert status in (0, 2), (argv, status, err)
    if status == 2:
        assert err.count("\n") == 1 and err.startswith("smeha"), (argv, err)
        named = [a.split("=")[0] for a in argv if a.startswith("--")] + argv[1:]
        assert any(n and n in err for n in named) or "argument" in err, (argv, err)
    after = _snapshot(root)
    new = sorted(set(after) - set(before))
    if new:  # put the sandbox back, so that the next command line is judged alone
        import shutil
        for name, _ in reversed(new):
            shutil.rmtree(root / name) if (root / name).is_dir() else (root / name).unlink()
    # only a path named on the command line (an output folder the command makes) may appear
    outside = [name for name, _ in new if not any(name == a or name.startswith(a + "/")
                                                  for a in argv[1:] if a)]
    assert not outside, (argv, "wrote outside the paths named", outside)


@pytest.mark.parametrize("command", COMMANDS)
def test_no_traceback_from_any_command_line(command, no_work):
    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(command_lines(command))
    def run(argv):
        check_command_line(argv, root, before)
    with sandbox() as (root, before):
        run()


def _fake_row(case):
    """A flow-study row for ``case`` with made-up figures (what the output stage reads)."""
    from smeha.studies.flowrow import FlowRow
    q = 3e-6
    return FlowRow(
        frequency_Hz=case.frequency, mode=case.mode, model=case.model, circuit=case.circuit,
        load_N=case.load_force, flow_sim_m3_s=q, flow_eq_m3_s=q, flow_ratio=1.0, dy_um=25.0,
        flow_sim_L_min=q * 6e4, flow_paper_m3_s=None, dy_paper_um=None, dy_free_um=30.0,
        flow_free_m3_s=q, delivered_fraction=1.0, control_amplitude_V=None,
        load_pressure_Pa=1e5, p_pump_min_Pa=1e5, p_pump_max_Pa=2e6, p_min_Pa=1e5,
        p_min_volume="pump", volume_imbalance_m3=0.0, volume_pumped_m3=1e-7,
        cycles_averaged=5, flow_drift_per_cycle=0.0, settled=True, step_s=case.step,
        coupling=case.coupling, backend=case.backend, wall_s=0.0, magnetics=case.magnetics,
        waveform=case.waveform)


@pytest.fixture
def fake_work(monkeypatch):
    """The co-simulations replaced by made-up rows, after opening the FMU as the real run
    does: the output stage (tables, plots, files) runs for real."""
    from smeha.studies import flow
    from test_cli_plots import _record

    def open_fmu(fmu_path):
        if fmu_path is not None:
            import fmpy
            fmpy.read_model_description(str(fmu_path))

    def run_cases(cases, fmu_path=None, **kwargs):
        open_fmu(fmu_path)
        return [_fake_row(c) for c in cases]

    def run_case(case, fmu_path=None, progress=None):
        open_fmu(fmu_path)
        return _record(case.frequency), None, _fake_row(case)
    monkeypatch.setattr(flow, "run_cases", run_cases)
    monkeypatch.setattr(flow, "run_case", run_case)
    monkeypatch.setattr(flow, "ensure_fmu", lambda **k: None)
    from system_models import kernel
    monkeypatch.setattr(kernel, "ensure_compiled", lambda *a, **k: None)


@pytest.mark.parametrize("argv", [
    ["flow", "--plot", "out.txt", "--frequencies", "100"],
    ["flow", "--fmu", "notes.txt", "--frequencies", "100"],
    ["flow", "--plot", "nowhere/x.png", "--frequencies", "100"],
    ["simulate", "--frequency", "100", "--mode", "compensated", "--plot", "out.txt"],
])
def test_the_reported_command_lines_through_their_output(argv, no_work, fake_work):
    # the tracebacks came after the work, where the plot or the FMU is opened
    with sandbox() as (root, before):
        check_command_line(argv, root, before)


@pytest.mark.parametrize("argv", [
    ["flow", "--plot", "out.txt"],
    ["flow", "--fmu", "notes.txt"],
    ["flow", "--plot", "nowhere/x.png"],
    ["position", "--csv", "nowhere/x.csv"],
    ["flow", "--load", "nan"],
    ["flow", "--cycles", "2.5"],
    ["simulate", "--frequency", "0.001", "--mode", "compensated"],
    ["sweep", "spec.toml", "--plot", "out.txt"],
    ["paper", "--plots", "nowhere/deeper"],
])
def test_the_reported_command_lines(argv, no_work):
    # the command lines a new user tried: each was a traceback, a folder made where none was
    # named, or a silent 40-minute run
    with sandbox() as (root, before):
        check_command_line(argv, root, before)
