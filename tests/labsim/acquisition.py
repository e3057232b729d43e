"""How the lab records a run: sample clock, anti-alias filter, noise, ADC.

* Sample clock: either a fixed number of samples per cycle (the digitiser's rate set per run
  to ``samples_per_cycle * f``) or one fixed sample rate for every run.
* Anti-alias filter: an analog Butterworth low-pass of order ``anti_alias_order`` (default
  4), the same on every channel, cutoff ``anti_alias_cutoff`` (default 0.2 x the sample
  rate, so -32 dB at the Nyquist frequency for order 4). It acts on the continuous signals
  exactly (``lti``/``waveform``), transients included.
* Noise: independent Gaussian samples added at the ADC input (sensor and amplifier noise,
  already band-limited by the filter): 0.05 um on the displacement, 1 mA on the current,
  0.5 mV on the sense voltage by default.
* ADC: ``adc_bits`` (16) bits, bipolar, mid-tread rounding, full scale +-FS per channel; FS
  either given per channel or, by default, chosen per run like an oscilloscope's range: the
  smallest value of the 1-2-5 series at least 1.1 x the channel's peak (signal + 5 sigma).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import lti
from .constants import LabsimError

CHANNELS = ("current", "displacement", "sense_voltage")


@dataclass(frozen=True)
class Acquisition:
    """Recording settings (SI). See the module docstring for the defaults' meaning."""

    samples_per_cycle: int | None = None
    sample_rate: float | None = None
    cycles: float = 6
    low_frequency_cycles: float | None = None
    low_frequency_limit: float = 10.0  # runs below this frequency hold low_frequency_cycles, [Hz]
    start_in_transient: bool = False
    anti_alias_order: int = 4
    anti_alias_cutoff: float | None = None  # [Hz]; None: 0.2 x sample rate
    adc_bits: int = 16
    full_scale: dict = field(default_factory=dict)  # channel -> FS (SI); missing: auto-range
    noise_displacement: float = 0.05e-6  # [m]
    noise_current: float = 1e-3  # [A]
    noise_voltage: float = 0.5e-3  # [V]
    sense_coil: bool = True
    sense_air_flux: bool = False  # the sense coil links the air flux too (README.md)

    def __post_init__(self) -> None:
        spc, rate = self.samples_per_cycle, self.sample_rate
        if spc is not None and rate is not None:
            raise LabsimError("give samples_per_cycle or sample_rate, not both")
        if spc is not None and not (isinstance(spc, (int, np.integer)) and 8 <= spc <= 100_000):
            raise LabsimError(f"samples_per_cycle = {spc!r}: must be an integer from 8 to 100000")
        if rate is not None and not (math.isfinite(rate) and 100.0 <= rate <= 10e6):
            raise LabsimError(f"sample_rate = {rate!r} Hz: must be from 100 Hz to 10 MHz")
        for name in ("cycles", "low_frequency_cycles"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and 1.0 <= value <= 10_000):
                raise LabsimError(f"{name} = {value!r}: must be from 1 to 10000")
        if not (isinstance(self.adc_bits, (int, np.integer)) and 4 <= self.adc_bits <= 32):
            raise LabsimError(f"adc_bits = {self.adc_bits!r}: must be an integer from 4 to 32")
        for name in ("noise_displacement", "noise_current", "noise_voltage"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise LabsimError(f"{name} = {value!r}: must be finite and >= 0")
        for channel, value in self.full_scale.items():
            if channel not in CHANNELS or not (math.isfinite(value) and value > 0):
                raise LabsimError(
                    f"full_scale[{channel!r}] = {value!r}: channel must be one of "
                    f"{', '.join(CHANNELS)} and FS > 0"
                )

    def rate(self, frequency: float) -> float:
        """Sample rate of a run at this frequency, [Hz]."""
        if self.sample_rate is not None:
            return float(self.sample_rate)
        if self.samples_per_cycle is None:
            raise LabsimError("give samples_per_cycle or sample_rate")
        return self.samples_per_cycle * frequency

    def record_cycles(self, frequency: float) -> float:
        """Number of drive periods the record spans."""
        if self.low_frequency_cycles is not None and frequency < self.low_frequency_limit:
            return self.low_frequency_cycles
        return self.cycles

    def anti_alias(self, rate: float) -> lti.Zpk:
        """The anti-alias filter at this sample rate."""
        cutoff = 0.2 * rate if self.anti_alias_cutoff is None else self.anti_alias_cutoff
        if cutoff >= rate / 2:
            raise LabsimError(
                f"anti_alias_cutoff = {cutoff} Hz: must be below the Nyquist frequency "
                f"{rate / 2} Hz"
            )
        return lti.butterworth(self.anti_alias_order, cutoff)

    def noise(self, channel: str) -> float:
        """Noise standard deviation of a channel (SI)."""
        return {
            "current": self.noise_current,
            "displacement": self.noise_displacement,
            "sense_voltage": self.noise_voltage,
        }[channel]


def auto_range(peak: float) -> float:
    """Smallest full scale of the 1-2-5 series >= 1.1 x peak."""
    need = max(1.1 * peak, 1e-12)
    decade = 10.0 ** math.floor(math.log10(need))
    for mantissa in (1.0, 2.0, 5.0, 10.0):
        if mantissa * decade >= need * (1 - 1e-12):
            return mantissa * decade
    return 10.0 * decade


def digitise(values: np.ndarray, full_scale: float, bits: int) -> tuple[np.ndarray, int]:
    """Bipolar mid-tread ADC: multiples of 2 FS / 2^bits, codes -2^(b-1) .. 2^(b-1) - 1;
    values beyond the range saturate at the end codes, as a real converter's do.
    Returns the samples and the number of saturated ones."""
    step = 2.0 * full_scale / 2**bits
    codes = np.round(values / step)
    low, high = -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    clipped = int(np.count_nonzero((codes < low) | (codes > high)))
    return np.clip(codes, low, high) * step, clipped


def record(signal: np.ndarray, channel: str, settings: Acquisition, rng,
           steady_peak: float) -> tuple[np.ndarray, float, int]:
    """Add noise and digitise one channel; returns (samples, full scale, saturated samples).

    ``steady_peak`` is the channel's peak once the transients are over: auto-ranging uses it
    (an operator sets the range on the running signal), so a switch-on spike of the sense
    voltage may saturate the converter for a few samples of a record started in the transient.
    A given full scale below the steady peak is refused.
    """
    sigma = settings.noise(channel)
    noisy = signal + sigma * rng.standard_normal(signal.size) if sigma > 0 else signal
    fs = settings.full_scale.get(channel)
    if fs is None:
        fs = auto_range(steady_peak + 5.0 * sigma)
    elif steady_peak > fs:
        raise LabsimError(
            f"full_scale[{channel!r}] = {fs:.4g} (SI) is below the signal's peak "
            f"{steady_peak:.4g}; raise it or leave the channel to auto-range"
        )
    samples, clipped = digitise(noisy, fs, settings.adc_bits)
    return samples, fs, clipped
