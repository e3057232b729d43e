"""Amplitude of the flux density B_m(f, I_m): this generator's own smooth law.

The paper's model takes B_m as an input measured by the sensing coil (eq 22, Table 1). To
make data at any (f, I_m), labsim needs B_m from a law. It uses an amplitude permeability

    |mu|(f, H_m) = (mu_i + eta H_m) * | rho + (1 - rho) / (1 + j f / f_r) |,
    B_m = mu_0 |mu| H_m,                                    H_m = N I_m / (k_f L)  (eq 1)

* the first factor is Rayleigh's law for the amplitude permeability at low and intermediate
  fields (Rayleigh 1887; Chikazumi, Physics of Ferromagnetism, 2nd ed., 1997, sec. 18.2:
  mu_a = mu_i + eta H_m);
* the second is a single Debye relaxation of the wall-motion permeability: the part
  (1 - rho) of the low-frequency permeability relaxes above f_r, the part rho (rotation)
  does not (Chikazumi, ch. 20; Smit and Wijn, Ferrites, 1959, ch. 12 on relaxation spectra).

Only the modulus is used (B_m is an amplitude); the lag of B behind H comes from the paper's
loss separation (eq 16) as in the paper. The four constants were fitted once to Table 1
(see ``constants``); they are not an interpolation of it.
"""
from __future__ import annotations

import numpy as np

from .constants import (
    MU_0,
    RAYLEIGH_INITIAL,
    RAYLEIGH_SLOPE,
    RELAXATION_FREQUENCY,
    RELAXED_FRACTION,
)


def amplitude_permeability(frequency, field_amplitude, scale: float = 1.0):
    """Relative amplitude permeability |mu| = B_m / (mu_0 H_m), [-].

    Parameters
    ----------
    frequency : float or array
        Excitation frequency f, [Hz].
    field_amplitude : float or array
        Applied field amplitude H_m, [A/m].
    scale : float
        Multiplies the law (per-seed jitter of the material), [-].
    """
    frequency = np.asarray(frequency, dtype=float)
    field_amplitude = np.asarray(field_amplitude, dtype=float)
    rayleigh = RAYLEIGH_INITIAL + RAYLEIGH_SLOPE * field_amplitude
    relaxation = RELAXED_FRACTION + (1.0 - RELAXED_FRACTION) / (
        1.0 + 1j * frequency / RELAXATION_FREQUENCY
    )
    return scale * rayleigh * np.abs(relaxation)


def flux_density_amplitude(frequency, field_amplitude, scale: float = 1.0):
    """B_m = mu_0 |mu| H_m, [T].

    >>> round(float(flux_density_amplitude(50.0, 1300 * 1.0 / (1.1 * 0.08))), 4)
    0.0644
    """
    return MU_0 * amplitude_permeability(frequency, field_amplitude, scale) * field_amplitude
