"""Complex relative permeability, flux density and magnetisation, eqs 3-5 and 17-20.

Sign convention (eq 3): mu = mu' - j mu'', mu'' >= 0 for a lossy material, so
the flux density lags the applied field by the angle of eq 18.
"""
from __future__ import annotations

import math

from .constants import MU_0
from .errors import ParameterError


def amplitude_permeability(flux_density_amplitude, field_amplitude):
    """Modulus of the complex relative permeability |mu| = B_m / (mu_0 H_m), eq 19.

    Parameters
    ----------
    flux_density_amplitude : float
        B_m, [T].
    field_amplitude : float
        H_m, [A/m].

    Returns
    -------
    float
        sqrt(mu'^2 + mu''^2), [-].
    """
    return flux_density_amplitude / (MU_0 * field_amplitude)


def real_permeability(flux_density_amplitude, field_amplitude, mu_imag):
    """Real part mu' of the complex relative permeability, eq 20.

    Parameters
    ----------
    flux_density_amplitude : float
        B_m, [T].
    field_amplitude : float
        H_m, [A/m].
    mu_imag : float
        mu'', [-] (eq 16).

    Returns
    -------
    float
        mu', [-].

    Raises
    ------
    ParameterError
        When B_m / (mu_0 H_m) <= mu'': eq 20 would make mu' imaginary (or zero).
    """
    mod = amplitude_permeability(flux_density_amplitude, field_amplitude)
    if not mod > mu_imag:
        raise ParameterError(
            f"flux_density_amplitude = {flux_density_amplitude:g} T makes mu' "
            f"imaginary (eq 20): B_m/(mu_0 H_m) = {mod:g} must exceed "
            f"mu'' = {mu_imag:g} at H_m = {field_amplitude:g} A/m")
    return math.sqrt(mod * mod - mu_imag * mu_imag)


def lag_angle(mu_real, mu_imag):
    """Lag of B behind H, phi = arctan(mu'' / mu'), eq 18, [rad]."""
    return math.atan2(mu_imag, mu_real)


def flux_density(field, quadrature_field, mu_real, mu_imag):
    """Flux density B = mu_0 (mu' H + mu'' H_q), eqs 4 and 17.

    ``quadrature_field`` is the paper's H tan(w t): for the sinusoidal field
    H = H_m cos(w t) the model is defined for, H tan(w t) = H_m sin(w t), the
    field's quadrature part.

    Parameters
    ----------
    field : float or array
        In-phase applied field H, [A/m].
    quadrature_field : float or array
        Quadrature field H_q = H_m sin(w t), [A/m].
    mu_real, mu_imag : float
        mu', mu'', [-].

    Returns
    -------
    float or array
        B, [T].
    """
    return MU_0 * (mu_real * field + mu_imag * quadrature_field)


def magnetization(field, quadrature_field, mu_real, mu_imag):
    """Magnetisation due to the coil, M = B/mu_0 - H = H (mu' - 1) + mu'' H_q, eq 5.

    Parameters
    ----------
    field, quadrature_field : float or array
        H and H_q = H_m sin(w t), [A/m].
    mu_real, mu_imag : float
        mu', mu'', [-].

    Returns
    -------
    float or array
        M, [A/m].
    """
    return (mu_real - 1.0) * field + mu_imag * quadrature_field


def magnetization_phasor(mu_real, mu_imag):
    """Complex amplitude of M per unit H_m: m = (mu' - 1) - j mu'', eq 5.

    M(t) = H_m Re(m exp(j w t)) for H = H_m cos(w t).
    """
    return complex(mu_real - 1.0, -mu_imag)
