"""Measured-data format (smeha.measured): round trip, and every bad file named precisely.

Signals here are plain sinusoids: the reader checks structure, units and the
current's frequency, not physics. Line numbers are 1-based and count every line
of the file (line 1 is the header).
"""
import math

import numpy as np
import pytest

from smeha import cli
from smeha.measured import (COLUMNS, DataError, Run, fundamental_frequency,
                            read_measurements, write_measurements)

N = 101  # samples per run: 2 periods at 100 samples a period, end point included


def sinusoid_run(name, f, *, sense=True, control=False, phase=0.4, n=N, cycles=2.0):
    t = 0.5 + np.arange(n) * cycles / (f * (n - 1))
    w = 2 * math.pi * f
    i = 0.8 * np.cos(w * t + phase)
    y = 20e-6 + 15e-6 * np.cos(w * t + phase - 0.3)  # a loop-like displacement, [m]
    e = 0.9 * np.sin(w * t + phase) if sense else None
    u = 1.0 + np.cos(w * t) if control else None
    return Run(name, f, t, i, y, e, u)


@pytest.fixture
def good(tmp_path):
    """A file with runs 'a' (lines 2-102) and 'b' (lines 103-203)."""
    path = tmp_path / "good.csv"
    write_measurements(path, [sinusoid_run("a", 50.0), sinusoid_run("b", 100.0)])
    return path


def edit(path, line, column, value):
    """Set ``column`` of 1-based ``line`` to ``value`` (text), in place."""
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[line - 1].split(",")
    cells[header.index(column)] = value
    lines[line - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def expect_error(path, capsys, *fragments):
    """DataError naming the file and ``fragments``; ``smeha identify`` exits 2, no traceback."""
    with pytest.raises(DataError) as exc:
        read_measurements(path)
    message = str(exc.value)
    assert str(path) in message
    for frag in fragments:
        assert frag in message, (frag, message)
    status = cli.main(["identify", str(path)])
    out, err = capsys.readouterr()
    assert status == 2
    assert err.startswith("smeha identify: error: ") and str(path) in err
    assert "Traceback" not in err and out == ""
    return exc.value


# -- round trip ----------------------------------------------------------------------------

@pytest.mark.parametrize("unit", ["um", "m"])
def test_round_trip_write_read(tmp_path, unit):
    runs = [sinusoid_run("r1", 5.0, control=True), sinusoid_run("r 2", 200.0, sense=False),
            sinusoid_run("r3", 50.0, sense=True)]
    path = write_measurements(tmp_path / "rt.csv", runs, displacement_unit=unit)
    header = path.read_text().splitlines()[0].split(",")
    assert header == ["run", "frequency_Hz", "time_s", "current_A", f"displacement_{unit}",
                      "sense_voltage_V", "control_V"]
    back = read_measurements(path)
    assert [r.name for r in back] == ["r1", "r 2", "r3"]
    for a, b in zip(runs, back):
        assert b.frequency == a.frequency
        np.testing.assert_array_equal(b.time, a.time)  # repr: exact
        np.testing.assert_array_equal(b.current, a.current)
        # um -> m multiplies by 1e-6 on reading: equal to rounding
        np.testing.assert_allclose(b.displacement, a.displacement, rtol=1e-15, atol=0)
        for attr in ("sense_voltage", "control"):
            va, vb = getattr(a, attr), getattr(b, attr)
            assert (va is None) == (vb is None)
            if va is not None:
                np.testing.assert_array_equal(vb, va)
        assert b.lines[0] >= 2 and b.source.startswith(str(path))
        assert abs(b.meta["frequency_estimate_Hz"] / a.frequency - 1) < 1e-6


def test_units_through_one_column_map(tmp_path):
    # COLUMNS is the single conversion: um -> m by 1e-6, SI columns by 1
    assert COLUMNS["displacement_um"] == ("displacement", 1e-6)
    path = tmp_path / "um.csv"
    path.write_text("# provenance: typed in\nrun,frequency_Hz,time_s,current_A,displacement_um\n"
                    + "".join(f"x,10,{k / 100},{math.cos(2 * math.pi * 10 * k / 100)},{k}\n"
                              for k in range(21)))
    (run,) = read_measurements(path)
    assert run.displacement[20] == pytest.approx(20e-6)
    assert list(run.lines[:2]) == [3, 4]  # comment line 1, header line 2


def test_interleaved_rows_group_by_run(tmp_path):
    a, b = sinusoid_run("a", 50.0), sinusoid_run("b", 50.0)
    path = tmp_path / "mixed.csv"
    write_measurements(path, [a, b])
    lines = path.read_text().splitlines()
    body = lines[1:]
    mixed = [lines[0]] + [row for pair in zip(body[:N], body[N:]) for row in pair]
    path.write_text("\n".join(mixed) + "\n")
    ra, rb = read_measurements(path)
    np.testing.assert_array_equal(ra.time, a.time)
    assert list(ra.lines[:3]) == [2, 4, 6] and list(rb.lines[:2]) == [3, 5]


def test_fundamental_frequency_non_uniform_sampling():
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0.0, 0.1, 400))  # 3.7 periods at 37 Hz, jittered
    x = 0.2 + np.cos(2 * math.pi * 37.0 * t) + 0.1 * np.cos(2 * math.pi * 111.0 * t)
    assert fundamental_frequency(t, x) == pytest.approx(37.0, rel=1e-6)
    assert math.isnan(fundamental_frequency(t, np.ones_like(t)))


def test_write_rejects_bad_unit_and_lengths(tmp_path):
    with pytest.raises(ValueError, match="displacement_unit"):
        write_measurements(tmp_path / "x.csv", [sinusoid_run("a", 5.0)], displacement_unit="mm")
    bad = sinusoid_run("a", 5.0)
    bad.current = bad.current[:-1]
    with pytest.raises(ValueError, match="different lengths"):
        write_measurements(tmp_path / "x.csv", [bad])


# -- bad files: each names file, run and line; the CLI exits 2 -------------------------------

def test_missing_column(good, capsys):
    text = good.read_text().replace("current_A", "current_mA", 1)
    good.write_text(text)
    err = expect_error(good, capsys, "line 1", "missing column(s) current_A")
    assert err.line == 1


def test_missing_displacement_column(good, capsys):
    good.write_text(good.read_text().replace("displacement_um", "y_um", 1))
    expect_error(good, capsys, "line 1", "displacement_m or displacement_um")


def test_both_displacement_columns(tmp_path, capsys):
    path = tmp_path / "both.csv"
    path.write_text("run,frequency_Hz,time_s,current_A,displacement_m,displacement_um\n")
    expect_error(path, capsys, "line 1", "both displacement_m and displacement_um")


@pytest.mark.parametrize("value, what", [("abc", "is not a number"),
                                         ("nan", "is not a finite number"),
                                         ("", "is not a number")])
def test_non_numeric_and_nan(good, capsys, value, what):
    edit(good, 57, "current_A", value)
    err = expect_error(good, capsys, "run 'a'", "line 57", "current_A", what)
    assert (err.run, err.line) == ("a", 57)


def test_nan_displacement(good, capsys):
    edit(good, 150, "displacement_um", "NaN")
    expect_error(good, capsys, "run 'b'", "line 150", "displacement_um")


def test_time_not_increasing(good, capsys):
    lines = good.read_text().splitlines()
    t_prev = lines[119 - 2].split(",")[2]
    edit(good, 119, "time_s", t_prev)  # equal to line 118's: not increasing
    err = expect_error(good, capsys, "run 'b'", "line 119", "does not increase", "line 118")
    assert err.line == 119


def test_run_too_short(tmp_path, capsys):
    path = tmp_path / "short.csv"
    write_measurements(path, [sinusoid_run("a", 50.0),
                              sinusoid_run("short", 50.0, cycles=0.8, n=40)])
    expect_error(path, capsys, "run 'short'", "lines 103-142", "0.8 periods",
                 "at least one full period")


def test_frequency_disagrees_with_current(tmp_path, capsys):
    # current at 51.5 Hz, labelled 50 Hz: 3 % off, beyond the 2 % tolerance
    run = sinusoid_run("off", 51.5)
    run.frequency = 50.0
    path = write_measurements(tmp_path / "off.csv", [sinusoid_run("a", 50.0), run])
    err = expect_error(path, capsys, "run 'off'", "lines 103-203", "51.5",
                       "frequency_Hz = 50 Hz", "tolerance 2 %")
    assert err.run == "off"


def test_frequency_within_tolerance_accepted(tmp_path):
    run = sinusoid_run("near", 50.75)  # 1.5 % off: within 2 %
    run.frequency = 50.0
    path = write_measurements(tmp_path / "near.csv", [run])
    (back,) = read_measurements(path)
    assert back.meta["frequency_estimate_Hz"] == pytest.approx(50.75, rel=1e-4)


def test_frequency_changes_within_run(good, capsys):
    edit(good, 40, "frequency_Hz", "60.0")
    expect_error(good, capsys, "run 'a'", "line 40", "frequency_Hz = 60",
                 "constant within a run")


@pytest.mark.parametrize("text", ["", "\n\n", "# only a comment\n"])
def test_empty_file(tmp_path, capsys, text):
    path = tmp_path / "empty.csv"
    path.write_text(text)
    expect_error(path, capsys, "line 1", "empty file")


def test_header_only(tmp_path, capsys):
    path = tmp_path / "header.csv"
    path.write_text("run,frequency_Hz,time_s,current_A,displacement_um\n")
    expect_error(path, capsys, "line 1", "no data rows")


def test_optional_column_partly_empty(good, capsys):
    edit(good, 30, "sense_voltage_V", "")
    expect_error(good, capsys, "run 'a'", "line 30", "sense_voltage_V", "whole run")


def test_wrong_field_count(good, capsys):
    lines = good.read_text().splitlines()
    lines[9] += ",1.0"  # line 10
    good.write_text("\n".join(lines) + "\n")
    expect_error(good, capsys, "run 'a'", "line 10", "7 fields", "header has 6")


def test_empty_run_label(good, capsys):
    edit(good, 12, "run", "")
    expect_error(good, capsys, "line 12", "empty run label")


def test_duplicate_column(tmp_path, capsys):
    path = tmp_path / "dup.csv"
    path.write_text("run,frequency_Hz,time_s,current_A,current_A,displacement_um\n")
    expect_error(path, capsys, "line 1", "'current_A' appears twice")


def test_missing_file_exit_2(tmp_path, capsys):
    status = cli.main(["identify", str(tmp_path / "nope.csv")])
    _, err = capsys.readouterr()
    assert status == 2 and "no such file" in err and "Traceback" not in err
