"""The synthetic runs: noise, offsets and the recorded channels of each (f, I_m).

What is recorded and how the noise is drawn: the package docstring
(:mod:`smeha.synthetic`).
"""
from __future__ import annotations

import numpy as np

import gmt
from gmt.forward import bias_displacement
from gmt.sensing import induced_voltage

from ..measured import Run
from .response import true_response
from .truth import truth_parameters

__all__ = ["OFFSET_RANGE", "run_name", "generate_runs"]

#: Half-width of the random constant displacement offset per run, [m].
OFFSET_RANGE = 30e-6


def run_name(frequency, current_amplitude) -> str:
    """Run label, e.g. ``f050_I1.0``."""
    return f"f{int(round(frequency)):03d}_I{current_amplitude:.1f}"


def generate_runs(effect=None, *, seed=0, strength=1.0, noise_um=0.05, voltage_noise=0.01,
                  frequencies=(5, 20, 50, 100, 150, 200), amplitudes=(0.5, 1.0), cycles=8,
                  samples_per_cycle=256, params=None, current_noise=1e-3, jitter=0.2,
                  amplifier_gain=1.0) -> list[Run]:
    """Synthetic measured runs of the paper's model plus one hidden effect.

    Parameters
    ----------
    effect : str or None
        One of :data:`EFFECTS`, or ``None`` for the paper's model alone.
    seed : int
        Seeds the noise and offsets (``numpy.random.default_rng(seed)``) and,
        through a separate stream, the effect's jittered parameters.
    strength : float
        Size of the effect, >= 0: 0 is none (the paper's model exactly), 1
        clearly visible (see :func:`truth_parameters`).
    noise_um : float
        Standard deviation of the displacement noise, [um].
    voltage_noise : float
        Standard deviation of the sensing-coil voltage noise, [V].
    frequencies : sequence of float
        Excitation frequencies, [Hz] (each within the calibration's reach).
    amplitudes : sequence of float
        Current amplitudes I_m, [A].
    cycles : float
        Periods per run (cycles * samples_per_cycle samples).
    samples_per_cycle : int
        Samples per period.
    params : gmt.TransducerParameters, optional
        The transducer; default Table 2.
    current_noise : float
        Standard deviation of the current-measurement noise, [A].
    jitter : float
        Relative spread of the effect's parameters between seeds.
    amplifier_gain : float
        K_a, [A/V]: the control signal is u = i / K_a.

    Returns
    -------
    list of Run
        One per (f, I_m), frequency-major, named by :func:`run_name`;
        ``meta`` holds the truth: effect, strength, seed, the effect's
        parameters (``truth``), the offset, the noise levels, I_m.
    """
    p = params or gmt.TransducerParameters()
    truth = truth_parameters(effect, strength, seed=seed, jitter=jitter, params=p)
    if int(cycles * samples_per_cycle) < samples_per_cycle + 1 or samples_per_cycle < 8:
        raise gmt.ParameterError(f"cycles = {cycles!r}, samples_per_cycle = {samples_per_cycle!r}: "
                         "a run needs at least one period of at least 8 samples")
    rng = np.random.default_rng(seed)
    y_bias = bias_displacement(p)
    runs = []
    for f in frequencies:
        for im in amplitudes:
            r = true_response(effect, truth, p, f, im, cycles, samples_per_cycle)
            n = r["time"].size
            # draw in a fixed order, whatever the effect or noise levels
            offset = rng.uniform(-OFFSET_RANGE, OFFSET_RANGE)
            e_i = rng.standard_normal(n)
            e_y = rng.standard_normal(n)
            e_v = rng.standard_normal(n)
            voltage = induced_voltage(r["flux_density_rate"], p.sense_turns, p.sense_area)
            meta = {"effect": effect, "strength": float(strength), "seed": seed,
                    "truth": dict(truth), "offset": offset,
                    "current_amplitude": float(im),
                    "noise": {"displacement": noise_um * 1e-6, "sense_voltage": voltage_noise,
                              "current": current_noise},
                    "amplifier_gain": amplifier_gain}
            if "temperature_rise" in r:
                meta["final_temperature_rise"] = float(r["temperature_rise"][-1])
            runs.append(Run(
                name=run_name(f, im), frequency=float(f), time=r["time"],
                current=r["current"] + current_noise * e_i,
                displacement=r["displacement"] - y_bias + offset + noise_um * 1e-6 * e_y,
                sense_voltage=voltage + voltage_noise * e_v,
                control=r["current"] / amplifier_gain,
                source=f"synthetic(effect={effect!r}, seed={seed}, strength={strength:g})",
                meta=meta))
    return runs
