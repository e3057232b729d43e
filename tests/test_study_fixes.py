"""What a new user met in the studies, each fixed and pinned here.

References: the flow check of eqs 39-41 (system_models.flowcheck) for the averaged
cycles; Figure 2's valve timing and a quarter period for a rod lagging past the valves'
switching (smeha.studies.flow.flag_row); the shell's convention of 128 + the signal's
number for a run stopped by SIGINT (130); the flow study's own runs otherwise.
"""
import math

import pytest

from smeha import cli
from smeha.studies import flow, flowcommands, sweep
from system_models import flowcheck


def _row(**over):
    row = {"frequency_Hz": 50.0, "mode": "uncompensated", "flow_sim_m3_s": -2.6e-7,
           "dy_um": -2.9, "load_pressure_Pa": 0.58e6, "p_min_Pa": 1e6}
    row.update(over)
    return row


def test_a_reversed_flow_within_a_quarter_period_blames_the_load():
    # 50 Hz, 300 N: the rod lags 73 deg and the valves act 4 deg late, 77 deg
    # in all: not past a quarter period (90 deg). The load is past the stall point.
    note = flow.flag_row(_row(), rod_lag_deg=73.0, dead_time=2e-4)["note"]
    assert "stall point" in note and "past a quarter period" not in note
    assert "73 deg" in note and "within a quarter period" in note


def test_a_reversed_flow_past_a_quarter_period_blames_the_lag():
    note = flow.flag_row(_row(frequency_Hz=150.0), rod_lag_deg=95.0, dead_time=2e-4)["note"]
    assert "past a quarter period" in note and "stall" not in note


def _summary(rows):
    return sweep.format_summary(sweep.SweepResult(rows=rows, ran=len(rows)), "t.csv")


def _sweep_row(status="ok", **over):
    base = {"frequency": 50.0, "mode": "uncompensated", "load": 300.0, "circuit": "realistic",
            "status": status, "error": "", "flow_sim_m3_s": 1e-6, "flow_ratio": 1.0,
            "dy_um": 10.0, "wall_s": 0.043, "flow_reversed": False, "cavitation": False}
    base.update(over)
    return base


def test_sweep_marks_a_reversed_flow_in_its_status_and_table():
    point = sweep.parse_spec({"grid": {"frequency": [50], "mode": ["uncompensated"]}})[0]
    flagged = sweep._result_row(point, {"flow_reversed": True, "cavitation": False}, None)
    assert flagged["status"] == "flagged"
    assert sweep._result_row(point, {"flow_reversed": False}, None)["status"] == "ok"
    assert "flagged" in sweep.FINISHED  # kept on a rerun like "ok"
    text = _summary([_sweep_row("flagged", flow_reversed=True, flow_sim_m3_s=-2.6e-7)])
    assert "(!) flow reversed" in text and "flagged" in text


def test_sweep_wall_column_shows_a_short_run():
    # a 0.043 s point printed "0.0" with one decimal
    assert "0.043" in _summary([_sweep_row()])


def test_the_flow_check_says_when_the_run_has_not_settled():
    # the realistic circuit follows the piston: its flow still falls ~0.02-0.03 % a cycle at
    # 100 Hz compensated, which the table's three-decimal ratios do not show (settled at the
    # printed precision, flow.SETTLED_DRIFT); the ideal circuit's does not change (eq 41
    # holds cycle by cycle). A trend the printed figures would show is said.
    from smeha.studies.flowtables import format_table
    realistic = flow.run_case(flow.Case(100.0, "compensated", backend="direct"))[2]
    ideal = flow.run_case(flow.Case(100.0, "compensated", circuit="ideal",
                                    backend="direct"))[2]
    assert -flow.SETTLED_DRIFT < realistic["flow_drift_per_cycle"] < -1e-4
    assert realistic["settled"]
    assert ideal["settled"] and abs(ideal["flow_drift_per_cycle"]) < 1e-6
    assert "not settled" not in format_table([realistic, ideal])
    drifting = dict(realistic.as_dict(), flow_drift_per_cycle=-3.75e-3, settled=False)
    assert "not settled (100 Hz compensated)" in format_table([drifting, ideal])


def test_drift_is_the_relative_slope_per_cycle():
    flows = [1.0, 0.99, 0.98, 0.97]
    assert flowcheck.drift(flows) == pytest.approx(-0.01 / 0.985)
    assert flowcheck.drift([1.0, 2.0]) == 0.0  # two cycles tell no trend


def test_cycles_help_gives_what_the_flow_check_averages():
    # 8 cycles: compression strokes start at 0.5 T ... 7.5 T; the first 2 skipped, the
    # whole cycles between the remaining 6 are 5 -- what a run reports
    assert flowcommands._averaged(8.0) == 5
    row = flow.run_case(flow.Case(100.0, "compensated", circuit="ideal", backend="direct"))[2]
    assert row["cycles_averaged"] == 5
    helptext = " ".join(cli.build_parser()._subparsers._group_actions[0].choices["simulate"]
                        .format_help().split())
    assert "(5 at the default 8)" in helptext and "averages the rest" not in helptext


def test_a_coarse_step_does_not_warn_where_the_compensator_sets_it(monkeypatch, capsys):
    # compensated, the master cuts every step at the compensator's 100 us samples: --step
    # 0.01 runs as 100 us, so no warning; uncompensated it does run at 10 ms
    monkeypatch.setattr(flow, "run_case", lambda *a, **k: (_ for _ in ()).throw(
        KeyboardInterrupt))
    monkeypatch.setattr(flow, "ensure_fmu", lambda **k: None)
    for mode, warned in (("compensated", False), ("uncompensated", True)):
        cli.main(["simulate", "--frequency", "100", "--mode", mode, "--step", "0.01",
                  "--backend", "direct"])
        assert ("warning" in capsys.readouterr().err) is warned, mode


def test_ctrl_c_is_one_line_and_exit_130(monkeypatch, capsys):
    monkeypatch.setattr(flow, "run_case", lambda *a, **k: (_ for _ in ()).throw(
        KeyboardInterrupt))
    assert cli.main(["simulate", "--frequency", "100", "--mode", "compensated",
                     "--backend", "direct", "--json"]) == 130  # --json: no progress bar
    err = capsys.readouterr().err
    assert err.strip() == "smeha simulate: interrupted"


def test_duration_limit_is_refused_at_parse_and_in_help(monkeypatch, capsys):
    monkeypatch.setattr(flow, "run_case", lambda *a, **k: pytest.fail("work started"))
    assert cli.main(["simulate", "--frequency", "100", "--mode", "compensated",
                     "--duration", "100000"]) == 2
    assert "--duration" in capsys.readouterr().err
    helptext = cli.build_parser()._subparsers._group_actions[0].choices["simulate"].format_help()
    assert "in (0, 10000] s" in " ".join(helptext.split())  # flowsettings.DURATION


def test_simulate_plot_keeps_the_legend_off_the_averaged_cycles(tmp_path):
    # the legend sits in head-room above the rod's averaged cycles; the rod starts at rest
    # under the chamber's pressure (system_models.plant.initial_state), so the 111 um
    # spike at t = 0 (the free rod springing back from A_d p_P / K) is gone and the start
    # is on scale
    import matplotlib
    matplotlib.use("Agg")
    from smeha.studies.flowplots import run_figure
    record, _, row = flow.run_case(flow.Case(100.0, "compensated", backend="direct"))
    fig = run_figure(record, row)
    ax = fig.axes[0]
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent().transformed(ax.transData.inverted())
    steady = record["time"] >= 2 / 100.0
    y = record["rod_displacement"] * 1e6
    assert legend.y0 > (y[steady] - y[steady].min()).max()
    assert "off scale" not in ax.get_title(loc="left")
    ys = y - y[steady].min()
    assert ys.max() <= ax.get_ylim()[1] and ys.min() >= ax.get_ylim()[0]
    assert math.isfinite(legend.y0)


# -- the error family (item 5) ----------------------------------------------------------
def test_input_and_run_errors_and_a_bug(monkeypatch, capsys):
    # bad input: exit 2, one line; a run that stopped: exit 1, one line; anything else is a
    # bug: its traceback, not "bad input"
    from smeha.errors import InputError, RunError
    from smeha.cliargs import UsageError
    from smeha.measured import DataError
    from smeha.studies.sweep import SpecError, SweepError
    from system_models.displacementport import CouplingError
    from system_models.implicit import IntegrationError
    import gmt
    for cls in (UsageError, DataError, SpecError, gmt.ParameterError):
        assert issubclass(cls, InputError)
    for cls in (SweepError, CouplingError, IntegrationError):
        assert issubclass(cls, RunError)
    argv = ["simulate", "--frequency", "100", "--mode", "compensated", "--backend", "direct",
            "--json"]
    for exc, status in ((gmt.ParameterError("load = x"), 2), (RunError("it stopped"), 1)):
        monkeypatch.setattr(flow, "run_case", lambda *a, exc=exc, **k: (_ for _ in ()).throw(exc))
        assert cli.main(argv) == status
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    monkeypatch.setattr(flow, "run_case", lambda *a, **k: (_ for _ in ()).throw(
        ValueError("a bug inside the study")))
    with pytest.raises(ValueError, match="a bug"):
        cli.main(argv)


def test_run_plot_marks_a_reversed_flow():
    import matplotlib
    matplotlib.use("Agg")
    from smeha.studies.flowplots import run_figure
    record, _, row = flow.run_case(flow.Case(50.0, "uncompensated", load=300.0,
                                             backend="direct"))
    title = run_figure(record, row)._suptitle.get_text()
    assert "(!) flow reversed: the load past its stall point" in title


def test_one_settings_object_checks_the_case():
    # Case accepted step = 1.0, which CosimSettings refuses; the case's co-simulation
    # settings are now checked by CosimSettings alone, with its message
    import gmt
    from system_models.cosim import CosimSettings
    with pytest.raises(gmt.ParameterError) as case_error:
        flow.Case(100.0, "compensated", step=1.0)
    with pytest.raises(gmt.ParameterError) as settings_error:
        CosimSettings(step=1.0)
    assert str(case_error.value) == str(settings_error.value)
    case = flow.Case(50.0, "compensated", cycles=8, load=20.0)
    s = case.cosim_settings()
    assert (s.duration, s.load_force, s.step) == (8 / 50.0, 20.0, case.step)


def test_public_modules_declare_all():
    # every public module of the studies, the command line's helpers, the measurement
    # files, the identification, the diagnosis, the generator and the FMU tooling names
    # what it exports, and each name exists
    import importlib
    import pkgutil
    from pathlib import Path

    import smeha
    root = Path(smeha.__file__).parent
    names = [f"smeha.{m.name}" for m in pkgutil.iter_modules([str(root)])
             if not m.ispkg and not m.name.startswith("_")]
    for package in ("studies", "identify", "diagnose", "synthetic", "fmu"):
        names += [f"smeha.{package}.{m.name}"
                  for m in pkgutil.iter_modules([str(root / package)])
                  if not m.name.startswith("_")]
    for name in names:
        module = importlib.import_module(name)
        assert hasattr(module, "__all__"), name
        missing = [n for n in module.__all__ if not hasattr(module, n)]
        assert not missing, (name, missing)


def test_the_flow_study_returns_a_typed_row():
    # a frozen dataclass with as_dict() (JSON), that still reads as the mapping it was
    import dataclasses
    import json
    from smeha.studies.flowrow import FlowRow
    row = flow.run_case(flow.Case(100.0, "compensated", circuit="ideal", backend="direct"))[2]
    assert isinstance(row, FlowRow)
    with pytest.raises(dataclasses.FrozenInstanceError):
        row.dy_um = 0.0
    d = row.as_dict()
    assert json.loads(json.dumps(d)) == d and "note" not in d and "variant_marks" not in d
    assert row["dy_um"] == row.dy_um and row.get("note") is None and "note" not in row
    assert dict(row) == d
    with pytest.raises(KeyError):
        row["no_such_figure"]


def test_simulate_writes_a_measurement_file_identify_reads(tmp_path, capsys):
    # simulate --csv claimed the measurement files' columns but identify could not read it;
    # --measurement writes that format, one run a simulation (replaced by name, others
    # kept). Round trip: identify fits eq 30 to the co-simulated transducer (its own rod,
    # free of the chamber's force, 0.05 um of sensor noise) and recovers the model's own
    # mu'' at (f, 1 A) within 0.2 % (tests/test_roundtrip.py: the diagnosis)
    import gmt
    from smeha import measured
    from smeha.identify import identify_run
    path = tmp_path / "sim.csv"
    for f in (50, 100, 50):
        assert cli.main(["simulate", "--frequency", str(f), "--mode", "uncompensated",
                         "--ideal", "--backend", "direct", "--json", "--measurement",
                         str(path)]) == 0
    capsys.readouterr()
    runs = measured.read_measurements(path)
    assert [r.name for r in runs] == ["uncompensated_100Hz", "uncompensated_50Hz"]
    params = gmt.TransducerParameters()
    for run in runs:
        mu_imag = gmt.operating_point(params, gmt.Excitation(run.frequency, 1.0)).mu_imag
        assert identify_run(run, params).mu_imag == pytest.approx(mu_imag, rel=2e-3)


def test_simulate_and_position_take_a_variant_file(monkeypatch, capsys):
    # the variant file reaches the case (simulate) and the settings (position)
    from pathlib import Path
    from smeha.studies import position
    path = str(Path(__file__).resolve().parents[1] / "data" / "paper_variant.json")
    seen = []
    monkeypatch.setattr(flow, "run_case", lambda case, *a, **k: (seen.append(case.variant),
                                                                 (_ for _ in ()).throw(
                                                                     KeyboardInterrupt))[1])
    assert cli.main(["simulate", "--frequency", "100", "--mode", "uncompensated",
                     "--backend", "direct", "--json", "--variant", path]) == 130
    assert seen[0].name.startswith("mechanical_resonance")
    monkeypatch.setattr(flow, "ensure_fmu", lambda **k: None)
    monkeypatch.setattr(position, "run_study", lambda settings, *a, **k: (
        seen.append(settings.variant), (_ for _ in ()).throw(KeyboardInterrupt))[1])
    assert cli.main(["position", "--mode", "compensated", "--json", "--variant", path]) == 130
    assert seen[1] == seen[0]
    capsys.readouterr()
