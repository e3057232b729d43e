"""Loss separation and the imaginary permeability, eqs 6-16.

Each loss is returned as a power, [W], for the whole rod volume V. The loss
coefficients are those of Table 2.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .constants import MU_0
from .errors import ParameterError


def hysteresis_loss_low_field(coefficient, field_amplitude, frequency, volume):
    """Rayleigh-region hysteresis loss P_h = K'_h H_m^3 f V, eq 6, [W].

    Parameters
    ----------
    coefficient : float
        K'_h, [W s/(m^3 (A/m)^3)].
    field_amplitude : float
        H_m, [A/m].
    frequency : float
        f, [Hz].
    volume : float
        V, [m^3].
    """
    return coefficient * field_amplitude ** 3 * frequency * volume


def hysteresis_loss(coefficient, exponent, flux_density_amplitude, frequency, volume):
    """Intermediate-field hysteresis loss P_h = K_h B_m^n f V, eq 7, [W].

    Parameters
    ----------
    coefficient : float
        K_h, [W s/(m^3 T^n)].
    exponent : float
        Steinmetz exponent n, [-].
    flux_density_amplitude : float
        B_m, [T].
    frequency : float
        f, [Hz].
    volume : float
        V, [m^3].
    """
    return coefficient * flux_density_amplitude ** exponent * frequency * volume


def eddy_current_loss(coefficient, flux_density_amplitude, frequency, volume):
    """Classical eddy-current loss P_eddy = K_e (B_m f)^2 V, eqs 8-9, [W]."""
    return coefficient * (flux_density_amplitude * frequency) ** 2 * volume


def excess_loss(coefficient, flux_density_amplitude, frequency, volume):
    """Excess (anomalous) loss P_ex = K_ex (B_m f)^1.5 V, eqs 10-11, [W]."""
    return coefficient * (flux_density_amplitude * frequency) ** 1.5 * volume


def loss_power_from_permeability(mu_imag, field_amplitude, frequency, volume):
    """Loss from the loop area, P = pi f mu_0 mu'' H_m^2 V, eq 13, [W]."""
    return math.pi * frequency * MU_0 * mu_imag * field_amplitude ** 2 * volume


def imaginary_permeability(total_loss, field_amplitude, frequency, volume):
    """mu'' = P_loss / (pi f mu_0 H_m^2 V), eq 14, [-]."""
    return total_loss / (math.pi * frequency * MU_0 * field_amplitude ** 2 * volume)


@dataclass(frozen=True)
class LossBreakdown:
    """The separated losses at one operating point, [W] (eq 12)."""

    hysteresis: float
    eddy: float
    excess: float

    @property
    def total(self) -> float:
        """P_loss = P_h + P_eddy + P_ex, eq 12, [W]."""
        return self.hysteresis + self.eddy + self.excess


def separate_losses(params, frequency, field_amplitude, flux_density_amplitude,
                    regime="intermediate"):
    """Loss separation at one operating point, eq 12 with eq 6 or eq 7.

    Parameters
    ----------
    params : TransducerParameters
        Loss coefficients and rod volume.
    frequency : float
        f, [Hz].
    field_amplitude : float
        H_m, [A/m].
    flux_density_amplitude : float
        B_m, [T].
    regime : {"intermediate", "low"}
        Hysteresis law: eq 7 (intermediate fields, the paper's choice with a
        permanent-magnet bias) or eq 6 (Rayleigh region, needs
        ``low_field_hysteresis_coefficient``).

    Returns
    -------
    LossBreakdown
    """
    V = params.rod_volume
    if regime == "intermediate":
        ph = hysteresis_loss(params.hysteresis_coefficient, params.steinmetz_exponent,
                             flux_density_amplitude, frequency, V)
    elif regime == "low":
        if params.low_field_hysteresis_coefficient <= 0.0:
            raise ParameterError(
                "low_field_hysteresis_coefficient = 0 (not identified): the "
                "low-field regime (eqs 6, 15) needs K'_h > 0")
        ph = hysteresis_loss_low_field(params.low_field_hysteresis_coefficient,
                                       field_amplitude, frequency, V)
    else:
        raise ParameterError(f"regime = {regime!r} is not one of 'intermediate', 'low'")
    pe = eddy_current_loss(params.eddy_coefficient, flux_density_amplitude, frequency, V)
    px = excess_loss(params.excess_coefficient, flux_density_amplitude, frequency, V)
    return LossBreakdown(hysteresis=ph, eddy=pe, excess=px)
