"""The studies with the time-domain magnetics: waveforms, --magnetics and --waveform, flows.

References: the trapezoid's RMS by numerical quadrature (not the module's closed form);
the valve controller's own phase rule (system_models.controller.pump_phase, Figure 2's
stages) for the compression windows.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import gmt
from smeha.studies import flow, flowcommands, waveforms
from system_models.controller import pump_phase


@pytest.mark.parametrize("name", waveforms.WAVEFORMS)
def test_waveform_rms_by_quadrature(name):
    phase = (np.arange(200000) + 0.5) / 200000  # midpoint rule, exact for the piecewise shapes
    s = waveforms.shape(name, phase)
    assert np.sqrt(np.mean(s * s)) == pytest.approx(waveforms.rms_factor(name), rel=1e-6)
    assert s.max() == pytest.approx(1.0) and s.min() == pytest.approx(-1.0)


@pytest.mark.parametrize("name", waveforms.WAVEFORMS)
def test_compression_window_is_where_the_valve_controller_compresses(name):
    # Figure 2's controller compresses while u rises and keeps its phase while u stands still
    # (system_models.controller.pump_phase): its window must be compression_window's
    n = 4000
    phase = np.arange(2 * n) / n
    u = waveforms.shape(name, phase)
    compressing, state = [], False
    for k in range(1, u.size):
        state = pump_phase(u[k], u[k - 1], state)
        compressing.append(state)
    compressing = np.array(compressing[n:])  # the second period (phase 1 + k/n, k >= 1)
    start, end = waveforms.compression_window(name)
    expected = (((phase[n + 1:] - start) % 1.0) < end - start)
    # the sampled rule switches one sample after the instant (it sees u move)
    assert np.mean(compressing != expected) <= 2.0 / n


def test_cli_choices_agree_with_the_models():
    assert flowcommands.MAGNETICS == gmt.transducer.MAGNETICS
    assert flowcommands.WAVEFORMS == waveforms.WAVEFORMS


def test_the_paper_drive_stays_the_default():
    # the paper's drive unless asked: the default case builds the same
    # control signal (a Sinusoid) and the FMU start values of the paper's magnetics
    case = flow.Case(frequency=100.0, mode="compensated")
    assert (case.magnetics, case.waveform, case.inverse, case.amplitude) == ("paper", "sine",
                                                                             None, None)
    assert isinstance(flow.control_signal("compensated", 100.0)[0], flow.Sinusoid)
    assert set(case.fmu_start_values()) == {"frequency", "current_amplitude", "compensated",
                                            "branch_rule", "compensator_period"}
    td = flow.Case(frequency=100.0, mode="compensated", magnetics="time_domain",
                   inverse="paper")
    assert td.fmu_start_values()["magnetics"] == "time_domain"
    assert td.fmu_start_values()["inverse_model"] == "paper"


@pytest.mark.parametrize("kwargs, name", [({"magnetics": "spice"}, "magnetics"),
                                          ({"waveform": "sawtooth"}, "waveform"),
                                          ({"inverse": "jiles"}, "inverse"),
                                          ({"amplitude": -1.0}, "amplitude")])
def test_bad_case_settings_are_refused(kwargs, name):
    with pytest.raises(gmt.ParameterError, match=name):
        flow.Case(frequency=50.0, mode="uncompensated", **kwargs)


def test_square_control_signal_keeps_the_cosines_timing():
    u, a = flow.control_signal("compensated", 100.0, 1.5, "square")
    assert a == 1.5
    assert u(0.0) == pytest.approx(3.0) and u(0.005) == pytest.approx(0.0)
    assert np.allclose(u(np.array([0.0, 0.005])), [3.0, 0.0])


@pytest.mark.integration
def test_simulate_with_time_domain_magnetics_and_a_square_drive():
    # the command end to end (gmt in-process): the square current at 100 Hz pumps, the JSON
    # says which magnetics and drive ran, and a bad --waveform is a usage error (status 2)
    cmd = [sys.executable, "-m", "smeha.cli", "simulate", "--frequency", "100", "--mode",
           "uncompensated", "--magnetics", "time_domain", "--waveform", "square", "--backend",
           "direct", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    row = json.loads(proc.stdout)
    assert (row["magnetics"], row["waveform"]) == ("time_domain", "square")
    assert row["flow_sim_m3_s"] > 0 and math.isfinite(row["dy_um"])
    bad = subprocess.run(cmd[:-1] + ["--waveform", "sawtooth"], capture_output=True,
                         text=True, timeout=600)
    assert bad.returncode == 2 and "--waveform" in bad.stderr


@pytest.mark.parametrize("mode, shape, basis", [("uncompensated", "trapezoid", "rms"),
                                                ("compensated", "sine", "peak"),
                                                ("compensated", "trapezoid", "rms")])
def test_drive_amplitude_meets_its_current_target(mode, shape, basis):
    # the waveform study compares drives at the paper's coil current: 1 A peak, or its RMS
    # 0.707 A (coil heating); the free transducer's current must meet that (bisection to
    # 2^-24 of the bracket; the current is sampled at 200 points a cycle: 0.5 %)
    from smeha.studies import timedomain

    a = timedomain.drive_amplitude(100.0, mode, shape, basis)
    current, _ = timedomain._free_current(100.0, mode, shape, a)
    got = np.max(np.abs(current)) if basis == "peak" else np.sqrt(np.mean(current ** 2))
    assert got == pytest.approx(1.0 if basis == "peak" else 1 / math.sqrt(2), rel=5e-3)


def test_measured_gain_is_table_3_through_eqs_40_41():
    # paper, Table 3: 50 Hz (46 - 0) / (42 - 1.8), 100 Hz (35.2 - 0) / (31.2 - 4.6)
    from smeha.studies import timedomain

    assert timedomain.measured_gain(50.0) == pytest.approx(46 / 40.2, rel=1e-12)
    assert timedomain.measured_gain(100.0) == pytest.approx(35.2 / 26.6, rel=1e-12)
    assert timedomain.measured_gain(120.0) is None


@pytest.mark.integration
def test_gains_command_time_domain_inverse_strokes_the_demand():
    # smeha timedomain --study gains at 100 Hz: behind its own inverse the time-domain model's
    # free stroke between the valve switches is the demanded 20 a um (a = 1.5 V at 100 Hz,
    # the paper's control signal, Table 3) within 1 %
    cmd = [sys.executable, "-m", "smeha.cli", "timedomain", "--study", "gains",
           "--frequencies", "100", "--workers", "1", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr
    rows = {r["model"]: r for r in json.loads(proc.stdout)["rows"]}
    own = rows["time-domain model, time-domain inverse"]
    assert own["dy_free_compensated_um"] == pytest.approx(30.0, rel=0.01)
    assert own["measured_gain"] == pytest.approx(35.2 / 26.6)


def test_sweep_table_without_the_magnetics_columns_keeps_its_finished_points(tmp_path):
    # a sweep table without the magnetics/inverse/waveform/amplitude columns
    # ran the paper's magnetics and sinusoid: its rows must match today's default points
    import csv

    from smeha.studies import sweep

    point = sweep.Point(flow.Case(frequency=50.0, mode="compensated"))
    old = [c for c in sweep.COLUMNS if c not in sweep.DEFAULTED_SETTINGS]
    path = tmp_path / "old.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(old)
        values = {**point.columns(), "status": "ok", "error": ""}
        w.writerow(["" if values.get(c) is None else values.get(c, "") for c in old])
    (row,) = sweep.read_table(path)
    assert sweep.row_key(row) == point.key


@pytest.mark.integration
@pytest.mark.parametrize("mode", flow.MODES)
def test_both_couplings_agree_with_time_domain_magnetics(mode):
    # the force port (the transducer hands over F, linear over a step; u held at mid-step
    # for the continuous drive) against the displacement port (the FMU integrates the rod
    # with the chamber force iterated): the two cuts agree within 0.11 % with the paper's
    # model (README); with the time-domain magnetics measured 0.18 % (uncompensated) and
    # 0.09 % (compensated) at 100 Hz; a held u(t_k) in the force port was 7.6 % off
    rows = {}
    for coupling, step in (("force", 1e-4), ("displacement", 2e-5)):
        case = flow.Case(frequency=100.0, mode=mode, magnetics="time_domain",
                         coupling=coupling, step=step, backend="direct")
        rows[coupling] = flow.run_case(case)[2]
    assert rows["force"]["flow_sim_m3_s"] == pytest.approx(rows["displacement"]["flow_sim_m3_s"],
                                                           rel=5e-3)


def test_sweep_spec_sets_the_time_domain_settings():
    from smeha.studies import sweep

    (point,) = sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"]},
                                 "settings": {"magnetics": "time_domain", "inverse": "paper",
                                              "waveform": "square", "amplitude": 1.2}})
    case = point.case
    assert (case.magnetics, case.inverse, case.waveform, case.amplitude) == (
        "time_domain", "paper", "square", 1.2)
    with pytest.raises(sweep.SpecError, match="inverse"):
        sweep.parse_spec({"grid": {"frequency": [100], "mode": ["compensated"]},
                          "settings": {"inverse": "jiles"}})
