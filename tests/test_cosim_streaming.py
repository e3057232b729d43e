"""Flat-memory co-simulation, the master's timing, and its options on the command line.

References: a streamed run equals a recorded one (the same arithmetic); the valves of
Figure 2 switch at the extremes of u, the controller's samples after them, and act their
dead time later; the ideal circuit's flow is f A_d dy with the free transducer's dy (eq 40),
dy taken here from gmt's closed-form periodic response (eq 30 harmonic by harmonic), which
shares no numerics with the co-simulation.
"""
import json

import numpy as np
import pytest

import gmt
from smeha import cli
from smeha.studies import flow
from system_models import presets
from system_models.cosim import CosimSettings, DirectTransducer, cosimulate
from system_models.flowcheck import RunningFlow, flow_check, switching_instants

#: Paper, Table 2: A_d = 1256 mm^2.
PISTON_AREA = 1256e-6


def _run(keep, observer=None, step=1e-4, window=64, mode="uncompensated"):
    f = 100.0
    control, _ = flow.control_signal(mode, f)
    backend = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(f, 1.0),
                               gmt.DriveParameters(compensated=mode == "compensated"))
    settings = CosimSettings(duration=5 / f, step=step, load_force=presets.REALISTIC_LOAD,
                             window=window)
    return cosimulate(backend, control, presets.realistic_circuit(), settings,
                      observer=observer, keep_record=keep)


@pytest.mark.integration
def test_streamed_run_gives_the_recorded_flow_and_final_state():
    full = _run(True)
    running = RunningFlow()
    last = _run(False, running)
    assert len(last) == 1
    # the same arithmetic in the same order: identical, not merely close
    assert last[0].tolist() == full[-1].tolist()
    assert running.flow == flow_check(full, 100.0, PISTON_AREA).flow_sim


@pytest.mark.integration
def test_the_plant_window_changes_nothing_but_the_newton_matrix():
    """One compiled call per step or per 64 steps: the same steps, the Newton matrix kept
    longer; the flows agree to the Newton tolerance (1e-10 relative; measured ~1e-12)."""
    for mode in flow.MODES:
        one, many = _run(True, window=1, mode=mode), _run(True, window=64, mode=mode)
        assert len(one) == len(many)
        q = [flow_check(r, 100.0, PISTON_AREA).flow_sim for r in (one, many)]
        assert q[0] == pytest.approx(q[1], rel=1e-8)


@pytest.mark.integration
def test_communication_points_fall_on_valve_actions_and_compensator_samples():
    """Valves act 0.2 ms after u's extremes (5, 10 ... ms); the compensator samples every
    100 us: both are record times whatever the step (here 130 us, dividing neither)."""
    for mode in flow.MODES:
        t = _run(True, step=130e-6, mode=mode)["time"]
        for instant in (5.2e-3, 10.2e-3, 15.2e-3):
            assert np.min(np.abs(t - instant)) < 1e-9
        if mode == "compensated":
            samples = np.arange(1, 500) * 1e-4
            assert np.all(np.min(np.abs(t[:, None] - samples[None, :]), axis=0) < 1e-9)


def test_running_flow_needs_whole_cycles():
    with pytest.raises(ValueError, match="too short"):
        RunningFlow().flow


@pytest.mark.integration
def test_cli_simulate_takes_the_timing_options(capsys):
    """--step, --controller-period and --hydraulic-step reach the co-simulation.

    Ideal circuit, 100 Hz, uncompensated, 200 us steps (the force linear over each), valve
    controller at 0.5 ms: the valves switch on its samples -- u's extremes fall on them
    at 100 Hz -- and the flow is eq 40's f A_d dy of the free transducer within 1 % (dy
    from the closed form; measured 0.3 % low).
    """
    assert cli.main(["simulate", "--frequency", "100", "--mode", "uncompensated", "--ideal",
                     "--cycles", "6", "--step", "2e-4", "--controller-period", "5e-4",
                     "--hydraulic-step", "2.5e-5", "--backend", "direct", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)
    assert row["step_s"] == 2e-4
    p = gmt.TransducerParameters()
    point = gmt.operating_point(p, gmt.Excitation(100.0, 1.0))
    y = gmt.periodic_response(p, point, np.array([0.0, 0.005]))["displacement"]
    assert row["flow_sim_m3_s"] == pytest.approx(100.0 * PISTON_AREA * (y[0] - y[1]), rel=0.01)


@pytest.mark.integration
def test_valve_controller_period_sets_the_switching_instants():
    """A 0.7 ms controller period: the valves switch on its samples (multiples of 0.7 ms),
    at the sample whose look-ahead u(t_j + T) - u(t_j) changes sign: the extreme of u
    (5, 10 ... ms) lies then within half a period of it (the secant's midpoint passes it)."""
    f = 100.0
    control, _ = flow.control_signal("uncompensated", f)
    backend = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(f, 1.0))
    circuit = presets.ideal_circuit()
    rec = cosimulate(backend, control, circuit,
                     CosimSettings(duration=4 / f, controller_period=7e-4))
    starts, ends = switching_instants(rec)
    times = rec["time"][np.concatenate((starts, ends))]
    assert times.size >= 6
    periods = times / 7e-4
    np.testing.assert_allclose(periods, np.round(periods), atol=1e-6)
    extremes = np.arange(1, 9) * 5e-3
    for t in times:
        assert abs(t - extremes[np.argmin(np.abs(t - extremes))]) <= 3.5e-4 + 1e-9

