"""The closed-loop position study (smeha position).

References: the discrete integrator under proportional-integral control (Franklin, Powell &
Workman, *Digital Control of Dynamic Systems*, 3rd ed. 1998, ch. 7: the sampled loop
x(k+1) = x(k) + T v(k), its pole at 1 - K_p T, its gain margin where the phase crosses
-180 deg at the Nyquist frequency), a first-order step's closed forms (rise time tau ln 9,
2 % settling tau ln 50), and the flow study (``smeha flow``): a long step runs at the flow
table's flow over the big cavity's area.
"""
import json
import math

import numpy as np
import pytest

import gmt
from smeha import cli
from smeha.studies import position
from smeha.studies.position import PlantModel, PositionSettings, design, step_metrics

#: Lines of the realistic circuit at 100 Hz, compensated, 150 N (identified, rounded).
MODEL = PlantModel(frequency=100.0, v0_down=-2.79e-3, g_down=13.06e-3, v0_up=-5.94e-3,
                   g_up=14.38e-3, droop_down=-8.6e-5, droop_up=-1.8e-4)


def test_step_metrics_of_a_first_order_step():
    tau = 0.05
    t = np.linspace(0.0, 1.0, 200001)
    x = 2e-3 * (1.0 - np.exp(-t / tau))
    m = step_metrics(t, x, 2e-3)
    assert m["rise_time_s"] == pytest.approx(tau * math.log(9.0), rel=1e-3)
    assert m["settling_time_s"] == pytest.approx(tau * math.log(50.0), rel=1e-3)
    assert m["overshoot_fraction"] == 0.0
    assert m["final_error_m"] == pytest.approx(2e-3 * math.exp(-1.0 / tau), abs=1e-12)


def test_design_margins_against_the_sampled_loop_closed_form():
    d = design(MODEL)
    T = d.period
    assert d.kp * T == pytest.approx(position.LOOP_GAIN)
    # L(z) = (K_p + K_i T z/(z-1)) T/(z-1) at z = -1: |L| = T (K_p + K_i T / 2) / 2
    assert d.gain_margin == pytest.approx(2.0 / (T * (d.kp + d.ki * T / 2.0)), rel=1e-9)
    # the proportional loop alone: closed-loop pole 1 - K_p T = 0.7; its -3 dB frequency
    # from |e^{jwT} - 0.7| = 0.3 sqrt(2); the slow integral adds a little
    p = 1.0 - position.LOOP_GAIN
    c = (1.0 + p * p - 2.0 * (1.0 - p) ** 2) / (2.0 * p)
    f3 = math.acos(c) / (2.0 * math.pi * T)
    assert d.bandwidth_Hz == pytest.approx(f3, rel=0.25)
    assert 60.0 < d.phase_margin_deg < 90.0


def test_predicted_rise_is_the_velocity_limited_ramp():
    # K_p e falls below v_max only within v_max / K_p = 0.34 mm of the command, inside the
    # last 10 % of a 5 mm step: 10-90 % is a ramp at v_max, 0.8 x 5 mm / 10.27 mm/s, to
    # a sample period
    d = design(MODEL, 5e-3)
    assert d.predicted_rise_time_s == pytest.approx(0.8 * 5e-3 / MODEL.v_max_down, abs=d.period)
    up = design(MODEL, -5e-3)
    assert up.predicted_rise_time_s == pytest.approx(0.8 * 5e-3 / -MODEL.v_max_up, abs=d.period)


def test_plant_model_inverts_its_lines():
    for v in (-2e-3, 0.0, 5e-3, 10e-3):
        direction, a, sat = MODEL.command(v)
        assert direction == "down" and not sat
        assert MODEL.v0_down + MODEL.g_down * a == pytest.approx(v)
    direction, a, sat = MODEL.command(-12e-3)
    assert direction == "up" and MODEL.v0_up - MODEL.g_up * a == pytest.approx(-12e-3)
    assert MODEL.command(1.0) == ("down", 1.0, True)
    assert MODEL.command(-1.0) == ("up", 1.0, True)


@pytest.mark.parametrize("kwargs, name", [({"mode": "both"}, "mode"),
                                          ({"target": 0.0}, "target"),
                                          ({"target": 0.05}, "target"),
                                          ({"frequency": 0.0}, "frequency"),
                                          ({"duration": 100.0}, "duration"),
                                          ({"circuit": "x"}, "circuit")])
def test_settings_are_checked(kwargs, name):
    with pytest.raises(gmt.ParameterError, match=name):
        PositionSettings(**kwargs)


@pytest.mark.parametrize("argv, words", [
    (["position", "--target-mm", "0"], "needs a distance"),
    (["position", "--target-mm", "30"], "--target-mm"),
    (["position", "--duration", "100"], "--duration"),
    (["position", "--bandwidth", "1,,2"], "")])
def test_cli_refuses_bad_input_before_work(argv, words, capsys, monkeypatch):
    monkeypatch.setattr(position, "identify", lambda *a, **k: pytest.fail("work started"))
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and words in err


@pytest.mark.integration
def test_the_loop_continued_period_by_period_is_one_run():
    # a constant decision over 12 periods, run period by period, against the flow study's
    # single co-simulation of the same drive (u = a - a cos, direction down): the piston
    # ends within 0.5 % of the same travel (the valves, the plant and the transducer are
    # continued, not restarted)
    from system_models import presets
    from system_models.cosim import CosimSettings, DirectTransducer, cosimulate
    from smeha.studies.positionloop import Decision, period_signal, run_loop
    f, a, periods = 100.0, 1.5, 12
    circuit = presets.circuit("realistic")

    def unit():
        return DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(f, 1.0),
                                gmt.DriveParameters(compensated=True))
    loop = run_loop(unit(), "compensated", circuit, f, periods,
                    lambda k, t, x: Decision("down", a), load=lambda t: 150.0)
    whole = cosimulate(unit(), period_signal("compensated", a, f), circuit,
                       CosimSettings(duration=periods / f, load_force=150.0))
    travel_loop = loop.rows["piston_position"][-1] - loop.rows["piston_position"][0]
    travel = whole["piston_position"][-1] - whole["piston_position"][0]
    assert travel_loop == pytest.approx(travel, rel=5e-3)
    per = loop.periods["position"]
    at = np.searchsorted(whole["time"], loop.periods["time"] - 1e-12)
    np.testing.assert_allclose(per, whole["piston_position"][at], atol=2e-6)


@pytest.mark.integration
def test_compensated_step_through_the_fmu_meets_its_targets(capsys):
    # 100 Hz, realistic circuit, 150 N, 5 mm compensated: final error within 1 %, overshoot
    # within 10 %, rise within 25 % of python-control's, top speed within 15 % of the flow table's
    assert cli.main(["position", "--mode", "compensated", "--target-mm", "5", "--json"]) == 0
    c = json.loads(capsys.readouterr().out)
    assert c["final_error_m"] <= 0.01 * 5e-3
    assert c["overshoot_fraction"] <= 0.10
    assert c["rise_time_s"] == pytest.approx(c["predicted_rise_time_s"], rel=0.25)
    assert c["max_velocity_m_s"] == pytest.approx(c["flow_velocity_m_s"], rel=0.15)
    assert c["simulated_s"] > 0.0 and c["wall_s"] > 0.0  # the real-time factor: a benchmark
    assert cli.main(["position", "--mode", "uncompensated", "--target-mm", "5", "--json"]) == 0
    u = json.loads(capsys.readouterr().out)
    assert u["rise_time_s"] > c["rise_time_s"]  # compensation's flow gain: a faster step
    assert u["max_velocity_m_s"] == pytest.approx(u["flow_velocity_m_s"], rel=0.15)


def test_a_slower_controller_holds_longer_in_the_design():
    # sampled every N = 4 pump periods: the sample-and-hold is 4 T, the gains scale with it,
    # so the loop in z is the one of N = 1 and every frequency of the design scales by 1/4
    # (Franklin, Powell & Workman, ch. 7: a sampled loop's response is a function of w T)
    one, four = design(MODEL), design(MODEL, periods=4)
    assert four.period == pytest.approx(4 * one.period)
    assert four.kp * four.period == pytest.approx(one.kp * one.period)
    assert four.phase_margin_deg == pytest.approx(one.phase_margin_deg, rel=1e-6)
    assert four.gain_margin == pytest.approx(one.gain_margin, rel=1e-6)
    for name in ("bandwidth_Hz", "crossover_Hz"):
        assert getattr(four, name) == pytest.approx(getattr(one, name) / 4, rel=1e-3)
    assert four.rise_time_linear_s == pytest.approx(4 * one.rise_time_linear_s, rel=1e-6)


@pytest.mark.parametrize("rate, words", [(30.0, "does not divide"), (200.0, "controller_rate")])
def test_the_controller_rate_divides_the_pump_frequency(rate, words):
    with pytest.raises(gmt.ParameterError, match=words):
        PositionSettings(controller_rate=rate)
    assert PositionSettings(controller_rate=25.0).controller_periods == 4
    assert PositionSettings().controller_periods == 1


def test_the_controller_decides_every_nth_period():
    gains = design(MODEL, periods=4)
    ctrl = position.Controller(MODEL, gains, 10.0, lambda t: 5e-3, settle=2)
    seen = [ctrl(k, k * 0.01, 0.0) for k in range(12)]
    assert all(d.amplitude == 0.0 for d in seen[:2])  # settling
    # after settling, one decision every 4 periods, held in between (the error changes
    # nothing in between: x stays 0 here, yet the integral would grow each call)
    assert seen[2] is seen[3] is seen[4] is seen[5]
    assert seen[6] is not seen[5] and seen[6] is seen[9]


@pytest.mark.integration
def test_a_controller_at_a_quarter_of_the_pump_rate_meets_the_targets(capsys):
    # --controller-rate 25 at 100 Hz (in-process transducer, compensated): the step still
    # meets the same targets, against python-control's prediction at the longer hold
    assert cli.main(["position", "--mode", "compensated", "--target-mm", "5",
                     "--controller-rate", "25", "--backend", "direct", "--json"]) == 0
    c = json.loads(capsys.readouterr().out)
    assert c["design"]["period"] == pytest.approx(0.04)
    assert c["final_error_m"] <= 0.01 * 5e-3
    assert c["overshoot_fraction"] <= 0.10
    assert c["rise_time_s"] == pytest.approx(c["predicted_rise_time_s"], rel=0.25)
