"""Magnetostriction about the bias and the magnetostrictive force, eqs 25 and 28.

K_lambda, the coefficient of eq 25 (eqs 24, 26), is Table 2's
``TransducerParameters.magnetostriction_coefficient``.
"""
from __future__ import annotations


def magnetostriction(magnetization, bias_magnetization, coefficient):
    """Strain about the permanent-magnet bias, lambda = K_lambda (M + M_b)^2, eq 25, [-].

    Parameters
    ----------
    magnetization : float or array
        Magnetisation due to the coil M (eq 5), [A/m].
    bias_magnetization : float
        M_b, [A/m].
    coefficient : float
        K_lambda, [m^2/A^2].

    Examples
    --------
    With no coil current the bias alone strains the rod by K_lambda M_b^2:

    >>> round(magnetostriction(0.0, 250e3, 1.4694e-14) * 1e6, 2)
    918.38
    """
    total = magnetization + bias_magnetization
    return coefficient * total * total


def magnetostrictive_force(strain, rod_area, youngs_modulus):
    """Blocked force of the rod F = A_r E^H lambda, eq 28, [N].

    Parameters
    ----------
    strain : float or array
        lambda, [-].
    rod_area : float
        A_r, [m^2].
    youngs_modulus : float
        E^H, [Pa].
    """
    return rod_area * youngs_modulus * strain
