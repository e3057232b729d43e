"""Applied magnetic field of the excitation coil, eqs 1-2."""
from __future__ import annotations


def applied_field(current, coil_turns, leakage_coefficient, rod_length):
    """Applied field H = N i / (k_f L), eq 1.

    Parameters
    ----------
    current : float or array
        Coil current i, [A].
    coil_turns : float
        N, [-].
    leakage_coefficient : float
        k_f, [-].
    rod_length : float
        L, [m].

    Returns
    -------
    float or array
        H, [A/m].

    Examples
    --------
    >>> round(applied_field(1.0, 1300, 1.1, 0.08), 1)
    14772.7
    """
    return coil_turns * current / (leakage_coefficient * rod_length)
