"""The flow study's table by the periodic-steady-state fast path (issue 6).

:mod:`smeha.flowstudy` time-steps eight cycles of the co-simulation for each
case and averages the last whole ones. Here each case's periodic steady state
is solved directly by :func:`system_models.periodic.periodic_steady_state`,
with the transducer (gmt, in-process) and the circuit on the displacement
port's discrete equations on a grid of :data:`system_models.periodic.GRID_STEP`:
a case in 0.1-0.2 s. The rows have the flow study's keys where they apply, so
:func:`smeha.flowstudy.format_table` and
:func:`~smeha.flowstudy.format_load_lines` print them unchanged
(``backend`` "fastpath", ``coupling`` "periodic").

Differences from the time-stepped rows (``benchmarks/flow_fastpath.py``):

* The piston stays at mid-stroke and the accumulator's charge does not drift.
  The time-stepped averaging window sits ~4.5 cycles later, with p_A 1-3 kPa
  lower.
* The valves switch on the grid (a controller sampling at the grid step,
  dead times rounded up to whole steps), the co-simulation's every 10 us with
  exact dead times. At a frequency whose period is not a whole number of
  steps the grid is stretched to one (70 Hz at 20 us: 714 steps of 20.008 us);
  ``sampling_phases`` > 1 averages grids offset by fractions of a step.
* The digital compensator samples on the grid, every round(T_c / h) steps;
  where T_c does not divide the period (70 Hz at 10 kHz) the last of a few
  settling periods is taken as the periodic one.
* There are no values for keys that need a whole run
  (``volume_imbalance_m3``, ``volume_pumped_m3``, ``cycles_averaged``).

Only the paper's transducer model is solved. A model variant
(:class:`gmt.ModelVariant`) needs the time-stepped study.
"""
from __future__ import annotations

import time
from numbers import Real

import numpy as np

import gmt
from gmt.parameters import COMPENSATOR_PERIOD
from system_models import presets
from system_models.periodic import (GRID_STEP, PeriodicSettings, grid, periodic_steady_state,
                                    rod_periodic_response)

from .flowstudy import (CURRENT_AMPLITUDE, MODES, control_signal, flag_row, paper_dy,
                        rod_lag_degrees)

#: The study's frequencies, [Hz] (Table 3).
FREQUENCIES = (50.0, 70.0, 80.0, 100.0)


def fast_case(frequency: float, mode: str, circuit: str = "realistic",
              load: float | None = None, step: float = GRID_STEP,
              branch_rule: str = "control", sampling_phases: int = 1,
              compensator_period: float = COMPENSATOR_PERIOD) -> tuple[list, dict]:
    """One case of the flow study by the fast path.

    Parameters
    ----------
    frequency : float
        f, [Hz].
    mode : {"uncompensated", "compensated"}
    circuit : str
        A name of :data:`system_models.presets.CIRCUITS`.
    load : float, optional
        Load on the cylinder, [N]; None: the circuit's
        (:func:`system_models.presets.default_load`).
    step : float
        Grid step, [s].
    branch_rule : {"control", "demand"}
        The compensator's root rule (:class:`gmt.DriveParameters`).
    sampling_phases : int
        Number of grids, offset by k / sampling_phases of a step, whose
        results are averaged (module docstring); 1: the grid aligned with
        the control signal's maximum at t = 0.
    compensator_period : float
        The digital compensator's sample period, [s].

    Returns
    -------
    (list of PeriodicSolution, dict)
        The solutions, one per sampling phase, and the row.
    """
    if mode not in MODES:
        raise gmt.ParameterError(f"mode = {mode!r} is not one of {MODES}")
    if not (isinstance(sampling_phases, int) and sampling_phases >= 1):
        raise gmt.ParameterError(
            f"sampling_phases = {sampling_phases!r} is outside the allowed range [1, inf)")
    frequency = float(frequency)
    load_force = float(load) if load is not None else presets.default_load(circuit)
    plant = presets.circuit(circuit)
    area = plant.chamber.piston_area
    drive = gmt.DriveParameters(compensated=mode == "compensated", branch_rule=branch_rule,
                                compensator_period=compensator_period)
    unit = gmt.Transducer(gmt.TransducerParameters(),
                          gmt.Excitation(frequency, CURRENT_AMPLITUDE), drive)
    control, amplitude = control_signal(mode, frequency)
    settings = PeriodicSettings(step=step, load_force=load_force)
    wall = time.perf_counter()
    n, h = grid(frequency, step)
    solutions = []
    for k in range(sampling_phases):
        offset = k * h / sampling_phases
        shifted = control if k == 0 else (lambda t, o=offset: control(t + o))
        solutions.append(periodic_steady_state(unit, shifted, frequency, plant, settings))
    dy_free = _free_dy(solutions[0].magnetostrictive_force, unit.params, h)
    wall = time.perf_counter() - wall
    flow = float(np.mean([s.flow for s in solutions]))
    dy = float(np.mean([s.dy for s in solutions]))
    flow_eq = frequency * area * dy
    paper = paper_dy(frequency, mode)
    first = solutions[0]
    row = {
        "frequency_Hz": frequency, "mode": mode, "model": "paper",
        "circuit": circuit, "load_N": load_force,
        "flow_sim_m3_s": flow, "flow_eq_m3_s": flow_eq, "flow_ratio": flow / flow_eq,
        "dy_um": dy * 1e6, "flow_sim_L_min": flow * 6e4,
        "flow_paper_m3_s": None if paper is None else frequency * area * paper,
        "dy_paper_um": None if paper is None else paper * 1e6,
        "dy_free_um": dy_free * 1e6,
        "flow_free_m3_s": frequency * area * dy_free,
        "delivered_fraction": flow / (frequency * area * dy_free),
        "control_amplitude_V": amplitude,
        "load_pressure_Pa": float(np.mean([np.mean(s.p_big - s.p_small) for s in solutions])),
        "p_pump_min_Pa": float(min(s.p_pump.min() for s in solutions)),
        "p_pump_max_Pa": float(max(s.p_pump.max() for s in solutions)),
        "p_accumulator_Pa": float(np.mean([np.mean(s.p_accumulator) for s in solutions])),
        "step_s": step, "grid_step_s": h, "sampling_phases": sampling_phases,
        "newton_iterations": int(sum(s.iterations for s in solutions)),
        "coupling": "periodic", "backend": "fastpath", "wall_s": wall,
    }
    lag = rod_lag_degrees(first.time, first.control, first.rod_displacement, frequency)
    flag_row(row, lag, max(v.opening_time if v.response == "delay" else 0.0
                           for v in plant.valves))
    return solutions, row


def _free_dy(force, params: gmt.TransducerParameters, h: float) -> float:
    """dy of the transducer alone between the control's extremes (t = 0 and T/2), [m].

    The free response to the magnetostrictive force of the same sampled drive
    (``force``, [N], held over each step of h [s]): the harmonic balance of
    :func:`system_models.periodic.rod_periodic_response` with no chamber
    force, read at T/2 by its trigonometric interpolation (T/2 is a grid
    point only for an even N). It is :func:`smeha.flowstudy.free_dy` on the
    fast path's grid: equal to it uncompensated, and within 0.15 %
    compensated, which flowstudy samples more finely.
    """
    n = force.size
    y, _ = rod_periodic_response(force, params, h)
    harmonics = np.fft.fft(y) / n
    k = np.fft.fftfreq(n) * n
    half_period = float(np.real(np.sum(harmonics * np.exp(1j * np.pi * k))))
    return float(y[0] - half_period)


def flow_table(frequencies=FREQUENCIES, modes=MODES, circuit: str = "realistic", load=None,
               step: float = GRID_STEP, branch_rule: str = "control",
               sampling_phases: int = 1,
               compensator_period: float = COMPENSATOR_PERIOD) -> list[dict]:
    """The flow study's table by the fast path: one row per frequency, mode and load.

    Parameters
    ----------
    frequencies : sequence of float
        [Hz].
    modes : sequence of {"uncompensated", "compensated"}
    circuit : str
        A name of :data:`system_models.presets.CIRCUITS`.
    load : float, sequence of float, or None
        Load(s) on the cylinder, [N] (several trace load lines); None: the
        circuit's.
    step, branch_rule, sampling_phases, compensator_period
        As :func:`fast_case`.

    Returns
    -------
    list of dict
        Rows in the order frequency, mode, load, with the keys of
        :func:`smeha.flowstudy.run_case`'s rows where they apply, plus
        ``p_accumulator_Pa``, ``grid_step_s``, ``sampling_phases`` and
        ``newton_iterations``; ``backend`` is ``"fastpath"``.

    Examples
    --------
    >>> rows = flow_table([100.0], ["uncompensated"], circuit="ideal")
    >>> round(rows[0]["flow_ratio"], 2)
    1.0
    """
    loads = [load] if load is None or isinstance(load, Real) else list(load)
    return [fast_case(f, mode, circuit, ld, step, branch_rule, sampling_phases,
                      compensator_period)[1]
            for f in frequencies for mode in modes for ld in loads]
