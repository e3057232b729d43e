"""`smeha sweep`: spec checks (fast), local and Dask sweeps, resume, failed points.

The sweeps are tiny (100 Hz, ideal circuit, 4 cycles, well under a second a point);
they check the machinery, not the physics.
"""
from __future__ import annotations

import csv
import json
import tempfile
from pathlib import Path

import pytest

import gmt
from smeha import cli
from smeha.studies import flow, sweep

TINY = """
[grid]
frequency = {frequency}
mode = {mode}
circuit = ["ideal"]
[settings]
cycles = 4
backend = "{backend}"
"""


def _spec(tmp_path, frequency="[100]", mode='["uncompensated", "compensated"]',
          backend="direct", name="spec.toml"):
    path = tmp_path / name
    path.write_text(TINY.format(frequency=frequency, mode=mode, backend=backend))
    return path


def _sweep(capsys, *argv):
    status = cli.main(["sweep", *map(str, argv), "--json"])
    out = capsys.readouterr().out
    return status, (json.loads(out) if out.strip() else None)


# ----------------------------------------------------------------- spec checks (fast)

@pytest.mark.parametrize("text, names", [
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\nvoltage = [1]\n', "grid.voltage"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\n[settings]\nsteps = 1e-5\n',
     "settings.steps"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\n[extra]\n', "extra"),
    ('[grid]\nfrequency = []\nmode = ["compensated"]\n', "grid.frequency"),
    ('[grid]\nfrequency = [100]\nmode = []\n', "grid.mode"),
    ('[grid]\nfrequency = ["100"]\nmode = ["compensated"]\n', "grid.frequency"),
    ('[grid]\nfrequency = 100\nmode = ["compensated"]\n', "grid.frequency"),
    ('[grid]\nfrequency = [100]\nmode = ["sideways"]\n', "grid.mode"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\nideal = [1]\n', "grid.ideal"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\nload = [true]\n', "grid.load"),
    ('[grid]\nfrequency = [100, 100]\nmode = ["compensated"]\n', "grid.frequency"),
    ('[grid]\nmode = ["compensated"]\n', "grid.frequency"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\n[settings]\nbackend = "fmi"\n',
     "settings.backend"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\n[settings]\nstep = -1\n',
     "settings.step"),
    ('[grid]\nfrequency = [100]\nmode = ["compensated"]\n[settings]\ncycles = 2\n', "cycles"),
    ('[settings]\ncycles = 4\n', "[grid]"),
    ('[grid\n', "not valid TOML"),
])
def test_bad_spec_is_a_usage_error_naming_the_key(tmp_path, capsys, text, names):
    spec = tmp_path / "bad.toml"
    spec.write_text(text)
    assert cli.main(["sweep", str(spec)]) == 2
    err = capsys.readouterr().err
    assert names in err and "Traceback" not in err
    assert not (tmp_path / "bad.csv").exists()


def test_grid_is_the_cartesian_product():
    points = sweep.parse_spec({"grid": {"frequency": [50, 100], "mode": list(sweep.flow.MODES),
                                        "load": [0, 150]},
                               "settings": {"cycles": 6}})
    assert len(points) == 8
    assert {(p.frequency, p.mode, p.load) for p in points} == {
        (f, m, ld) for f in (50.0, 100.0) for m in sweep.flow.MODES for ld in (0.0, 150.0)}
    assert all(p.cycles == 6 and p.backend == "fmu" and p.circuit == "realistic"
               for p in points)


def test_points_are_cases_with_their_defaults():
    """A point is a flow.Case: the settings a spec leaves out are Case's defaults, and
    every setting is part of the point's key, so a table swept with other settings does not
    count as done."""
    from smeha.studies.flow import Case
    plain, timed = (sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"]},
                                      "settings": extra})[0]
                    for extra in ({}, {"controller_period": 2e-5, "hydraulic_step": 2e-5,
                                       "coupling": "displacement"}))
    assert plain.case == Case(100.0, "compensated")
    assert (timed.case.controller_period, timed.case.hydraulic_step, timed.case.coupling) == (
        2e-5, 2e-5, "displacement")
    assert plain.key != timed.key
    row = {**timed.columns(), "status": "ok"}
    assert sweep.row_key(row) == timed.key


def test_table_without_the_optional_columns_still_reads(tmp_path):
    # a table written before those settings existed reads, its points keyed without them
    point = sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"]}})[0]
    table = sweep.write_table([{**point.columns(), "status": "ok", "error": ""}],
                              tmp_path / "t.csv")
    lines = table.read_text().splitlines()
    header = lines[0].split(",")
    drop = [header.index(c) for c in sweep.OPTIONAL_SETTINGS]
    table.write_text("\n".join(",".join(c for i, c in enumerate(line.split(","))
                                        if i not in drop) for line in lines) + "\n")
    rows = sweep.read_table(table)
    assert all(rows[0][c] is None for c in sweep.OPTIONAL_SETTINGS)
    assert sweep.row_key(rows[0]) != point.key  # swept otherwise: not done for this spec


def test_table_with_the_ideal_column_reads_as_named_circuits(tmp_path):
    """Tables from before the circuits were named (an ``ideal`` column) still read."""
    point = sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"],
                                       "circuit": ["ideal"]}})[0]
    table = sweep.write_table([{**point.columns(), "status": "ok", "error": ""}],
                              tmp_path / "t.csv")
    header, row = table.read_text().splitlines()
    table.write_text(header.replace(",circuit,", ",ideal,") + "\n"
                     + row.replace(",ideal,", ",true,") + "\n")
    assert sweep.read_table(table)[0]["circuit"] == "ideal"


@pytest.mark.parametrize("key", ["controller_period", "hydraulic_step", "compensator_period",
                                 "step"])
def test_bad_setting_names_the_key(key):
    with pytest.raises(sweep.SpecError, match=f"settings.{key}"):
        sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"]},
                          "settings": {key: -1e-5}})


def test_missing_spec_file_is_exit_2(tmp_path, capsys):
    # bad input, like any other (tests/test_cli_input.py drives every input file)
    assert cli.main(["sweep", str(tmp_path / "none.toml")]) == 2
    assert "no such file" in capsys.readouterr().err


# ----------------------------------------------------------------- sweeps (integration)

@pytest.mark.integration
def test_local_sweep_writes_table_and_rerun_skips(tmp_path, capsys):
    spec = _spec(tmp_path)
    status, report = _sweep(capsys, spec, "--workers", 2)
    assert status == 0
    assert (report["skipped"], report["failed"], report["ran"]) == (0, 0, 2)
    table = tmp_path / "spec.csv"  # default: the spec's name, beside it
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["mode"], r["status"]) for r in rows] == [("uncompensated", "ok"),
                                                        ("compensated", "ok")]
    for r in rows:
        # ideal circuit: q = f A_d dy holds (eqs 40/41); 5 % allows for the 2 averaged cycles
        assert float(r["flow_ratio"]) == pytest.approx(1.0, abs=0.05)
        assert float(r["flow_sim_m3_s"]) > 0 and float(r["wall_s"]) > 0
    walls = [r["wall_s"] for r in rows]

    status, again = _sweep(capsys, spec, "--workers", 2)
    assert status == 0
    assert (again["skipped"], again["ran"], again["failed"]) == (2, 0, 0)
    with open(table, newline="") as fh:
        assert [r["wall_s"] for r in csv.DictReader(fh)] == walls  # nothing was run again
    assert [r["wall_s"] for r in again["rows"]] == [r["wall_s"] for r in report["rows"]]


@pytest.mark.integration
def test_failed_point_is_recorded_and_rerun(tmp_path, capsys, monkeypatch):
    # the spec is checked against the study's own ranges: 2000 Hz is refused before any run
    spec = _spec(tmp_path, frequency="[100, 2000]", mode='["uncompensated"]')
    assert cli.main(["sweep", str(spec), "--json"]) == 2
    assert "frequency" in capsys.readouterr().err
    # a point that fails at run time (the workers are forked with this run_case)
    real = flow.run_case

    def run_case(case, *args, **kwargs):
        if case.frequency == 90.0:
            raise gmt.ParameterError("frequency = 90 Hz: a point made to fail")
        return real(case, *args, **kwargs)
    monkeypatch.setattr(flow, "run_case", run_case)
    spec = _spec(tmp_path, frequency="[100, 90]", mode='["uncompensated"]')
    out = tmp_path / "table.csv"
    status, report = _sweep(capsys, spec, "--out", out, "--workers", 2)
    assert status == 1  # a failed point is a failure of the run, after the table is written
    assert report["failed"] == 1
    by_f = {r["frequency"]: r for r in report["rows"]}
    assert by_f[100.0]["status"] == "ok" and by_f[100.0]["flow_sim_m3_s"] > 0
    assert by_f[90.0]["status"] == "failed"
    assert "ParameterError" in by_f[90.0]["error"] and "frequency" in by_f[90.0]["error"]
    with open(out, newline="") as fh:
        assert [r["status"] for r in csv.DictReader(fh)] == ["ok", "failed"]
    # rerun: the ok point is skipped, the failed one tried again (and fails again)
    status, again = _sweep(capsys, spec, "--out", out, "--workers", 1)
    assert (status, again["skipped"], again["ran"], again["failed"]) == (1, 1, 1, 1)


@pytest.mark.integration
def test_dask_cluster_runs_the_fmu_shipped_to_workers(tmp_path, capsys):
    distributed = pytest.importorskip("dask.distributed")
    from smeha.studies.flow import ensure_fmu

    fmu = ensure_fmu(quiet=True)
    shipped = Path(tempfile.gettempdir()) / "smeha-fmu"
    before = set(shipped.glob("*.fmu")) if shipped.is_dir() else set()
    for old in before:  # the worker must write its own copy from the shipped bytes
        old.unlink()
    spec = _spec(tmp_path, mode='["compensated"]', backend="fmu")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        status, report = _sweep(capsys, spec, "--scheduler", cluster.scheduler_address,
                                "--fmu", fmu)
    assert status == 0, report
    (row,) = report["rows"]
    assert row["status"] == "ok" and row["backend"] == "fmu"
    assert row["flow_ratio"] == pytest.approx(1.0, abs=0.05)  # ideal circuit, eq 41
    copies = list(shipped.glob(f"*-{fmu.name}"))
    assert len(copies) == 1 and copies[0].read_bytes() == fmu.read_bytes()


def test_interrupted_sweep_keeps_finished_points(tmp_path, monkeypatch):
    # the table is written as points finish: a sweep stopped after its first point (here by a
    # KeyboardInterrupt raised when the second starts) leaves that point in the table, and a
    # rerun skips it. run_point is replaced by a stub, so no co-simulation runs.
    points = sweep.read_spec(_spec(tmp_path))
    out = tmp_path / "interrupted.csv"
    calls = []

    def stub(point, fmu_path=None):
        calls.append(point.key)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return sweep._result_row(point, {"flow_sim_m3_s": 1.0e-6, "wall_s": 0.5}, None)

    monkeypatch.setattr(sweep, "run_point", stub)
    with pytest.raises(KeyboardInterrupt):
        sweep.run_sweep(points, out, workers=1, quiet=True)
    rows = sweep.read_table(out)
    assert len(rows) == 1 and rows[0]["status"] == "ok"
    calls.clear()
    monkeypatch.setattr(sweep, "run_point",
                        lambda p, fmu_path=None: sweep._result_row(p, {"flow_sim_m3_s": 2e-6}, None))
    result = sweep.run_sweep(points, out, workers=1, quiet=True)
    assert result.skipped == 1 and result.ran == len(points) - 1


def test_flags_and_the_lowest_pressure_round_trip_through_the_table(tmp_path):
    """The cavitation flag, the lowest pressure and its volume are table columns: written and
    read back as a flag, a number and a name."""
    point = sweep.parse_spec({"grid": {"frequency": [100], "mode": ["uncompensated"],
                                       "circuit": ["differential"]}})[0]
    row = sweep._result_row(point, {"flow_sim_m3_s": 4.7e-6, "flow_reversed": False,
                                    "cavitation": True, "p_min_Pa": -2.2e6,
                                    "p_min_volume": "big cavity"}, None)
    (back,) = sweep.read_table(sweep.write_table([row], tmp_path / "t.csv"))
    assert back["cavitation"] is True and back["flow_reversed"] is False
    assert back["p_min_Pa"] == -2.2e6 and back["p_min_volume"] == "big cavity"


def test_scheduler_without_dask_names_the_install(tmp_path, monkeypatch, capsys):
    # Dask is an extra (smeha[dask]): without it, --scheduler is refused before any work,
    # in one line that names the install command (it was a SweepError, exit 1, after the
    # spec was read and the FMU found)
    import importlib.util

    from smeha import cli
    from smeha.studies import flow, sweep

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "distributed" else real(name, *a))
    monkeypatch.setattr(flow, "ensure_fmu", lambda **k: pytest.fail("work started"))
    spec = tmp_path / "s.toml"
    spec.write_text('[grid]\nfrequency = [100]\nmode = ["compensated"]\n')
    assert cli.main(["sweep", str(spec), "--scheduler", "tcp://127.0.0.1:8786"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'distributed' is not installed" in err
    assert sweep.DASK_INSTALL in err and "smeha[dask]" in err
