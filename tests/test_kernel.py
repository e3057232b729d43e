"""The compiled hydraulic kernel, the plant it steps, and the sampled valve controller.

References: the kernel claims to compute the same right-hand sides as
:func:`system_models.circuit.rhs` and :func:`system_models.plant.rhs` (so:
equal to round-off), the displacement port's TR-BDF2 step as
:func:`system_models.implicit.tr_bdf2` (so: equal to the kernel's Newton
tolerance, 1 Pa plus 1e-7 relative on the pressures), and the plant's
solution of its ODE -- checked against scipy's Radau IIA (a different method:
fifth order, its own error control; Hairer & Wanner, Solving ODEs II, sec.
IV.8) to TR-BDF2's own error. Statics: eq 27 at rest, K y = F - A_d p
(paper; Table 2's K).
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from system_models import circuit, kernel, plant, presets
from system_models.kernel import trbdf2
from system_models.controller import TIME_TOLERANCE, SampledValveController
from system_models.implicit import tr_bdf2
from system_models.rod import RodParameters

CIRCUITS = {"realistic": presets.realistic_circuit(), "ideal": presets.ideal_circuit(),
            "differential": presets.differential_circuit(),
            "first_order_valves": circuit.CircuitParameters()}
#: Paper, Table 2: m, c, K of eq 27 and A_d.
TABLE_2_ROD = RodParameters(0.02, 2945.0, 1.963e7)
PISTON_AREA = 1256e-6
#: A two-mass rod (the mechanical_resonance:two_dof variant's form): Table 2's m split
#: 12 g / 8 g, a 30 kHz joint (k_j = m_2 (2 pi 30 kHz)^2 ~ 2.8e8 N/m).
TWO_MASS_ROD = RodParameters(0.012, 2945.0, 1.963e7, 0.008, 2.84e8, 150.0)


def _states(params, n, seed, rod=None):
    rng = np.random.default_rng(seed)
    base = circuit.initial_state(params)
    for _ in range(n):
        x = base.copy()
        x[:3] += rng.normal(0.0, 3e5, 3)
        x[3] = abs(rng.normal(1e-5, 5e-6))
        x[4] += rng.normal(0.0, 1e-3)
        x[5] = rng.normal(0.0, 1e-2)
        x[6:10] = rng.uniform(0.0, 1.0, 4)
        if rod is not None:
            x = np.concatenate((x, rng.uniform(60e-6, 90e-6, rod.size)))
            x[11::2] = rng.normal(0.0, 1e-2, rod.size // 2)
        yield x, rng.uniform(60e-6, 90e-6), rng.normal(0.0, 1e-2), rng.integers(0, 2, 4)


@pytest.mark.parametrize("name", sorted(CIRCUITS))
def test_compiled_circuit_rates_equal_the_readable_ones(name):
    params = CIRCUITS[name]
    for x, y, v, cmds in _states(params, 20, seed=3):
        ref = circuit.rhs(0.0, x, circuit.CircuitInputs(y, v, tuple(cmds), 150.0), params)
        got = kernel.rates(x, y, v, cmds, 150.0, kernel.pack(params))
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("rod", [TABLE_2_ROD, TWO_MASS_ROD], ids=["one_mass", "two_masses"])
def test_compiled_plant_rates_equal_the_readable_ones(rod):
    p = plant.PlantParameters(CIRCUITS["realistic"], rod)
    for z, _, _, cmds in _states(p.circuit, 20, seed=4, rod=rod):
        ref = plant.rhs(0.0, z, 1900.0, tuple(cmds), 150.0, p)
        got = kernel.rates(z, 1900.0, 0.0, cmds, 150.0, p.packed)
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("name", ["realistic", "ideal"])
def test_compiled_circuit_step_equals_python_tr_bdf2(name):
    params = CIRCUITS[name]
    x = circuit.initial_state(params)
    x[0] += 3e5
    x[5] = 1e-3
    rod0, rod1, h = (73e-6, 0.0), (76e-6, 0.01), 20e-6
    dy, v0, v1 = rod1[0] - rod0[0], rod0[1], rod1[1]

    def position(s):  # the cubic Hermite path the kernel puts the rod on
        r = s / h
        return (rod0[0] + v0 * s + (3 * dy - h * (2 * v0 + v1)) * r * r
                + (h * (v0 + v1) - 2 * dy) * r ** 3)

    for cmds in ((1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)):
        x[6:10] = cmds
        ref = tr_bdf2(x, h, lambda s, vel, c=cmds: circuit.CircuitInputs(position(s), vel, c,
                                                                         150.0), params, 2)
        status, got, *rest = kernel.circuit_step(x, rod0, rod1, h, cmds, 150.0, params, 2)
        assert status == kernel.OK
        # pressures within ten of the kernel's Newton tolerances (two stages a substep, two
        # substeps, each converged to one), volumes to what such errors move them
        np.testing.assert_allclose(got[:3], ref[0][:3], rtol=0.0,
                                   atol=10 * (trbdf2._ATOL[0] + kernel.RTOL * 2e6))
        assert rest[1] == pytest.approx(ref[2], rel=1e-5, abs=1e-20)
        assert rest[2] == pytest.approx(ref[3], rel=1e-5, abs=1e-18)


def test_kernel_reports_an_emptied_chamber():
    params = CIRCUITS["realistic"]
    x = circuit.initial_state(params)
    far = params.chamber.dead_volume / params.chamber.piston_area + 1e-3
    status, *_ = kernel.circuit_step(x, (0.0, 0.0), (far, 0.0), 20e-6, (1, 0, 0, 1), 0.0,
                                     params)
    assert status == kernel.CHAMBER_EMPTIED


# -- the plant against an independent integrator -------------------------------------------
def _radau(p, z0, force, cmds, duration):
    z = np.array(z0, dtype=float)
    z[6:10] = cmds  # valves without dynamics hold their command (kernel.equations._hold_valves)
    scale = np.maximum(np.abs(z), [1e5] * 3 + [1e-6, 1e-3, 1e-3] + [1.0] * 4
                       + [1e-6, 1e-3] * (p.rod.size // 2))
    sol = solve_ivp(lambda t, y: plant.rhs(t, y, force(t), cmds, 150.0, p), (0.0, duration),
                    z, method="Radau", rtol=1e-10, atol=1e-12 * scale, dense_output=True)
    assert sol.success
    return sol


@pytest.mark.integration
@pytest.mark.parametrize("rod", [TABLE_2_ROD, TWO_MASS_ROD], ids=["one_mass", "two_masses"])
def test_plant_converges_to_radau_at_second_order(rod):
    """Realistic circuit, the rod loaded from rest with V1/V4 open (the chamber at 1.7 MPa
    pushes it back, p_P falls to 0.36 MPa in 0.2 ms) under a linear force ramp: 2 ms in
    communication steps of 100 us, substeps of at most 10 us and 1 us, against Radau at
    rtol 1e-10.

    TR-BDF2 is second order: ten times shorter substeps must cut the error by well over
    ten (measured ~65x at the worst instant; the bound asks 30x). At 1 us the errors are
    ~20 Pa and ~1 nm (bounds 100 Pa, 5 nm, against a 1.3 MPa swing and a ~30 um stroke).
    """
    p = plant.PlantParameters(CIRCUITS["realistic"], rod)
    z0 = plant.initial_state(p, 73.47e-6)
    # the rod at its free rest (initial_state starts it loaded by the chamber): the
    # transient this test is about
    z0[z0.size - p.rod.size:] = p.rod.rest_state(73.47e-6)
    z0[0] += 2e5
    cmds = (1.0, 0.0, 0.0, 1.0)
    n, h = 20, 1e-4

    def force(t):
        return 1400.0 + 500.0 * t / (n * h)

    forces = np.array([[force(k * h), force((k + 1) * h)] for k in range(n)])
    ref = _radau(p, z0, force, cmds, n * h)
    exact = np.array([ref.sol((k + 1) * h) for k in range(n)])
    errors = {}
    for substep in (1e-5, 1e-6):
        run = plant.run(z0, [h] * n, forces, np.tile(cmds, (n, 1)), 150.0, p,
                        max_substep=substep)
        assert run.status == kernel.OK and run.done == n
        y = np.array([plant.chamber_side(z, p)[0] for z in run.states])
        y_ref = np.array([plant.chamber_side(z, p)[0] for z in exact])
        errors[substep] = (np.max(np.abs(run.states[:, 0] - exact[:, 0])),
                           np.max(np.abs(y - y_ref)))
    assert errors[1e-6][0] < 100.0 and errors[1e-6][1] < 5e-9
    assert errors[1e-5][0] > 30 * errors[1e-6][0] and errors[1e-5][1] > 30 * errors[1e-6][1]


def test_held_force_settles_at_eq_27_statics():
    """Valves shut, a held force: the rod settles where K y + c v = F - A_d p_P (eq 27 with
    m y'' gone), p_P the chamber pressure the rod's travel leaves; what motion is left is the
    shut valves' leakage (1e-6 of their area) letting the chamber creep."""
    p = plant.PlantParameters(CIRCUITS["ideal"], TABLE_2_ROD)
    z0 = plant.initial_state(p, 73.47e-6)
    n = 200  # 20 ms: many times the rod's slowest time constant, c / (K + k_oil)
    run = plant.run(z0, [1e-4] * n, np.full((n, 2), 2500.0), np.zeros((n, 4)), 0.0, p)
    assert run.status == kernel.OK
    y, v = plant.chamber_side(run.states[-1], p)
    p_p = run.states[-1][0]
    rod = TABLE_2_ROD
    assert rod.stiffness * y + rod.damping * v == pytest.approx(2500.0 - PISTON_AREA * p_p,
                                                                rel=1e-9)
    assert abs(v) < 1e-4  # mm/s against the rod's 10 mm/s when pumping


def test_plant_volume_balance_closes():
    """Continuity over the plant: the rod's swept volume, the piston's, the accumulator's oil
    and the compression add up to zero (round-off; system_models.cosim.volume_balance)."""
    from system_models.accumulator import oil_volume_at
    p = plant.PlantParameters(CIRCUITS["realistic"], TWO_MASS_ROD)
    z0 = plant.initial_state(p, 73.47e-6)
    n = 60
    cmds = np.array([(1.0, 0.0, 0.0, 1.0)] * 30 + [(0.0, 0.0, 1.0, 1.0)] * 30)
    forces = np.column_stack([1400 + 300 * np.sin(np.arange(n) * 0.3)] * 2)
    run = plant.run(z0, [1e-4] * n, forces, cmds, 150.0, p)
    assert run.status == kernel.OK
    cyl, acc, z1 = p.circuit.cylinder, p.circuit.accumulator, run.states[-1]
    dx = z1[4] - z0[4]
    total = (-PISTON_AREA * (plant.chamber_side(z1, p)[0] - plant.chamber_side(z0, p)[0])
             + (cyl.big_area - cyl.small_area) * dx
             + oil_volume_at(acc, run.accumulator_pressure[-1]) - z0[3]
             + run.compression_volume[-1])
    # TR-BDF2 keeps the sum to its Newton tolerance (1e-7 relative): against a stroke's
    # swept volume A_d 1e-4 m; one shut valve's leakage left out would be ~1e-4 of it
    assert abs(total) < 1e-6 * PISTON_AREA * 1e-4


def test_substeps_start_short_after_a_valve_action():
    """Counts of the work done: a step after the valves switch takes the graded substeps
    (1 + 4 + 16 + 64 us, then one of 15 us), the next step one substep."""
    p = plant.PlantParameters(CIRCUITS["realistic"], TABLE_2_ROD)
    z0 = plant.initial_state(p, 73.47e-6)
    counts = np.zeros(3, dtype=np.int64)
    control = kernel.new_control()
    for cmds in ((1.0, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 1.0)):
        before = counts[0]
        status, _, rows = kernel.plant_run(z0, [1e-4], [[1442.0, 1442.0]], [cmds], 150.0,
                                           p.packed, control=control, counts=counts)
        assert status == kernel.OK
        z0 = rows[0, :12]
        assert counts[0] - before == (5 if before == 0 else 1)


# -- the sampled valve controller --------------------------------------------------------
def _switch_times(period, step, dead=2e-4, f=100.0, duration=0.03):
    u = lambda t: np.cos(2 * np.pi * f * t)  # noqa: E731
    ctl = SampledValveController("down", u, period, (dead,) * 4)
    t, times = 0.0, []
    while t < duration:
        action = ctl.next_action(t, t + step)
        h = step if action is None else action - t
        times.append((t, ctl.commands_at(t)))
        # steps end at valve actions: the commands are constant over each
        assert ctl.commands_at(t + 0.5 * h) == times[-1][1]
        t += h
    return [t for (t, c), (_, c0) in zip(times[1:], times[:-1]) if c != c0]


def test_valve_actions_do_not_depend_on_the_communication_step():
    """Extremes of u = cos(2 pi 100 t) at 5, 10, 15 ... ms; valves act 0.2 ms later (dead time)."""
    for step in (10e-6, 30e-6, 80e-6, 330e-6):
        times = np.array(_switch_times(10e-6, step))
        expected = np.array([5.2e-3, 10.2e-3, 15.2e-3, 20.2e-3, 25.2e-3])
        np.testing.assert_allclose(times, expected, atol=2 * TIME_TOLERANCE)


def test_scalar_and_vectorised_control_give_the_same_switches():
    """A u that takes only floats (math.cos) is sampled one instant at a time: same actions."""
    f = 70.0
    vector = SampledValveController("down", lambda t: np.cos(2 * np.pi * f * t), 1e-5,
                                    (2e-4,) * 4)
    scalar = SampledValveController("down", lambda t: math.cos(2 * math.pi * f * t), 1e-5,
                                    (2e-4,) * 4)
    t = 0.0
    while t < 0.05:
        a, b = vector.next_action(t, t + 1e-3), scalar.next_action(t, t + 1e-3)
        assert a == b
        t = a if a is not None else t + 1e-3
        assert vector.commands_at(t) == scalar.commands_at(t)
        assert vector.phase_at(t) == scalar.phase_at(t)


def test_sampled_controller_rejects_bad_input():
    from gmt import ParameterError
    with pytest.raises(ParameterError, match="period"):
        SampledValveController("down", math.cos, 0.0, (0.0,) * 4)
    with pytest.raises(ParameterError, match="dead_times"):
        SampledValveController("down", math.cos, 1e-5, (0.0, -1e-4, 0.0, 0.0))
    with pytest.raises(ParameterError, match="direction"):
        SampledValveController("sideways", math.cos, 1e-5, (0.0,) * 4)


def test_circuit_names_agree():
    """The command line's --circuit choices (typed there so --help loads no solver) are the
    presets' circuits."""
    from smeha.studies import flowcommands
    assert flowcommands.CIRCUITS == tuple(presets.CIRCUITS)


def test_the_cache_is_keyed_by_every_file_the_kernel_compiles():
    """numba keys a cached function by its own file's content only (numba's documented
    cache limitation: "changes to functions called from other files are not detected"); a
    kernel entry point compiled with another module's code would be taken stale after that
    module changed. Every compiled function of the kernel carries the stamp of the whole
    set instead: the kernel's modules with compiled code and every module with jitable
    physics (found here by their decorators, not by the kernel's own text search)."""
    import ast
    import hashlib
    from pathlib import Path

    from numba.core.registry import CPUDispatcher

    package = Path(kernel.__file__).parent
    jitable_modules = {p.name for p in package.parent.glob("*.py")
                       if any(isinstance(d, ast.Name) and d.id == "jitable"
                              for node in ast.walk(ast.parse(p.read_text()))
                              if isinstance(node, ast.FunctionDef) for d in node.decorator_list)}
    assert {"fluid.py", "valves.py", "accumulator.py", "cylinder.py", "rod.py"} <= jitable_modules
    compiled_modules = [package / f"{m}.py" for m in ("equations", "integrated", "prescribed",
                                                      "trbdf2")]  # all but __init__
    files = compiled_modules + sorted(package.parent / n for n in jitable_modules)
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    compiled = [value for module in (kernel.equations, kernel.trbdf2, kernel.prescribed,
                                     kernel.integrated)
                for value in vars(module).values() if isinstance(value, CPUDispatcher)]
    assert len(compiled) > 20
    for function in compiled:
        assert function._cache._cache_file._source_stamp == digest.digest(), function
