"""Datasets of runs as a lab records them, and their CSV form."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import lti
from .acquisition import Acquisition, record
from .constants import LabsimError, Transducer
from .effects import FORMULATIONS, EffectSet
from .transducer import DECAY_CONSTANTS, simulate

DEFAULT_FREQUENCIES = (5.0, 20.0, 50.0, 70.0, 80.0, 100.0, 150.0, 200.0)
DEFAULT_AMPLITUDES = (0.6, 1.0)
#: Parameters jittered per seed when ``jitter`` > 0 (relative standard deviation).
JITTERED = ("magnetostriction_coefficient", "bias_magnetization", "mass", "damping", "stiffness")
#: The displacement sensor's zero is drawn uniformly from +-this, once per dataset, [m].
SENSOR_OFFSET_RANGE = 20e-6


@dataclass(frozen=True)
class Run:
    """One recorded run (SI). ``displacement`` is relative: the sensor's arbitrary zero, no
    knowledge of the bias; ``sense_voltage`` is None without a sensing coil."""

    label: str
    frequency: float  # [Hz]
    current_amplitude: float  # nominal I_m, [A]
    time: np.ndarray  # from the first sample, [s]
    current: np.ndarray  # [A]
    displacement: np.ndarray  # [m]
    sense_voltage: np.ndarray | None  # [V]
    drive_phase: float  # phase of the drive current at its switch-on, [rad]
    record_start: float  # first sample, after the switch-on, [s]
    sample_rate: float  # [Hz]
    full_scale: dict = field(default_factory=dict)  # ADC ranges used (SI)
    saturated: dict = field(default_factory=dict)  # samples at the ADC's end codes, per channel

    @property
    def phase_at_start(self) -> float:
        """Phase of the drive current at the first sample, [rad]."""
        return (self.drive_phase + 2 * math.pi * self.frequency * self.record_start) % (2 * math.pi)


@dataclass(frozen=True)
class Dataset:
    """Runs plus the truth they were made from."""

    runs: list
    truth: dict

    def write_csv(self, path) -> Path:
        """Write the measured-data CSV (long form: run, frequency_Hz, time_s, current_A,
        displacement_um and, with a sensing coil, sense_voltage_V)."""
        path = Path(path)
        sense = all(r.sense_voltage is not None for r in self.runs)
        header = ["run", "frequency_Hz", "time_s", "current_A", "displacement_um"]
        if sense:
            header.append("sense_voltage_V")
        provenance = f"# seed = {self.truth['seed']}; effects = {self.truth['strengths'] or 'none'}"
        defaults = {name: next(iter(forms)) for name, forms in FORMULATIONS.items()}
        chosen = {name: form for name, form in self.truth.get("formulations", {}).items()
                  if form != defaults[name]}
        if chosen:
            provenance += f"; formulations = {chosen}"
        if self.truth["acquisition"].sense_air_flux and sense:
            provenance += "; the sense coil links the air flux (A_c - A_r) mu_0 H"
        lines = [
            "# synthetic lab measurements from labsim (independent generator, tests/labsim)",
            provenance,
            ",".join(header),
        ]
        for run in self.runs:
            cols = [run.time, run.current, run.displacement * 1e6]
            if sense:
                cols.append(run.sense_voltage)
            prefix = f"{run.label},{run.frequency:g},"
            body = np.column_stack(cols)
            lines.extend(prefix + ",".join(f"{v:.10g}" for v in row) for row in body)
        path.write_text("\n".join(lines) + "\n")
        return path


def make_dataset(
    effects=None,
    seed: int = 0,
    *,
    frequencies=DEFAULT_FREQUENCIES,
    amplitudes=DEFAULT_AMPLITUDES,
    samples_per_cycle: int | None = None,
    sample_rate: float | None = None,
    cycles: float = 6,
    low_frequency_cycles: float | None = None,
    start_in_transient: bool = False,
    noise_um: float = 0.05,
    noise_current_A: float = 1e-3,
    noise_voltage_V: float = 0.5e-3,
    sense_coil: bool = True,
    sense_air_flux: bool = False,
    adc_bits: int = 16,
    full_scale: dict | None = None,
    anti_alias_order: int = 4,
    anti_alias_cutoff: float | None = None,
    jitter: float = 0.0,
    transducer: Transducer | None = None,
    formulation: str = "default",
    formulations: dict | None = None,
) -> Dataset:
    """Make a dataset of runs (frequencies x amplitudes) with the given effects.

    Parameters
    ----------
    effects : dict {name: strength} or iterable of names (strength 1) or None
        Effects from ``EFFECTS`` or, outside the six causes, ``OUTSIDE_EFFECTS``; strength
        0 = absent, 1 = the reference magnitude.
    seed : int
        Controls everything random: drive phases, record starts, sensor offset, noise, jitter.
    samples_per_cycle, sample_rate : int, float
        Samples per drive period, or one fixed sample rate [Hz].
    cycles, low_frequency_cycles : float
        Record length in drive periods; runs below 10 Hz hold ``low_frequency_cycles``.
    start_in_transient : bool
        True: the record starts at the drive's switch-on. False: after all transients have
        decayed (>= 2 periods), at a random phase.
    noise_um, noise_current_A, noise_voltage_V : float
        Gaussian noise at the ADC input: displacement [um], current [A], sense voltage [V].
    sense_coil : bool
        Record the sensing-coil voltage (eq 21).
    sense_air_flux : bool
        The coil links the air flux around the rod too, E = -N_c d/dt [A_r B + (A_c - A_r)
        mu_0 H] (False: eq 21 with A_c).
    adc_bits, full_scale : int, dict
        ADC resolution and per-channel full scale (SI; missing channels auto-range).
    anti_alias_order, anti_alias_cutoff : int, float
        Butterworth order and cutoff [Hz] (default 0.2 x the sample rate).
    jitter : float
        Relative std of the per-seed jitter of K_lambda, M_b, m, c, K, B_m's scale (0: none).
    formulation : {"default", "alt"}
        Formulation of every effect: the first one, or the second one from other literature
        (``labsim.FORMULATIONS``; README.md).
    formulations : dict {name: formulation}, optional
        Per-effect choice, overriding ``formulation``: a name from ``FORMULATIONS[name]``
        (e.g. "general_preisach", "preisach_random", "slab_magnetization") or "default" /
        "alt".
    """
    effect_set = EffectSet.from_strengths(effects, formulation, formulations, seed)
    if samples_per_cycle is None and sample_rate is None:  # the default: 800 a period
        samples_per_cycle = 800
    settings = Acquisition(
        samples_per_cycle=samples_per_cycle, sample_rate=sample_rate, cycles=cycles,
        low_frequency_cycles=low_frequency_cycles, start_in_transient=start_in_transient,
        anti_alias_order=anti_alias_order, anti_alias_cutoff=anti_alias_cutoff,
        adc_bits=adc_bits, full_scale=dict(full_scale or {}), noise_displacement=noise_um * 1e-6,
        noise_current=noise_current_A, noise_voltage=noise_voltage_V, sense_coil=sense_coil,
        sense_air_flux=bool(sense_air_flux),
    )
    runs, offset, factors, device = _draw_runs(effect_set, settings, frequencies, amplitudes,
                                               seed, jitter, transducer)
    truth = {"seed": seed, "effects": effect_set.truth(),
             "strengths": {name: s for name, s in effect_set.strengths},
             "formulations": dict(effect_set.formulations), "sensor_offset_m": offset,
             "jitter_factors": factors, "transducer": device, "acquisition": settings}
    return Dataset(runs, truth)


def _draw_runs(effect_set, settings, frequencies, amplitudes, seed, jitter, transducer):
    """The runs of :func:`make_dataset` and what every run shares, drawn from ``seed``:
    (runs, the sensor's offset [m], the jitter factors, the jittered transducer)."""
    grid = _grid(frequencies, amplitudes)
    if not (math.isfinite(jitter) and 0.0 <= jitter <= 0.2):
        raise LabsimError(f"jitter = {jitter!r}: must be from 0 to 0.2")
    seeds = np.random.SeedSequence(seed).spawn(len(grid) + 1)
    common = np.random.default_rng(seeds[0])
    offset = common.uniform(-SENSOR_OFFSET_RANGE, SENSOR_OFFSET_RANGE)
    factors = {name: 1.0 + jitter * float(np.clip(common.standard_normal(), -3, 3))
               for name in JITTERED + ("bm_scale",)}
    device = (transducer or Transducer()).jittered(
        {k: v for k, v in factors.items() if k != "bm_scale"})
    # phases of the mains hum, from a stream of their own (the other draws stay the same)
    hum_rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1802,)))
    hum_phases = hum_rng.uniform(0.0, 2.0 * math.pi, len(grid))
    runs = [
        _run(device, f, amp, effect_set, settings, np.random.default_rng(s), offset,
             factors["bm_scale"], hum)
        for (f, amp), s, hum in zip(grid, seeds[1:], hum_phases)
    ]
    return runs, offset, factors, device


def _grid(frequencies, amplitudes):
    freqs = [float(f) for f in np.atleast_1d(frequencies)]
    amps = [float(a) for a in np.atleast_1d(amplitudes)]
    for f in freqs:
        if not (math.isfinite(f) and 0.1 <= f <= 2000.0):
            raise LabsimError(f"frequency = {f!r} Hz: must be from 0.1 to 2000 Hz")
    for a in amps:
        if not (math.isfinite(a) and 0.01 <= a <= 3.0):
            raise LabsimError(f"amplitude = {a!r} A: must be from 0.01 to 3 A")
    if not freqs or not amps:
        raise LabsimError("frequencies and amplitudes must not be empty")
    return [(f, a) for a in amps for f in freqs]


def _run(device, frequency, amplitude, effects, settings, rng, offset, bm_scale,
         hum_phase) -> Run:
    phase = rng.uniform(0.0, 2.0 * math.pi)
    period = 1.0 / frequency
    rate = settings.rate(frequency)
    anti_alias = settings.anti_alias(rate)
    continuous = simulate(device, frequency, amplitude, phase, effects,
                          transient=settings.start_in_transient, bm_scale=bm_scale)
    # whole periods until every transient has decayed, then a random fraction of one: the
    # phase at the first sample depends on the seed only, not on the effects
    filter_rate = lti.modal(anti_alias).slowest_rate
    settle = math.ceil(max(continuous.settle_time, DECAY_CONSTANTS / filter_rate) / period)
    if settings.start_in_transient:
        start = 0.0
    else:
        start = (settle + rng.uniform(0.0, 1.0)) * period
    count = int(round(settings.record_cycles(frequency) * rate / frequency))
    t = start + np.arange(count) / rate
    chain = (anti_alias, offset, settings, effects, hum_phase)
    signals = _channels(continuous, t, *chain)
    steady = signals if start > 0.0 else _channels(continuous, t + settle * period, *chain)
    recorded, ranges, clipped = {}, {}, {}
    for channel, values in signals.items():
        peak = float(np.max(np.abs(steady[channel])))
        recorded[channel], ranges[channel], clipped[channel] = record(
            values, channel, settings, rng, peak)
    return Run(
        label=f"{frequency:g}Hz_{amplitude:g}A",
        frequency=frequency,
        current_amplitude=amplitude,
        time=t - start,
        current=recorded["current"],
        displacement=recorded["displacement"],
        sense_voltage=recorded.get("sense_voltage"),
        drive_phase=phase,
        record_start=start,
        sample_rate=rate,
        full_scale=ranges,
        saturated=clipped,
    )


def _channels(continuous, t, anti_alias, offset, settings, effects, hum_phase) -> dict:
    """The filtered, noiseless channels at times t (SI; displacement with the sensor zero),
    with the effects outside the six (module ``outside``)."""
    y = continuous.displacement(t, anti_alias)
    backlash = effects.outside_effect("joint_backlash")
    if backlash is not None:  # the play's state: one period of motion before the record
        rate = settings.rate(continuous.frequency)
        lead = t[0] - np.arange(int(math.ceil(rate / continuous.frequency)), 0, -1) / rate
        moved = backlash.apply(np.concatenate([continuous.displacement(lead, anti_alias), y]))
        y = moved[lead.size:]
    signals = {
        "current": continuous.current_signal(t, anti_alias),
        "displacement": y + offset,
    }
    if settings.sense_coil:
        signals["sense_voltage"] = continuous.sense_voltage(t, anti_alias,
                                                            settings.sense_air_flux)
    hum = effects.outside_effect("mains_hum")
    if hum is not None:
        for channel in ("displacement", "sense_voltage"):
            if channel in signals:
                signals[channel] = signals[channel] + hum.signal(t, hum_phase, anti_alias,
                                                                 channel)
    return signals
