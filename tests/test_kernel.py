"""The compiled hydraulic kernel against the readable reference, and the sampled valve controller.

References: the kernel claims to compute the same right-hand side as
:func:`system_models.circuit.rhs` (so: equal to round-off) and the same TR-BDF2
step as :func:`system_models.implicit.tr_bdf2` (so: equal to Newton's
tolerance, NEWTON_ATOL = 1e-3 Pa plus NEWTON_RTOL = 1e-10 relative).
"""
import math

import numpy as np
import pytest

from system_models import circuit, kernel, presets
from system_models.controller import TIME_TOLERANCE, SampledValveController
from system_models.cosim import _integrate_step

CIRCUITS = {"realistic": presets.realistic_circuit(), "ideal": presets.ideal_circuit(),
            "first_order_valves": circuit.CircuitParameters()}


def _states(params, n, seed):
    rng = np.random.default_rng(seed)
    base = circuit.initial_state(params)
    for _ in range(n):
        x = base.copy()
        x[:3] += rng.normal(0.0, 3e5, 3)
        x[3] = abs(rng.normal(1e-5, 5e-6))
        x[4] += rng.normal(0.0, 1e-3)
        x[5] = rng.normal(0.0, 1e-2)
        x[6:10] = rng.uniform(0.0, 1.0, 4)
        yield x, rng.uniform(60e-6, 90e-6), rng.normal(0.0, 1e-2), rng.integers(0, 2, 4)


@pytest.mark.parametrize("name", sorted(CIRCUITS))
def test_compiled_rhs_equals_reference(name):
    params = CIRCUITS[name]
    for x, y, v, cmds in _states(params, 20, seed=3):
        ref = circuit.rhs(0.0, x, circuit.CircuitInputs(y, v, tuple(cmds), 150.0), params)
        got = kernel.rhs(x, y, v, cmds, 150.0, params)
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("name", ["realistic", "ideal"])
def test_compiled_step_equals_python_tr_bdf2(name):
    params = CIRCUITS[name]
    held = np.array([v.response != "first_order" for v in params.valves])
    x = circuit.initial_state(params)
    x[0] += 3e5
    x[5] = 1e-3
    rod0, rod1 = (73e-6, 0.0), (76e-6, 0.01)
    for cmds in ((1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)):
        seg = [(0.0, cmds)]
        ref = _integrate_step(x, rod0, rod1, seg, 150.0, params, 20e-6, 2, held, "tr_bdf2", False)
        got = _integrate_step(x, rod0, rod1, seg, 150.0, params, 20e-6, 2, held, "tr_bdf2", True)
        # pressures within the Newton tolerance (a few 1e-3 Pa on ~1.8 MPa), volumes to 1e-9
        np.testing.assert_allclose(got[0][:3], ref[0][:3], rtol=0.0, atol=1e-2)
        assert got[2] == pytest.approx(ref[2], rel=1e-6, abs=1e-20)
        assert got[3] == pytest.approx(ref[3], rel=1e-6, abs=1e-18)


def test_split_step_matches_whole_step_when_commands_do_not_change():
    """Two segments with the same commands integrate the same interval (two substeps each way)."""
    params = CIRCUITS["realistic"]
    held = np.array([True] * 4)
    x = circuit.initial_state(params)
    cmds = (1.0, 0.0, 0.0, 1.0)
    whole = _integrate_step(x, (73e-6, 0.0), (75e-6, 0.01), [(0.0, cmds)], 0.0, params,
                            20e-6, 2, held, "tr_bdf2", True)
    split = _integrate_step(x, (73e-6, 0.0), (75e-6, 0.01), [(0.0, cmds), (10e-6, cmds)], 0.0,
                            params, 20e-6, 2, held, "tr_bdf2", True)
    np.testing.assert_allclose(split[0][:3], whole[0][:3], atol=1e-2)


def test_kernel_reports_an_emptied_chamber():
    params = CIRCUITS["realistic"]
    x = circuit.initial_state(params)
    far = params.chamber.dead_volume / params.chamber.piston_area + 1e-3
    status, *_ = kernel.circuit_step(x, (0.0, 0.0), (far, 0.0), 20e-6, (1, 0, 0, 1), 0.0,
                                     params)
    assert status == kernel.CHAMBER_EMPTIED


def _switch_times(period, step, dead=2e-4, f=100.0, duration=0.03):
    u = lambda t: math.cos(2 * math.pi * f * t)  # noqa: E731
    ctl = SampledValveController("down", u, period, (dead,) * 4)
    t, times = 0.0, []
    while t < duration:
        event = ctl.next_event(t, t + step)
        h = step if event is None else event - t
        segs = ctl.segments(t, t + h)
        assert len(segs) == 1  # steps end at valve actions: none falls inside one
        times.append((t, segs[0][1]))
        t += h
    return [t for (t, c), (_, c0) in zip(times[1:], times[:-1]) if c != c0]


def test_valve_actions_do_not_depend_on_the_communication_step():
    """Extremes of u = cos(2 pi 100 t) at 5, 10, 15 ... ms; valves act 0.2 ms later (dead time)."""
    for step in (10e-6, 30e-6, 80e-6, 330e-6):
        times = np.array(_switch_times(10e-6, step))
        expected = np.array([5.2e-3, 10.2e-3, 15.2e-3, 20.2e-3, 25.2e-3])
        np.testing.assert_allclose(times, expected, atol=2 * TIME_TOLERANCE)


def test_sampled_controller_rejects_bad_input():
    from gmt import ParameterError
    with pytest.raises(ParameterError, match="period"):
        SampledValveController("down", math.cos, 0.0, (0.0,) * 4)
    with pytest.raises(ParameterError, match="dead_times"):
        SampledValveController("down", math.cos, 1e-5, (0.0, -1e-4, 0.0, 0.0))
