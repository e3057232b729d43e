"""The position study across its envelope: every option one truth, loads the pump cannot
move refused in one line before the work, the PI law one implementation, the speed-load
envelope against the hand calculation.

References: the pump's pressure limit, p_stall = A_d dy / (A_d^2 / K + V_c / beta) (the
blocked force K dy over the piston area with the chamber's oil in series; Merritt,
*Hydraulic Control Systems*, 1967, sec. 2.5), Table 2's K = 1.963e7 N/m and A_d = 1256 mm^2,
the cylinder's areas from its 20 mm bore and 10 mm rod (system_models.cylinder).
"""
import math

import numpy as np
import pytest

import gmt
from smeha import cli
from smeha.studies import position, positionoptions
from smeha.studies.positiondesign import (Controller, PlantModel, design, pi_step,
                                          predict_step)
from smeha.studies.positionlimits import PumpLimits

#: Lines identified at 100 Hz, compensated, realistic circuit, 0 N (smeha position's own
#: identification, rounded): down moves, but full drive up still moves down (+6.44 mm/s).
STALLED_UP = PlantModel(frequency=100.0, v0_down=10.297e-3, g_down=12.871e-3,
                        v0_up=21.099e-3, g_up=14.654e-3, droop_down=-8.6e-5, droop_up=-1.77e-4)
#: 150 N, the same point: both ways move (test_position.MODEL).
MOVING = PlantModel(frequency=100.0, v0_down=-2.79e-3, g_down=13.06e-3, v0_up=-5.94e-3,
                    g_up=14.38e-3, droop_down=-8.6e-5, droop_up=-1.8e-4)


def _no_work(monkeypatch):
    monkeypatch.setattr(position, "identify", lambda *a, **k: pytest.fail("work started"))


@pytest.mark.parametrize("argv, words", [
    (["--load", "1000"], ("stalls moving down", "from about 10 to 261 N")),
    (["--load", "-500"], ("cannot lift", "from about 10 to 261 N")),
    (["--target-mm", "0.005"], ("--target-mm 0.005 mm", "metres")),
    (["--target-mm", "20.5"], ("--target-mm", "[-20, 20] mm")),
])
def test_refused_in_one_line_before_any_run(argv, words, monkeypatch, capsys):
    # --load 1000 ran into cavitation (exit 1), --target-mm 0.005 ran a 5 um step without
    # a word: now exit 2, one line, the limit named, before the identification
    _no_work(monkeypatch)
    assert cli.main(["position", "--mode", "compensated", *argv]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w in err


def test_every_option_is_one_truth(capsys):
    # the range --help shows, the parser checks and the study enforces come from one
    # declaration: --target-mm 20 was [-20, 20] in --help, (-20, 20] in the parser and
    # (-0.02, 0.02) m in the study
    assert position.PositionSettings(target=0.02).target == 0.02
    assert position.PositionSettings(target=-0.02).target == -0.02
    assert cli.main(["position", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for option in positionoptions.OPTIONS.values():
        if option.name == "sine_amplitude":
            continue  # the study's, not an option of the command line
        assert option.interval() in text, option.flag
        low = option.low - 1.0 if not option.low_open else option.low
        with pytest.raises(gmt.ParameterError, match=option.name):
            option.check_si(low * option.si)


#: The 150 N lines moved to 300 N along their droops: full drive down gives -2.6 mm/s.
STALLED_DOWN = PlantModel(frequency=100.0, v0_down=-2.79e-3 - 8.6e-5 * 150, g_down=13.06e-3,
                          v0_up=-5.94e-3 - 1.8e-4 * 150, g_up=14.38e-3, droop_down=-8.6e-5,
                          droop_up=-1.8e-4)


def test_a_load_past_the_down_stall_is_refused_with_it():
    # --load 300 (an IndexError) and --target-mm -5 --load 300 (int(NaN)): the stall load
    # down, 300 N - (-2.63 mm/s) / (-0.086 mm/s per N) = 269 N, is named
    s = position.PositionSettings(load=300.0, target=-5e-3)
    with pytest.raises(position.OutsideEnvelope, match=r"stalls moving down .* about 269 N"):
        position.check_plant(STALLED_DOWN, s)


def test_a_stalled_direction_is_refused_with_its_stall_load():
    # at 0 N the identified lines give +6.44 mm/s at full drive up: a design for them
    # predicts a step that never settles (a run would end on int(NaN)), so the stall load
    # up, 0 N - 6.44 / -0.177 = 36 N, is named instead
    s = position.PositionSettings(load=0.0)
    with pytest.raises(position.OutsideEnvelope, match=r"above about 36 N"):
        position.check_plant(STALLED_UP, s)
    position.check_plant(MOVING, position.PositionSettings())


def test_a_pump_that_runs_backwards_is_refused():
    # uncompensated at 200 Hz more drive "down" moves the piston up (the rod lags the
    # valves by more than a quarter period): refused before a run that would end on an
    # IndexError
    backwards = PlantModel(frequency=200.0, v0_down=1e-3, g_down=-2e-3, v0_up=-1e-3,
                           g_up=-1e-3, droop_down=-1e-5, droop_up=-1e-5)
    with pytest.raises(position.OutsideEnvelope, match="runs backwards"):
        position.check_plant(backwards, position.PositionSettings(frequency=200.0,
                                                                  mode="uncompensated"))


def test_prediction_and_loop_agree_step_by_step_when_saturating():
    # the PI law once (pi_step): python-control's prediction (nlsys) and the controller
    # closed around the same lines (x(k+1) = x(k) + T v) give the same positions to
    # rounding, through the saturated ramp, the overshoot's correction and the band
    # between the lines' offsets (-5.94 to -2.79 mm/s), where a prediction that clips the
    # velocity wanted and a controller that takes the least amplitude down differ
    gains = design(MOVING, -2e-3)  # up: the approach crosses the band (those: 6.5 um apart)
    t, predicted = predict_step(MOVING, gains.kp, gains.ki, gains.period, -2e-3, 120)
    ctrl = Controller(MOVING, gains, 1.0, lambda t: -2e-3)
    x, loop, saturated = 0.0, [0.0], 0
    for k in range(120):
        d = ctrl(k, k * gains.period, x)
        saturated += d.saturated
        x += gains.period * MOVING.velocity(d.direction, d.amplitude)
        loop.append(x)
    assert saturated >= 5
    np.testing.assert_allclose(loop, predicted, rtol=0, atol=1e-12)


def test_pi_step_holds_the_integral_while_saturated():
    d, integral = pi_step(MOVING, 30.0, 150.0, 0.01, 0.0, 1.0)  # 1 m error: saturated
    assert d.saturated and d.amplitude == 1.0 and integral == 0.0
    d, integral = pi_step(MOVING, 30.0, 150.0, 0.01, 0.0, 1e-4)
    assert not d.saturated and integral == pytest.approx(150.0 * 0.01 * 1e-4)


def test_hand_calculation_against_typed_numbers():
    # Table 2: K = 1.963e7 N/m, A_d = 1256 mm^2; a 30 um free stroke; stiff oil (C = A_d^2/K);
    # p_A = 1.5 MPa; 20 mm bore, 10 mm rod
    a_b, a_s = math.pi * 0.02 ** 2 / 4, math.pi * (0.02 ** 2 - 0.01 ** 2) / 4
    lim = PumpLimits(frequency=100.0, mode="compensated", circuit="differential",
                     free_stroke=30e-6, stiffness=1.963e7, piston_area=1256e-6,
                     compliance=1256e-6 ** 2 / 1.963e7, accumulator_pressure=1.5e6,
                     big_area=a_b, small_area=a_s)
    p = 1.963e7 * 30e-6 / 1256e-6  # the blocked force over the piston area: 0.469 MPa
    assert lim.stall_pressure == pytest.approx(p, rel=1e-12)
    assert lim.stall_load_down == pytest.approx(a_b * p + 1.5e6 * (a_b - a_s), rel=1e-12)
    assert lim.stall_load_up == pytest.approx(1.5e6 * (a_b - a_s) - a_s * p, rel=1e-12)
    assert lim.velocity(lim.stall_load_down, "down") == pytest.approx(0.0, abs=1e-12)
    assert lim.velocity(lim.stall_load_up, "up") == pytest.approx(0.0, abs=1e-12)


def test_not_settled_is_said_in_words():
    # --load 0 --duration 1 printed settling "nan" without a word
    from smeha.studies.positionreport import format_report
    step = position.PositionResult("step", "compensated", {
        "rise_time_s": 0.2, "predicted_rise_time_s": 0.2, "overshoot_fraction": 0.05,
        "settling_time_s": math.nan, "settled": False, "predicted_settling_time_s": 0.5,
        "final_error_m": 2e-4, "max_velocity_m_s": 0.01, "wall_s": 1.0, "cpu_s": 1.0,
        "simulated_s": 1.0}, ["not settled within the duration (1 s): 200.0 um from the "
                              "command at the end"])
    gains = design(MOVING)
    out = {"compensated": {"model": MOVING, "design": gains, "results": [step],
                           "flow_velocity_m_s": 0.01}}
    text = format_report(out, position.PositionSettings())
    assert "not settled" in text and "nan" not in text.lower()


def test_each_warning_once_per_mode_and_fitting_it():
    # --bandwidth --load-step printed the design-point warning six times, "compensated"
    # in the uncompensated runs
    from smeha.studies.positionreport import merged_flags
    flag = "design point: the coil current departed at the end of 3 of 10 periods"
    results = [position.PositionResult(s, "uncompensated", {}, [flag])
               for s in ("step", "sine", "load")]
    merged = merged_flags(results)
    assert len(merged) == 1 and "also in the sine, load runs" in merged[0]
    assert "compensated" not in position.DESIGN_POINT_REASON["uncompensated"]


def test_a_long_run_says_so_before_it_starts(monkeypatch, capsys):
    monkeypatch.setattr(position, "run_study", lambda *a, **k: (_ for _ in ()).throw(
        KeyboardInterrupt))
    assert cli.main(["position", "--mode", "compensated", "--frequency", "5",
                     "--backend", "direct"]) == 130
    assert "this run is estimated at" in capsys.readouterr().err


def test_the_plot_shows_the_sine_and_load_step_results(tmp_path, monkeypatch):
    # --bandwidth --load-step drew the step only; now a panel each, and the title names
    # the magnetics, the drive, the circuit and the load
    from smeha.studies import positionplots
    from smeha.studies.positionloop import PERIOD_FIELDS, LoopRecord
    n, per_n = 200, 20
    rows = np.zeros(n, dtype=[(f, float) for f in ("time", "piston_position", "direction",
                                                   "valves_compressing", "p_big",
                                                   "p_small")])
    rows["time"] = np.linspace(0.0, 0.2, n)
    rows["piston_position"] = np.linspace(0.025, 0.026, n)
    rows["direction"], rows["p_big"], rows["p_small"] = 1.0, 1.6e6, 1.5e6
    periods = np.zeros(per_n, dtype=[(f, float) for f in PERIOD_FIELDS])
    periods["time"] = np.linspace(0.0, 0.19, per_n)
    periods["position"] = np.linspace(0.025, 0.026, per_n)
    periods["command"] = np.where(periods["time"] < 0.05, np.nan, 0.030)
    rec = LoopRecord(rows, periods, 1.0, 100.0, 1.0)
    results = [position.PositionResult("step", "compensated", {}, [], rec),
               position.PositionResult("sine", "compensated", {
                   "tracking": [{"frequency_Hz": 2.0, "gain": 1.0, "phase_deg": -20.0},
                                {"frequency_Hz": 8.0, "gain": 0.5, "phase_deg": -80.0}],
                   "predicted_bandwidth_Hz": 6.8}),
               position.PositionResult("load", "compensated", {
                   "load_step_at_s": 0.1, "origin_m": 0.025, "load_step_N": 50.0}, [], rec)]
    seen = {}
    monkeypatch.setattr(positionplots.plt, "close", lambda fig: seen.setdefault("fig", fig))
    positionplots.plot_study(tmp_path / "p.png", {"compensated": {"results": results}},
                             position.PositionSettings())
    titles = [ax.get_title() for ax in seen["fig"].axes]
    assert any("Sine tracking" in t for t in titles) and any("Load step" in t for t in titles)
    assert all(w in titles[0] for w in ("magnetics", "sinusoidal", "realistic", "150 N"))
    assert (tmp_path / "p.png").stat().st_size > 0


@pytest.mark.integration
def test_stall_loads_at_20_hz_meet_the_hand_calculation():
    # at 20 Hz, far below the piston's ringing on the oil (~130-175 Hz), the quasi-static
    # hand calculation holds: at its stall loads the full drive moves the piston less than
    # 2 % of its speed at the other end of the range (co-simulation: 1 N off each way)
    s = position.PositionSettings(frequency=20.0, backend="direct")
    lim = position.check_load(s)
    free = lim.velocity(lim.stall_load_up, "down")
    for direction, load in (("down", lim.stall_load_down), ("up", lim.stall_load_up)):
        v = position.full_drive_velocity(s, direction, load)
        assert abs(v) < 0.02 * free, (direction, v, free)


@pytest.mark.integration
@pytest.mark.parametrize("argv, words", [
    (["--mode", "compensated", "--load", "300"], "stalls moving down"),
    (["--mode", "uncompensated", "--frequency", "200"], "stalls moving down")])
def test_a_stall_the_identification_finds_exits_2_in_one_line(argv, words, capsys):
    # --load 300 and --mode uncompensated --frequency 200 died on an IndexError after the
    # identification: the identified lines now name the stall (in-process transducer)
    assert cli.main(["position", *argv, "--backend", "direct", "--json"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err


def test_envelope_stall_loads_interpolate_the_zero_crossing():
    # v = 10 - 0.05 F (down) and v = 2 - 0.1 F (up) at loads 0..300: zero at 200 N and 20 N
    from smeha.studies.positionenvelope import _stall
    loads = np.linspace(0.0, 300.0, 7)
    assert _stall(loads, list(10.0 - 0.05 * loads), "down") == pytest.approx(200.0)
    assert _stall(loads, list(2.0 - 0.1 * loads), "up") == pytest.approx(20.0)
    assert math.isnan(_stall(loads, list(10.0 + 0 * loads), "down"))  # never stalls


def test_envelope_refuses_the_step_options(monkeypatch, capsys):
    from smeha.studies import positionenvelope
    monkeypatch.setattr(positionenvelope, "run_envelope", lambda *a, **k: pytest.fail("ran"))
    assert cli.main(["position", "--envelope", "--load-step"]) == 2
    assert "--envelope runs no step" in capsys.readouterr().err


def test_flow_table_speed_over_the_filled_cavitys_area(monkeypatch):
    # the ideal circuit's through rod fills an annulus, pi (20^2 - 10^2) / 4 mm^2, not the
    # bore (the speed came out 25 % low there)
    from smeha.studies import flow
    monkeypatch.setattr(flow, "run_case", lambda case, fmu=None: (None, None,
                                                                  {"flow_sim_m3_s": 1e-6}))
    v = position.flow_table_velocity(position.PositionSettings(circuit="ideal"))
    assert v == pytest.approx(1e-6 / (math.pi * (0.02 ** 2 - 0.01 ** 2) / 4), rel=1e-12)


def test_the_study_owns_its_defaults():
    # the study imported its defaults from its command line, which imported the study (a
    # circle); now the command line reads the study's declarations, never the reverse
    import subprocess
    import sys
    code = ("import sys, smeha.studies.position, smeha.studies.positionenvelope; "
            "print('smeha.studies.positioncommands' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_a_long_envelope_says_so_before_it_starts(monkeypatch, capsys):
    from smeha.studies import positionenvelope
    monkeypatch.setattr(positionenvelope, "run_envelope", lambda *a, **k: (_ for _ in ()).throw(
        KeyboardInterrupt))
    assert cli.main(["position", "--envelope", "--frequency", "20", "--backend", "direct"]) == 130
    assert "this envelope is estimated at" in capsys.readouterr().err
