"""The periodic-steady-state fast path (system_models.periodic, smeha.fastpath).

References: the flow q = f A_d dy of eqs 39-41 (the paper), eq 27 at zero
frequency (static compliance 1/K, Table 2), and continuity in the cylinder's
cavities. The agreement with time-stepped co-simulations -- the displacement
port on the same grid, and the force port (another cut and integration) -- is
in the integration tests at the end (module docstring of system_models.periodic
for what the fast path keeps and drops).
"""
from __future__ import annotations

import json
import dataclasses
import math

import numpy as np
import pytest

import gmt
from gmt.mechanics import frequency_response
from smeha import flowstudy
from smeha.fastpath import fast_case, flow_table
from system_models import periodic, presets
from system_models.accumulator import accumulator_pressure
from system_models.chamber import chamber_volume
from system_models.circuit import CircuitInputs, rhs, valve_flows
from system_models.cylinder import cavity_volumes
from system_models.periodic import PeriodicSettings, periodic_steady_state

#: Paper, Table 2: pump piston area A_d = 1256 mm^2 and rod stiffness K = 1.963e7 N/m.
PISTON_AREA = 1256e-6
STIFFNESS = 1.963e7


def _unit(frequency, compensated=False):
    drive = gmt.DriveParameters(compensated=compensated)
    return gmt.Transducer(gmt.TransducerParameters(), gmt.Excitation(frequency, 1.0), drive)


def _cosine(frequency):
    return lambda t: math.cos(2.0 * math.pi * frequency * t)


@pytest.fixture(scope="module")
def realistic_100():
    """Realistic circuit, 150 N, 100 Hz, uncompensated (the study's default case)."""
    return periodic_steady_state(_unit(100.0), _cosine(100.0), 100.0,
                                 presets.realistic_circuit(),
                                 PeriodicSettings(load_force=presets.REALISTIC_LOAD))


@pytest.fixture(scope="module")
def stiff_100():
    """Stiff oil (constant bulk modulus) on the differential cylinder, no load, 100 Hz,
    uncompensated (presets.differential_circuit)."""
    return periodic_steady_state(_unit(100.0), _cosine(100.0), 100.0,
                                 presets.differential_circuit())


# -- the equations ------------------------------------------------------------------------
def test_circuit_rates_are_the_circuit_rhs():
    """The vectorised assembly equals circuit.rhs (the co-simulation's) to round-off."""
    circuit = presets.realistic_circuit()
    rng = np.random.default_rng(6)
    x = np.array([1.7e6, 1.6e6, 1.45e6, 1.2e-5, 0.025, 0.01, 1.0, 0.3, 0.0, 0.8])
    for _ in range(5):
        x[:3] = rng.uniform(1.0e6, 2.2e6, 3)
        x[5] = rng.uniform(-0.05, 0.05)
        x[6:] = rng.uniform(0.0, 1.0, 4)
        y, v = rng.uniform(-50e-6, 50e-6), rng.uniform(-0.02, 0.02)
        inputs = CircuitInputs(y, v, (1.0, 0.0, 0.0, 1.0), 150.0)
        reference = rhs(0.0, x, inputs, circuit)
        p_a = accumulator_pressure(circuit.accumulator, x[3])
        vol_b, vol_s = cavity_volumes(circuit.cylinder, x[4])
        plant = periodic._Plant(circuit, x[4], vol_b, vol_s,
                                chamber_volume(circuit.chamber, 0.0), 150.0,
                                1.5e6, 0.0, x[4], None)
        s = np.array([[x[0], x[1], x[2], p_a, x[5]]])
        f, *_ = periodic._circuit(s, np.array([y]), np.array([v]), x[6:][None, :], 0.0, 1.0,
                                  plant)
        expected = [reference[0], reference[1], reference[2], reference[3], reference[5]]
        np.testing.assert_allclose(f[0], expected, rtol=1e-12, atol=1e-12)
        q, _ = periodic._valve_flows(*(np.array([p]) for p in (x[0], x[1], x[2], p_a)),
                                     x[6:][None, :], circuit)
        np.testing.assert_allclose(np.ravel(q), valve_flows(x, circuit), rtol=1e-12)


def test_jacobian_matches_finite_differences():
    """The assembled sparse Jacobian against central differences of the residual."""
    frequency, n = 100.0, 40
    settings = PeriodicSettings(step=1.0 / (frequency * n), load_force=150.0)
    system, z, _ = periodic._setup(_unit(frequency), _cosine(frequency), frequency,
                                   presets.realistic_circuit(), settings)
    _, data, _ = system.evaluate(z)
    matrix = system.matrix(data).toarray()
    # perturbation per unknown: [m, m/s, Pa x4, m/s] for t_n and the stage, the drift [m^3/s]
    size = np.concatenate((np.tile([1e-11, 1e-8] + [1.0] * 4 + [1e-8] + [1.0] * 4 + [1e-8],
                                   n), [1e-13]))
    for col in list(range(0, system.size, 7)) + [system.size - 1]:
        dz = np.zeros_like(z)
        dz[col] = size[col]
        column = (system.evaluate(z + dz, False)[0] - system.evaluate(z - dz, False)[0]) \
            / (2.0 * size[col])
        # the linearised gas spring's stiffness is held fixed in the Jacobian (its change
        # with the mean p_A, ~1e-6 relative, is left out)
        np.testing.assert_allclose(matrix[:, col], column, rtol=1e-4,
                                   atol=1e-6 * np.max(np.abs(column)) + 1e-30)


def test_rod_harmonic_balance_is_the_sampled_eq_29():
    """Y = G_d(z) F at the period's harmonics, G_d from gmt.mechanics (eq 29, ZOH)."""
    params = gmt.TransducerParameters()
    n, h = 64, 1.0 / (100.0 * 64)
    impulse = np.zeros(n)
    impulse[0] = 1.0
    y, v = periodic.rod_periodic_response(impulse, params, h)
    k = np.arange(1, 6)
    gy, gv = frequency_response(params.mass, params.damping, params.stiffness,
                                2.0 * np.pi * k / (n * h), step=h)
    np.testing.assert_allclose(np.fft.fft(y)[k], gy, rtol=1e-12)
    np.testing.assert_allclose(np.fft.fft(v)[k], gv, rtol=1e-12)


def test_first_order_valve_opening_returns_to_itself():
    command = np.r_[np.ones(30), np.zeros(20)]
    start, stage, end = periodic._first_order_openings(command, 2e-4, 20e-6)
    assert end[-1] == pytest.approx(start[0], abs=1e-14)
    np.testing.assert_allclose(end[:-1], start[1:])
    # the same orbit as iterating the step many periods from shut
    o = 0.0
    c = periodic.TRBDF2_D * 20e-6 / 2e-4
    for _ in range(200):
        for cmd in command:
            og = ((1 - c) * o + 2 * c * cmd) / (1 + c)
            o = (periodic._A * og - periodic._B * o + c * cmd) / (1 + c)
    assert o == pytest.approx(start[0], abs=1e-12)
    assert np.all((0.0 <= stage) & (stage <= 1.0))


# -- the physics --------------------------------------------------------------------------
@pytest.mark.parametrize("frequency", [50.0, 100.0])
@pytest.mark.parametrize("mode", flowstudy.MODES)
def test_ideal_circuit_gives_eq_40_41(frequency, mode):
    """The ideal circuit: q = f A_d dy (eqs 40, 41), with dy the free transducer's.

    The pumped volume reaches the big cavity uncompressed (stiff oil, wide instant
    valves) and the chamber pressure is the same in both strokes (equal areas, no load),
    so the rod's stroke is the free one. 0.5 %: the fast path's grid dy (switches on the
    20 us grid); measured within 0.3 %.
    """
    _, row = fast_case(frequency, mode, circuit="ideal")
    assert row["flow_eq_m3_s"] == pytest.approx(frequency * PISTON_AREA * row["dy_um"] * 1e-6)
    assert row["flow_ratio"] == pytest.approx(1.0, abs=5e-3)
    assert row["delivered_fraction"] == pytest.approx(1.0, abs=5e-3)


def test_rod_is_pushed_back_by_the_chamber_force(realistic_100):
    """Eq 27 linear in F_ext: y = y_free - G (A_d p_P); at DC the mean shifts by A_d p_P / K."""
    sol = realistic_100
    params = gmt.TransducerParameters()
    loaded = sol.magnetostrictive_force - PISTON_AREA * np.roll(sol.p_pump, -1)
    y, v = periodic.rod_periodic_response(loaded, params, sol.step)
    np.testing.assert_allclose(sol.rod_displacement, y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.rod_velocity, v, rtol=0, atol=1e-8)
    y_free, _ = periodic.rod_periodic_response(sol.magnetostrictive_force, params, sol.step)
    shift = np.mean(y_free) - np.mean(sol.rod_displacement)
    assert shift == pytest.approx(PISTON_AREA * np.mean(sol.p_pump) / STIFFNESS, rel=1e-9)


def test_cavities_conserve_oil(stiff_100):
    """Continuity: the oil into B moves the piston (A_B w), the accumulator gives the rod's volume.

    With the stiff oil's constant bulk modulus the cavity balances close to
    round-off; the chamber, whose volume moves with the rod, absorbs ~5e-4 of
    the flow over a cycle at this step (its pressure-volume loop), which the
    accumulator's outflow carries.
    """
    cyl = presets.differential_circuit().cylinder
    w = np.mean(stiff_100.piston_velocity)
    assert stiff_100.flow == pytest.approx(cyl.big_area * w, rel=1e-4)
    assert stiff_100.accumulator_drift == pytest.approx(-(cyl.big_area - cyl.small_area) * w,
                                                        rel=2e-3)


def test_realistic_piston_rings_while_the_big_cavity_is_shut(realistic_100):
    """The reason the cavities are kept dynamic: p_B swings far from its load balance.

    Load balance at rest: p_B = (F + p_S A_S) / A_B, ~1.6 MPa; the time-stepped
    record swings 1.08-2.06 MPa (system_models.periodic docstring).
    """
    sol = realistic_100
    cyl = presets.realistic_circuit().cylinder
    balance = (presets.REALISTIC_LOAD + np.mean(sol.p_small) * cyl.small_area) / cyl.big_area
    assert np.mean(sol.p_big) == pytest.approx(balance, rel=0.01)
    assert np.ptp(sol.p_big) > 0.5 * balance


def test_a_heavier_load_leaves_less_flow():
    """The pump must lift p_B further above p_S; the chamber gives more stroke back."""
    flows = [fast_case(100.0, "uncompensated", load=load)[1]["flow_sim_m3_s"]
             for load in (0.0, 100.0, 150.0)]
    assert flows[0] > flows[1] > flows[2] > 0.0


def test_oil_charge_sets_the_accumulator_below_its_filling_pressure(realistic_100):
    """Chamber force pushes the rod back ~96 um (1.9 kN / K); the accumulator refills it."""
    p_fill = 1.5 * presets.realistic_circuit().accumulator.precharge_pressure
    assert p_fill - 15e3 < np.mean(realistic_100.p_accumulator) < p_fill


def test_fixed_accumulator_pressure_is_kept():
    sol = periodic_steady_state(_unit(100.0), _cosine(100.0), 100.0, presets.ideal_circuit(),
                                PeriodicSettings(accumulator_pressure=1.4e6))
    assert np.mean(sol.p_accumulator) == pytest.approx(1.4e6, rel=1e-6)


# -- the table ----------------------------------------------------------------------------
def test_flow_table_rows_print_as_the_study_does():
    rows = flow_table([100.0], ["compensated"], load=[0.0, 150.0])
    assert [r["load_N"] for r in rows] == [0.0, 150.0]
    for r in rows:
        assert r["backend"] == "fastpath" and r["circuit"] == "realistic"
        assert r["flow_ratio"] == pytest.approx(r["flow_sim_m3_s"] / r["flow_eq_m3_s"])
    text = flowstudy.format_table(rows) + flowstudy.format_load_lines(rows)
    assert "compensated" in text


def test_free_dy_is_the_study_free_dy():
    """dy of the transducer alone on the fast path's grid equals flowstudy's (closed form)."""
    _, row = fast_case(100.0, "uncompensated", circuit="ideal")
    assert row["dy_free_um"] == pytest.approx(flowstudy.free_dy(100.0, "uncompensated") * 1e6,
                                              rel=1e-4)


def test_sampling_phases_average_shifted_grids():
    sols, row = fast_case(70.0, "uncompensated", sampling_phases=2)
    assert len(sols) == 2
    assert row["flow_sim_m3_s"] == pytest.approx(np.mean([s.flow for s in sols]))


# -- errors -------------------------------------------------------------------------------
def test_refuses_bad_settings():
    with pytest.raises(gmt.ParameterError, match="direction"):
        PeriodicSettings(direction="sideways")
    with pytest.raises(gmt.ParameterError, match="max_iterations"):
        PeriodicSettings(max_iterations=0)
    with pytest.raises(gmt.ParameterError, match="piston_position"):
        periodic_steady_state(_unit(100.0), _cosine(100.0), 100.0, presets.realistic_circuit(),
                              PeriodicSettings(piston_position=0.06))  # the stroke is 50 mm
    with pytest.raises(gmt.ParameterError, match="sampling_phases"):
        fast_case(100.0, "uncompensated", sampling_phases=0)


def test_refuses_a_model_variant():
    variant = gmt.ModelVariant("transport_delay", {"delay_s": 5e-4})
    unit = gmt.Transducer(excitation=gmt.Excitation(100.0, 1.0), variant=variant)
    with pytest.raises(gmt.ParameterError, match="variant"):
        periodic_steady_state(unit, _cosine(100.0), 100.0, presets.ideal_circuit())


@pytest.mark.integration
def test_first_order_valves_solve_to_the_force_port_flow():
    """The valve lag is solved on its own periodic orbit, and the flow is the one a
    time-stepped force-port co-simulation delivers (another cut, integrator, valve timing
    and time marching instead of Newton on the period): within 1 %, measured 0.56 % (the
    fast path's displacement-port discretisation at 20 us, whose time-stepped run agrees
    with it to 0.04 %)."""
    base = presets.realistic_circuit()
    valve = dataclasses.replace(base.valves[0], response="first_order")
    circuit = dataclasses.replace(base, valves=(valve,) * 4)
    sol = periodic_steady_state(_unit(100.0), _cosine(100.0), 100.0, circuit,
                                PeriodicSettings(load_force=150.0))
    from system_models.cosim import CosimSettings, DirectTransducer, cosimulate
    from system_models.flowcheck import flow_check
    backend = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(100.0, 1.0))
    record = cosimulate(backend, flowstudy.control_signal("uncompensated", 100.0)[0], circuit,
                        CosimSettings(duration=0.08, load_force=150.0))
    stepped = flow_check(record, 100.0, PISTON_AREA)
    assert sol.flow == pytest.approx(stepped.flow_sim, rel=0.01)
    assert sol.dy == pytest.approx(stepped.dy, rel=0.01)


def test_reversed_flow_is_flagged_with_its_reason():
    """The uncompensated pump at 150 Hz: the rod lags the valve timing by more than a quarter
    period, dy < 0 and the flow runs backwards; the row says so, and why (issue 12)."""
    rows = flow_table([100.0, 150.0], ["uncompensated"])
    ok, reversed_ = rows
    assert not ok["flow_reversed"] and "note" not in ok
    assert reversed_["flow_sim_m3_s"] < 0.0 and reversed_["dy_um"] < 0.0
    assert reversed_["flow_reversed"]
    assert "lags" in reversed_["note"] and "quarter period" in reversed_["note"]
    text = flowstudy.format_table(rows)
    assert "(!) 150 Hz uncompensated: flow reversed" in text


# -- against time stepping -----------------------------------------------------------------
@pytest.mark.integration
def test_agrees_with_the_time_stepped_co_simulation(realistic_100):
    """The realistic 100 Hz case against 8 time-stepped cycles of the displacement port on the
    fast path's grid (gmt in-process; the valve controller sampling at the 20 us step).

    Both take the same discrete equations, so what separates them is what
    the fast path drops: the accumulator's pressure falls ~0.2 kPa a cycle and
    the piston advances 0.05 mm a cycle in the time-stepped run (together
    ~0.2 % of flow by the averaging window's middle), plus transient left in
    the window (cycle-to-cycle change < 0.05 %). Measured: -0.05 %; allowed 0.5 %.
    """
    record, check, _ = flowstudy.run_case(flowstudy.Case(
        100.0, "uncompensated", backend="direct", coupling="displacement", step=20e-6,
        controller_period=20e-6, hydraulic_step=None))
    sol = realistic_100
    assert sol.flow == pytest.approx(check.flow_sim, rel=5e-3)
    assert sol.dy == pytest.approx(check.dy, rel=5e-3)
    # the waveforms of the last whole cycle, the piston's ringing included. Measured: rms
    # 0.2-0.7 % of the swing, largest 1.6-2.5 % on the step after a valve switch (the
    # accumulator's ~1 kPa drift shifts the chamber's jump there)
    n = sol.time.size
    last = record[-n - 1:-1]
    index = np.rint(last["time"] / sol.step).astype(int) % n
    for name in ("p_big", "p_pump", "rod_displacement", "piston_velocity"):
        error = getattr(sol, name)[index] - last[name]
        swing = np.ptp(last[name])
        assert np.sqrt(np.mean(error ** 2)) < 0.01 * swing, name
        assert np.max(np.abs(error)) < 0.03 * swing, name


def test_cli_flow_fast_json(capsys):
    """`smeha flow --fast --json`: the fast path's rows, in the flow study's keys."""
    from smeha import cli
    assert cli.main(["flow", "--fast", "--frequencies", "100", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [(r["frequency_Hz"], r["mode"]) for r in rows] == [
        (100.0, "uncompensated"), (100.0, "compensated")]
    assert all(r["backend"] == "fastpath" and r["flow_sim_m3_s"] > 0 for r in rows)


def test_cli_flow_fast_says_what_it_solved(capsys):
    """The fast path's table is labelled as the periodic steady state, not a co-simulation."""
    from smeha import cli
    assert cli.main(["flow", "--fast", "--frequencies", "100"]) == 0
    out = capsys.readouterr().out
    assert "periodic steady state (fast path) against eqs 40/41" in out
    assert "co-simulation against" not in out


def test_cli_flow_fast_refuses_a_variant(capsys):
    from smeha import cli
    assert cli.main(["flow", "--fast", "--variant", "data/paper_variant.json"]) == 2
    assert "--fast does not take --variant: it solves the paper's model only" in \
        capsys.readouterr().err
