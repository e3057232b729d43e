"""Co-simulation of the EHA: transducer (FMU or gmt in-process) + hydraulic circuit.

References (the paper): the flow q = f A_d dy of eqs 39-41, with dy
the rod's displacement between the two valve switching instants of a cycle;
the valve bridge and the four stages of Figure 2; Figure 12 and conclusion 4
("the flow rate is improved [by the inverse compensator] and the growth rate
of the flow rate increases with excitation frequency").

The co-simulations are shared through module-scoped fixtures so that the file
runs in about a minute (run with ``-s`` to see the measured figures).
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import gmt
from smeha import cli
from smeha.flowstudy import MODES, Case, ensure_fmu, run_case
from system_models import presets
from system_models.circuit import CircuitInputs, CircuitParameters, initial_state
from system_models.controller import pump_phase, valve_commands
from system_models.cosim import CosimSettings, DirectTransducer, cosimulate, volume_balance
from system_models.flowcheck import switching_instants
from system_models.fluid import FluidParameters
from system_models.implicit import backward_euler
from system_models.valves import ValveParameters

REPO = Path(__file__).resolve().parents[1]

#: Paper, Table 2: pump piston area A_d = 1256 mm^2.
PISTON_AREA = 1256e-6
#: Frequencies of the ideal-limit checks [Hz]: the paper identified its model
#: at 50 and 100 Hz (Figures 6-7), the two ends of Figure 12.
FREQUENCIES = (50.0, 100.0)
#: Upper end of a plausible circuit pressure [Pa]: the accumulator runs at
#: 1.5 MPa (presets docstring); 10 MPa is far above anything the pump can build.
P_MAX = 10e6
#: Communication steps of the convergence study [s].
STEPS = (40e-6, 20e-6, 10e-6)


def _report(title, lines):
    print(f"\n[{title}]")
    for line in lines:
        print(f"  {line}")


# --------------------------------------------------------------------------------------
# shared co-simulations
# --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ideal_runs():
    """Ideal circuit, both modes at 50 and 100 Hz, gmt in-process, 6 cycles, h = 20 us.

    flow_check discards 2 cycles and averages the whole cycles after (3 here).
    """
    return {(f, mode): run_case(Case(f, mode, ideal=True, cycles=6, backend="direct"))
            for f in FREQUENCIES for mode in MODES}


@pytest.fixture(scope="module")
def realistic_steps():
    """Realistic circuit (delay valves, 150 N load), 100 Hz, uncompensated, at each h in STEPS.

    5 cycles: the shortest run flow_check accepts with two whole cycles averaged.
    """
    return {h: run_case(Case(100.0, "uncompensated", step=h, cycles=5, backend="direct"))
            for h in STEPS}


@pytest.fixture(scope="module")
def first_order_run():
    """Realistic oil and valves, but first-order valve openings (tau = 0.2 ms).

    Run through cosimulate directly: the presets have no first-order circuit.
    Returns (record, circuit).
    """
    valve = ValveParameters(area=20e-6, discharge_coefficient=0.65, transition_pressure=1e4,
                            response="first_order", opening_time=2e-4)
    circuit = CircuitParameters(fluid=FluidParameters(air_fraction=0.005), valves=(valve,) * 4)
    f = 100.0
    backend = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(f, 1.0),
                               gmt.DriveParameters())
    settings = CosimSettings(duration=3.0 / f, step=20e-6, load_force=presets.REALISTIC_LOAD)
    record = cosimulate(backend, lambda t: math.cos(2.0 * math.pi * f * t), circuit, settings)
    return record, circuit


@pytest.fixture(scope="module")
def fmu_and_direct():
    """100 Hz compensated, realistic circuit, through the FMU and through gmt in-process.

    4 cycles: flow_check (called by run_case) needs at least 4 compression
    starts, and a 3-cycle run has only 3 (see test_cli_*: --cycles 4).
    Also returns the file the FMU's physics module was loaded from.
    """
    path = ensure_fmu(quiet=True)
    case = Case(100.0, "compensated", cycles=4, backend="fmu")
    fmu = run_case(case, path)
    module = sys.modules.get("smeha_fmu_gmt")
    physics_file = getattr(module, "__file__", None)
    direct = run_case(dataclasses.replace(case, backend="direct"))
    return fmu, direct, physics_file


# --------------------------------------------------------------------------------------
# 1. ideal-limit flow check, eqs 40/41
# --------------------------------------------------------------------------------------
@pytest.mark.integration
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("frequency", FREQUENCIES)
def test_ideal_limit_flow_is_f_ad_dy(ideal_runs, frequency, mode):
    """Paper, eq 40 (uncompensated) and eq 41 (compensated): q = f A_d dy.

    In the ideal limit (100x stiffer oil, wide valves switching instantly, no
    load) every volume the rod sweeps between the switching instants reaches
    the big cavity, so the simulated mean flow must equal f A_d dy. 1 %: the
    issue's requirement; what remains is the oil compressed in the chamber
    and cavities (V/beta dp ~ 1e-4 of the pumped volume) and the O(h) timing
    of the switches on the step grid (measured ratios 1.001-1.002).
    """
    _, check, row = ideal_runs[(frequency, mode)]
    _report(f"ideal flow {frequency:g} Hz {mode}",
            [f"q_sim = {row['flow_sim_m3_s']:.5e} m^3/s, f A_d dy = {row['flow_eq_m3_s']:.5e} "
             f"m^3/s, ratio = {row['flow_ratio']:.5f}, dy = {row['dy_um']:.3f} um, "
             f"{check.cycles} cycles averaged, wall {row['wall_s']:.1f} s"])
    # the row's eq-39 flow is f A_d dy with the paper's A_d (Table 2), not some other area
    assert row["flow_eq_m3_s"] == pytest.approx(frequency * PISTON_AREA * check.dy, rel=1e-12)
    assert check.cycles >= 2
    assert row["flow_ratio"] == pytest.approx(1.0, abs=0.01)


# --------------------------------------------------------------------------------------
# 2. compensation gain grows with frequency (Figure 12)
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_compensated_flow_gain_grows_with_frequency(ideal_runs):
    """Paper, Figure 12 and conclusion 4: compensated flow above uncompensated, and
    the gain (compensated / uncompensated) larger at 100 Hz than at 50 Hz.

    For scale, the paper's Table 3 dy give 46 / (42 - 1.8) = 1.14 at 50 Hz and
    35.2 / (31.2 - 4.6) = 1.32 at 100 Hz (eqs 40/41 at equal f A_d); the test
    checks the paper's qualitative claim only, as the simulated dy differ.
    """
    gains = {}
    for f in FREQUENCIES:
        q_c = ideal_runs[(f, "compensated")][2]["flow_sim_m3_s"]
        q_u = ideal_runs[(f, "uncompensated")][2]["flow_sim_m3_s"]
        assert q_u > 0.0
        assert q_c > q_u, f"{f:g} Hz: compensated {q_c:.4e} not above uncompensated {q_u:.4e}"
        gains[f] = q_c / q_u
    _report("compensation gain", [f"{f:g} Hz: {g:.4f}" for f, g in gains.items()])
    assert gains[100.0] > gains[50.0]


# --------------------------------------------------------------------------------------
# 3. volume conservation over a whole run
# --------------------------------------------------------------------------------------
#: Oil volume bookkeeping: the imbalance left after a whole run, as a fraction
#: of the pumped volume. Backward Euler keeps the continuity equations' sum
#: (every valve flow leaves one volume and enters another) to round-off:
#: measured 1e-14-1e-12. One closed valve's leakage (1e-6 of its area) left out
#: of the books would already show as ~1e-6, so 1e-9 separates round-off from
#: any real leak in the bookkeeping.
IMBALANCE = 1e-9


@pytest.mark.integration
def test_volume_balance_ideal_circuit(ideal_runs):
    circuit = presets.ideal_circuit()
    lines = []
    for key, (record, _, _) in ideal_runs.items():
        imbalance, pumped = volume_balance(record, circuit)
        lines.append(f"{key}: imbalance {imbalance:.3e} m^3 of {pumped:.3e} m^3 pumped "
                     f"({abs(imbalance) / pumped:.1e})")
        assert pumped > 0.0
        assert abs(imbalance) <= IMBALANCE * pumped
    _report("volume balance, ideal circuit", lines)


@pytest.mark.integration
def test_volume_balance_realistic_delay_valves(realistic_steps):
    circuit = presets.realistic_circuit()
    assert all(v.response == "delay" for v in circuit.valves)
    lines = []
    for h, (record, _, _) in realistic_steps.items():
        imbalance, pumped = volume_balance(record, circuit)
        lines.append(f"h = {h * 1e6:g} us: imbalance {imbalance:.3e} m^3 of {pumped:.3e} m^3 "
                     f"({abs(imbalance) / pumped:.1e})")
        assert abs(imbalance) <= IMBALANCE * pumped
    _report("volume balance, realistic circuit (delay valves)", lines)


@pytest.mark.integration
def test_volume_balance_realistic_first_order_valves(first_order_run):
    """First-order valves add the opening fractions to the integrated state.

    That they were exercised shows in the record: in direction "down" V1 and
    V3 are never commanded open together (Figure 2, stages 1 and 2), yet a
    first-order valve closes over ~tau, so after each switch both pass flow
    far above a closed valve's leakage (presets docstring: the short circuit
    S -> P -> B). Leakage bound: C_d * 1e-6 A * sqrt(2 * 10 MPa / rho) = 2e-9.
    """
    record, circuit = first_order_run
    imbalance, pumped = volume_balance(record, circuit)
    overlap = int(np.sum((np.abs(record["q_v1"]) > 1e-7) & (np.abs(record["q_v3"]) > 1e-7)))
    _report("volume balance, first-order valves",
            [f"imbalance {imbalance:.3e} m^3 of {pumped:.3e} m^3 pumped "
             f"({abs(imbalance) / pumped:.1e}); rows with V1 and V3 both passing "
             f"> 1e-7 m^3/s: {overlap} of {len(record)}"])
    assert overlap > 0
    assert np.all(np.isfinite(record["p_pump"]))
    assert abs(imbalance) <= IMBALANCE * pumped


# --------------------------------------------------------------------------------------
# 4. convergence with the communication step
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_flow_converges_with_the_communication_step(realistic_steps):
    """Realistic circuit, 100 Hz, uncompensated: flows at h = 40, 20, 10 us.

    Requirements: the difference |q(h) - q(h/2)| shrinks as h halves, and
    |q(20 us) - q(10 us)| / q(10 us) < 2 %, so that the study's default 20 us
    step is within 2 % of a step half as long.

    Measured (and why the test does not claim a convergence order): q = 1.39518,
    1.39160, 1.39395 e-6 m^3/s; the differences are -3.59e-9 then +2.36e-9:
    they change sign, so their ratio (1.52) is not an asymptotic order. Runs
    outside the test (too slow for it) give 1.39656e-6 at 5 us and 1.39816e-6
    at 2.5 us: differences 2.61e-9 and 1.60e-9, i.e. the asymptotic (about
    first-order) regime begins only below ~10 us, where h resolves the
    rod-on-oil relaxation (c / k_oil ~ 15 us) and the O(h) lag of the valve
    switches on the step grid dominates. Below 0.3 % everywhere.
    """
    q = {h: realistic_steps[h][2]["flow_sim_m3_s"] for h in STEPS}
    d1 = q[40e-6] - q[20e-6]
    d2 = q[20e-6] - q[10e-6]
    _report("step convergence (realistic, 100 Hz, uncompensated)",
            [f"h = {h * 1e6:g} us: q = {q[h]:.6e} m^3/s, ratio to f A_d dy "
             f"{realistic_steps[h][2]['flow_ratio']:.4f}, wall "
             f"{realistic_steps[h][2]['wall_s']:.1f} s" for h in STEPS]
            + [f"q(40) - q(20) = {d1:+.3e}, q(20) - q(10) = {d2:+.3e}, "
               f"ratio |d1/d2| = {abs(d1 / d2):.3f}, |d2| / q(10) = {abs(d2) / q[10e-6]:.2e}"])
    assert abs(d2) < abs(d1)
    assert abs(d2) / q[10e-6] < 0.02


# --------------------------------------------------------------------------------------
# 5. FMU against gmt in-process
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_fmu_and_direct_backends_give_the_same_run(fmu_and_direct):
    """The same master loop with the FMU (fmpy) and with gmt in-process.

    The FMU runs the same physics code (its bundled copy) on the same floats,
    so the records must agree to round-off (measured: exactly).
    """
    (rec_f, _, row_f), (rec_d, _, row_d), _ = fmu_and_direct
    assert row_f["backend"] == "fmu" and row_d["backend"] == "direct"
    assert len(rec_f) == len(rec_d)
    lines = []
    for name in ("rod_displacement", "p_pump", "volume_into_big"):
        diff = float(np.max(np.abs(rec_f[name] - rec_d[name])))
        scale = float(np.max(np.abs(rec_d[name])))
        lines.append(f"{name}: max |fmu - direct| = {diff:.3e} (scale {scale:.3e})")
        assert diff <= 1e-12 * scale
    lines.append(f"flow fmu {row_f['flow_sim_m3_s']:.6e}, direct {row_d['flow_sim_m3_s']:.6e}; "
                 f"wall fmu {row_f['wall_s']:.1f} s, direct {row_d['wall_s']:.1f} s")
    _report("FMU vs direct (100 Hz compensated, realistic)", lines)
    assert row_f["flow_sim_m3_s"] == pytest.approx(row_d["flow_sim_m3_s"], rel=1e-12)


@pytest.mark.integration
def test_fmu_runs_its_own_bundled_physics(fmu_and_direct):
    """The FMU imports its physics under its own name (smeha_fmu_gmt) from its resources,
    not the repository's gmt that this process has imported."""
    physics_file = fmu_and_direct[2]
    assert physics_file is not None, "the FMU did not load smeha_fmu_gmt"
    path = Path(physics_file).resolve()
    assert REPO not in path.parents
    assert path.parent.name == "smeha_fmu_gmt" and path.parent.parent.name == "resources"
    assert Path(gmt.__file__).resolve() != path


# --------------------------------------------------------------------------------------
# 6. stability of the coupling
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_implicit_coupling_is_bounded_at_a_40_us_step(realistic_steps):
    """Realistic circuit, 100 Hz, h = 40 us: every pressure finite and in [0, 10 MPa]."""
    record = realistic_steps[40e-6][0]
    lines = []
    for name in ("p_pump", "p_big", "p_small", "p_accumulator"):
        p = record[name]
        lines.append(f"{name}: [{p.min() / 1e6:.3f}, {p.max() / 1e6:.3f}] MPa")
        assert np.all(np.isfinite(p))
        assert 0.0 <= p.min() and p.max() <= P_MAX
    assert np.all(np.isfinite(record["rod_displacement"]))
    _report("implicit coupling, h = 40 us", lines)


def _explicit_coupling(circuit, step, n_steps, frequency=100.0, load=0.0, limit=1e8):
    """Plain explicit (Gauss-Seidel) coupling of gmt.Transducer with the circuit.

    Each step: the transducer is stepped with the force A_d p_P of the previous
    step held, then the hydraulics are integrated over the step (backward
    Euler, the same integrator as the master) fed the rod's secant velocity.
    No iteration on the interface force. Uncompensated drive, direction
    "down", valves held at the Figure-2 command (no delay). Stops at the first
    |p_P| > limit or non-finite p_P.

    Returns the chamber pressures p_P at t_0..t_n [Pa].
    """
    area = circuit.chamber.piston_area
    transducer = gmt.Transducer(gmt.TransducerParameters(), gmt.Excitation(frequency, 1.0),
                                gmt.DriveParameters())
    w = 2.0 * math.pi * frequency
    x = initial_state(circuit)
    y0 = transducer.forward.displacement
    force = area * x[0]
    u_prev, compressing = 1.0, True
    pressures = [x[0]]
    for k in range(n_steps):
        u = math.cos(w * k * step)
        if k:
            compressing = pump_phase(u, u_prev, compressing)
        commands = tuple(1.0 if c else 0.0 for c in valve_commands("down", compressing))
        y1 = transducer.step(u, step, force).displacement
        x = x.copy()
        x[6:10] = commands

        def inputs_over(s0, s1, y0=y0, y1=y1, commands=commands):
            return CircuitInputs(y0 + (y1 - y0) * s1 / step, (y1 - y0) / step, commands, load)

        x = backward_euler(x, step, inputs_over, circuit)[0]
        pressures.append(x[0])
        if not (np.isfinite(x[0]) and abs(x[0]) <= limit):
            break
        force, y0, u_prev = area * x[0], y1, u
    return np.array(pressures)


@pytest.mark.integration
def test_explicit_coupling_diverges_where_the_implicit_master_does_not(ideal_runs):
    """Why cosim.py iterates on the interface force (its docstring).

    With the stiff oil of the ideal limit (beta = 1e11 Pa) a plain explicit
    coupling at the study's 20 us step blows up: the chamber, joined through
    V1 to the sealed big cavity, is a spring k = beta A_d^2 / (V_P + V_B)
    ~ 1e10 N/m on a rod with damping c = 2945 N s/m (paper, Table 2); the rod
    answers a held force error dF with dy ~ dF h / c, the oil with k dy: a
    loop gain of order k h / c ~ 1e2 per step. Measured: p_P = -55 MPa at the
    first step, then bounded while V3/V4 join the chamber to the soft
    accumulator (the first half cycle is expansion), and |p_P| > 1e8 Pa at
    step 254 (t = 5.08 ms), a few steps into the first compression stage.
    The implicit master, same circuit and step, keeps p_P in [0, 10 MPa]
    throughout (ideal_runs).

    Not asserted, measured: with the *realistic* circuit (air-laden oil, 20 mm^2
    valves) explicit coupling at 20 us stays bounded (p_P within 0.78-1.78 MPa
    over 2 cycles): open valves join the chamber to far larger volumes and
    the oil softens at low pressure, so k h / c stays near 1. It does not blow
    up within 50 steps at 20 us there, whatever cosim.py's docstring implies.
    """
    h = 20e-6
    n = int(round(1.5 / 100.0 / h))  # 1.5 cycles: into the first compression stage
    p = _explicit_coupling(presets.ideal_circuit(), h, n)
    diverged = (not np.isfinite(p[-1])) or abs(p[-1]) > 1e8
    _report("explicit (Gauss-Seidel) coupling, ideal circuit, h = 20 us",
            [f"stopped after {len(p) - 1} of {n} steps (t = {(len(p) - 1) * h * 1e3:.2f} ms), "
             f"last p_P = {p[-1]:.3e} Pa, max |p_P| before = {np.max(np.abs(p[:-1])):.3e} Pa"])
    assert diverged, f"explicit coupling stayed bounded over {n} steps: max |p_P| = " \
                     f"{np.max(np.abs(p)):.3e} Pa"
    implicit = ideal_runs[(100.0, "uncompensated")][0]["p_pump"]
    assert np.all(np.isfinite(implicit))
    assert 0.0 <= implicit.min() and implicit.max() <= P_MAX


# --------------------------------------------------------------------------------------
# 7. the valve stages of Figure 2 in a run
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_valve_stages_route_the_flow_as_figure_2(ideal_runs):
    """Ideal circuit, 100 Hz uncompensated, direction "down" (the paper's Figure 2):
    stage 1 (compressing) V1 open, V3 closed: V1 carries the pumped volume
    A_d dy of each compression window into the big cavity; stage 2 (expanding)
    V3 open, V1 closed: the chamber refills from the small cavity through V3.

    Record row k holds the phase applied over [t_k, t_k+1) while its flows are
    those of the state at t_k; backward Euler moves h q(x_k+1) over that step,
    so the phase of row k goes with the flows of row k+1.

    Tolerances: the pumped volume within 1 % (compression of the stiff oil
    and the cylinder's own motion, ~1e-4, measured 0.02 %); a closed valve
    passes only its leakage, area 1e-6 A: C_d 1e-6 A sqrt(2 dp / rho) with
    dp <= 10 MPa bounds it by 2e-8 m^3/s (measured 4e-9 for V3, 1.1e-8 for V1
    across the -1.6 MPa dip of p_B when V1 shuts behind the moving piston);
    the net leakage volume below 1e-3 of the pumped volume (measured 4e-4).
    """
    record = ideal_runs[(100.0, "uncompensated")][0]
    circuit = presets.ideal_circuit()
    h = record["time"][1] - record["time"][0]
    v = circuit.valves[0]
    leak_bound = (v.discharge_coefficient * v.leakage_fraction * v.area
                  * math.sqrt(2.0 * P_MAX / circuit.fluid.density))
    y = record["rod_displacement"]
    q1, q3 = record["q_v1"], record["q_v3"]
    starts, ends = switching_instants(record)
    starts = starts[2:]  # the study's transient: 2 cycles discarded (flow_check)
    lines = []
    n_windows = 0
    for s, s_next in zip(starts[:-1], starts[1:]):
        e = ends[(ends > s) & (ends < s_next)][0]
        comp, expa = slice(s + 1, e + 1), slice(e + 1, s_next + 1)
        assert np.all(record["compressing"][s:e] == 1.0)
        assert np.all(record["compressing"][e:s_next] == 0.0)
        pumped = PISTON_AREA * (y[e] - y[s])
        refill = PISTON_AREA * (y[e] - y[s_next])
        v1_c, v3_c = h * q1[comp].sum(), h * q3[comp].sum()
        v1_e, v3_e = h * q1[expa].sum(), h * q3[expa].sum()
        lines.append(f"t = {record['time'][s] * 1e3:.2f} ms: compression A_d dy = {pumped:.4e}, "
                     f"V1 {v1_c:.4e}, V3 {v3_c:.2e} (max |q3| {np.abs(q3[comp]).max():.1e}); "
                     f"expansion A_d dy = {refill:.4e}, V3 {-v3_e:.4e}, V1 {v1_e:.2e} "
                     f"(max |q1| {np.abs(q1[expa]).max():.1e}) m^3")
        assert pumped > 0.0 and refill > 0.0
        # stage 1: V1 carries the pumped volume, V3 leaks only
        assert v1_c == pytest.approx(pumped, rel=0.01)
        assert np.abs(q3[comp]).max() <= leak_bound
        assert abs(v3_c) <= 1e-3 * pumped
        # stage 2: V3 carries the refill (flow S -> P, negative), V1 leaks only
        assert -v3_e == pytest.approx(refill, rel=0.01)
        assert np.abs(q1[expa]).max() <= leak_bound
        assert abs(v1_e) <= 1e-3 * refill
        n_windows += 1
    _report("valve stages, ideal 100 Hz uncompensated", lines + [f"leak bound {leak_bound:.1e}"])
    assert n_windows >= 2


# --------------------------------------------------------------------------------------
# 8. command line
# --------------------------------------------------------------------------------------
@pytest.mark.integration
def test_cli_simulate_json(capsys):
    """``smeha simulate ... --json``: one JSON object with the eq-41 check.

    --cycles 4, not 3: the flow check discards 2 cycles and needs two
    compression starts after them; a 3-cycle run has 3 starts in all and the
    command exits 2 ("run too short").
    """
    status = cli.main(["simulate", "--frequency", "100", "--mode", "compensated", "--ideal",
                       "--cycles", "4", "--backend", "direct", "--json"])
    out = capsys.readouterr().out
    assert status == 0
    row = json.loads(out)
    assert {"frequency_Hz", "mode", "flow_sim_m3_s", "flow_eq_m3_s", "dy_um"} <= row.keys()
    assert row["frequency_Hz"] == 100.0 and row["mode"] == "compensated"
    # eq 41 with the paper's A_d (Table 2)
    assert row["flow_eq_m3_s"] == pytest.approx(100.0 * PISTON_AREA * row["dy_um"] * 1e-6,
                                                rel=1e-12)
    # ideal limit: within 1 % as in test_ideal_limit_flow_is_f_ad_dy
    assert row["flow_sim_m3_s"] == pytest.approx(row["flow_eq_m3_s"], rel=0.01)


@pytest.mark.integration
def test_cli_flow_json_has_both_modes(capsys):
    status = cli.main(["flow", "--frequencies", "100", "--ideal", "--cycles", "4",
                       "--backend", "direct", "--workers", "1", "--json"])
    out = capsys.readouterr().out
    assert status == 0
    rows = json.loads(out)["rows"]
    assert sorted(r["mode"] for r in rows) == sorted(MODES)
    assert all(r["frequency_Hz"] == 100.0 and r["circuit"] == "ideal" for r in rows)
    by = {r["mode"]: r for r in rows}
    assert by["compensated"]["flow_sim_m3_s"] > by["uncompensated"]["flow_sim_m3_s"] > 0.0


@pytest.mark.parametrize("argv, word", [
    (["simulate", "--frequency", "-5", "--mode", "compensated"], "--frequency"),
    (["simulate", "--frequency", "100", "--mode", "sideways"], "--mode"),
])
def test_cli_bad_input_exits_2(capsys, argv, word):
    """Bad input is refused by the parser (exit status 2), before any co-simulation."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert word in err
