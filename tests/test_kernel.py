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
from system_models.implicit import NEWTON_ATOL, NEWTON_RTOL

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


def _run_steps(params, workspace_for_call, n=24, h=25e-6, substeps=3):
    """n communication steps of the kernel along a swinging rod, the valves switching halfway.

    ``workspace_for_call(k)`` gives the workspace of the k-th call (or None).
    Returns one row (state, three quadratures) per step.
    """
    x = circuit.initial_state(params)
    rows = []
    for k in range(n):
        t0, t1 = k * h, (k + 1) * h
        rod0 = (75e-6 + 5e-6 * math.sin(2e3 * t0), 1e-2 * math.cos(2e3 * t0))
        rod1 = (75e-6 + 5e-6 * math.sin(2e3 * t1), 1e-2 * math.cos(2e3 * t1))
        cmds = (1.0, 0.0, 0.0, 1.0) if k < n // 2 else (0.0, 1.0, 1.0, 0.0)
        x[6:10] = cmds
        status, x, pint, vol, comp, halvings = kernel.circuit_step(
            x, rod0, rod1, h, cmds, 150.0, params, substeps, workspace=workspace_for_call(k))
        assert status == kernel.OK and halvings == 0
        rows.append(np.concatenate((x, [pint, vol, comp])))
    return np.array(rows)


def _assert_same_to_newton_tolerance(got, ref):
    # each state within ten Newton tolerances (two stages a substep, three
    # substeps a call, each stage converged to one tolerance); the
    # quadratures to what such errors move them
    tol = 10.0 * (NEWTON_ATOL + NEWTON_RTOL * np.abs(ref[:, :10]))
    assert np.all(np.abs(got[:, :10] - ref[:, :10]) <= tol)
    # integral of p_P over the 25 us step [Pa s]
    np.testing.assert_allclose(got[:, 10], ref[:, 10], rtol=0.0, atol=10.0 * NEWTON_ATOL[0] * 25e-6)
    np.testing.assert_allclose(got[:, 11:], ref[:, 11:], rtol=0.0, atol=1e-15)  # volumes [m^3]


def test_kept_factors_give_the_steps_of_fresh_ones():
    """Factors kept over the substeps (the default) against a fresh Jacobian at every substep."""
    params = CIRCUITS["realistic"]
    fresh = [kernel.Workspace(reuse_factors=False) for _ in range(24)]
    ref = _run_steps(params, lambda k: fresh[k])
    got = _run_steps(params, lambda k: None)
    _assert_same_to_newton_tolerance(got, ref)
    jacobians = sum(int(w.counts[2]) for w in fresh)
    substeps = sum(int(w.counts[0]) for w in fresh)
    assert jacobians >= substeps  # fresh: at least one per substep


def test_workspace_kept_across_calls_gives_the_same_steps_with_fewer_jacobians():
    params = CIRCUITS["realistic"]
    ref = _run_steps(params, lambda k: kernel.Workspace(reuse_factors=False))
    per_call = [kernel.Workspace() for _ in range(24)]
    alone = _run_steps(params, lambda k: per_call[k])
    ws = kernel.Workspace()
    got = _run_steps(params, lambda k: ws)
    _assert_same_to_newton_tolerance(got, ref)
    _assert_same_to_newton_tolerance(alone, ref)
    substeps, newton, jacobians = ws.counts
    assert substeps == 24 * 3
    # fresh factors for each call's first substep (and where Newton stalls:
    # most after the valves switch), against those a shared workspace needs
    alone_jacobians = sum(int(w.counts[2]) for w in per_call)
    assert alone_jacobians >= 24
    assert 2 <= jacobians < alone_jacobians - 12
    assert newton < 10 * substeps


def test_a_call_without_workspace_depends_on_its_arguments_alone():
    params = CIRCUITS["realistic"]
    x = circuit.initial_state(params)
    args = (x, (73e-6, 0.0), (76e-6, 0.01), 25e-6, (1.0, 0.0, 0.0, 1.0), 150.0, params, 3)
    first = kernel.circuit_step(*args)
    kernel.circuit_step(x, (73e-6, 0.0), (70e-6, -0.02), 40e-6, (0.0, 1.0, 1.0, 0.0), 0.0,
                        params, 4)
    again = kernel.circuit_step(*args)
    np.testing.assert_array_equal(again[1], first[1])
    assert again[2:] == first[2:]


def test_workspace_factors_follow_the_substep_and_the_commands():
    """Kept factors are used for the same substep and commands only."""
    params = CIRCUITS["realistic"]
    ws = kernel.Workspace()
    x = circuit.initial_state(params)

    def jacobians_of_step(h, cmds):
        nonlocal x
        before = int(ws.counts[2])
        x[6:10] = cmds
        status, x, *_ = kernel.circuit_step(x, (73e-6, 0.0), (73e-6, 0.0), h, cmds, 150.0,
                                            params, 2, workspace=ws)
        assert status == kernel.OK
        return int(ws.counts[2]) - before

    for _ in range(20):  # settle at rest
        jacobians_of_step(20e-6, (1.0, 0.0, 0.0, 1.0))
    assert jacobians_of_step(20e-6, (1.0, 0.0, 0.0, 1.0)) == 0
    assert jacobians_of_step(20e-6, (0.0, 1.0, 1.0, 0.0)) >= 1  # other commands
    for _ in range(20):
        jacobians_of_step(20e-6, (0.0, 1.0, 1.0, 0.0))
    assert jacobians_of_step(10e-6, (0.0, 1.0, 1.0, 0.0)) >= 1  # another substep
    assert jacobians_of_step(10e-6, (0.0, 1.0, 1.0, 0.0)) == 0
    ws.forget()
    assert jacobians_of_step(10e-6, (0.0, 1.0, 1.0, 0.0)) >= 1


def _pressure_after(params, substeps=3, **kwargs):
    x = circuit.initial_state(params)
    x[0] += 3e5  # a transient: the chamber above the big cavity
    status, x1, *_ = kernel.circuit_step(x, (73e-6, 0.0), (76e-6, 0.01), 25e-6,
                                         (1.0, 0.0, 0.0, 1.0), 150.0, params, substeps,
                                         **kwargs)
    assert status == kernel.OK
    return x1[:3]


def test_error_control_converges_to_the_fine_fixed_step_result():
    params = CIRCUITS["realistic"]
    fine = _pressure_after(params, substeps=256)
    coarse_error = np.max(np.abs(_pressure_after(params) - fine))
    errors = [np.max(np.abs(_pressure_after(params, rtol=rtol) - fine))
              for rtol in (1e-3, 1e-4, 1e-5)]
    assert errors[0] < coarse_error
    assert errors[2] < errors[1] < errors[0]
    assert errors[2] < 1e-2 * coarse_error


def test_error_control_repeats_the_substeps_of_the_same_start():
    """Interface iterations (same x0, another rod end) take the first call's substeps."""
    params = CIRCUITS["realistic"]
    x = circuit.initial_state(params)
    x[0] += 3e5
    ws = kernel.Workspace()
    step = lambda rod1: kernel.circuit_step(  # noqa: E731
        x, (73e-6, 0.0), rod1, 25e-6, (1.0, 0.0, 0.0, 1.0), 150.0, params, 3, workspace=ws,
        rtol=1e-4)
    step((76e-6, 0.01))
    grid = ws.grid.copy()
    assert grid[0] == 0.0 and grid[-1] == 25e-6 and grid.size > 4
    substeps = int(ws.counts[0])
    again = step((76.5e-6, 0.012))
    assert again[0] == kernel.OK
    np.testing.assert_array_equal(ws.grid, grid)
    assert int(ws.counts[0]) - substeps == grid.size - 1
    # a new start state is controlled afresh, from the length proposed last
    x = again[1]
    step((78e-6, 0.01))
    assert ws.grid[-1] == 25e-6 and ws.control[0] > 0.0


def test_error_control_without_workspace_depends_on_the_arguments_alone():
    params = CIRCUITS["realistic"]
    first = _pressure_after(params, rtol=1e-4)
    _pressure_after(params, substeps=7, rtol=1e-3)
    np.testing.assert_array_equal(_pressure_after(params, rtol=1e-4), first)
