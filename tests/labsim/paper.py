"""The paper's magnetic model for a sinusoidal current, eqs 1-20 and 25-28.

For i = I_m cos(w t + phi0) the paper writes H = H_m cos(w t + phi0) (eq 1) and
B = mu_0 H_m [mu' cos + mu'' sin] (eqs 3-4, 17), i.e. B is the real part of the phasor
mu_0 (mu' - j mu'') H_m exp(j (w t + phi0)); M = B / mu_0 - H (eq 5). mu'' comes from the
loss separation (eq 16), mu' from B_m (eq 20). The strain is lambda = K_lambda (M + M_b)^2
(eq 25) and the force F = A_r E^H lambda (eq 28).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .bmlaw import flux_density_amplitude
from .constants import MU_0, LabsimError, Transducer


def field_amplitude(transducer: Transducer, current_amplitude: float) -> float:
    """H_m = N I_m / (k_f L), eq 1, [A/m]."""
    t = transducer
    return t.coil_turns * current_amplitude / (t.leakage_coefficient * t.rod_length)


def mu_imag(transducer: Transducer, flux_amplitude: float, field_amp: float, frequency: float):
    """mu'' from the loss separation at intermediate fields, eq 16, [-]."""
    t = transducer
    loss = (
        t.hysteresis_coefficient * flux_amplitude**t.steinmetz_exponent
        + t.eddy_coefficient * flux_amplitude**2 * frequency
        + t.excess_coefficient * flux_amplitude**1.5 * frequency**0.5
    )
    return loss / (math.pi * MU_0 * field_amp**2)


@dataclass(frozen=True)
class Permeability:
    """Complex relative permeability mu' - j mu'' of one run (eqs 16, 19, 20)."""

    real: float
    imag: float
    flux_amplitude: float  # B_m, [T]
    field_amplitude: float  # H_m, [A/m]

    @property
    def complex(self) -> complex:
        """mu' - j mu'' (eq 3), [-]."""
        return complex(self.real, -self.imag)


def permeability(
    transducer: Transducer, frequency: float, current_amplitude: float, bm_scale: float = 1.0
) -> Permeability:
    """mu', mu'' at (f, I_m) with B_m from this generator's law (``bmlaw``)."""
    h_m = field_amplitude(transducer, current_amplitude)
    b_m = float(flux_density_amplitude(frequency, h_m, bm_scale))
    imag = mu_imag(transducer, b_m, h_m, frequency)
    modulus = b_m / (MU_0 * h_m)
    if imag >= modulus:
        raise LabsimError(
            f"frequency = {frequency} Hz, current amplitude = {current_amplitude} A: eq 16 gives "
            f"mu'' = {imag:.3f} above |mu| = {modulus:.3f}, so eq 20 has no real mu'; "
            "the paper's model is not defined there (use lower frequencies)"
        )
    return Permeability(math.sqrt(modulus**2 - imag**2), imag, b_m, h_m)
