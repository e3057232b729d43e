"""Sensing coil: flux density from the induced voltage, eqs 21-22."""
from __future__ import annotations

import math

import numpy as np


def induced_voltage(flux_density_rate, sense_turns, sense_area):
    """Sensing-coil voltage E = -N_c A_c dB/dt, eq 21, [V].

    Parameters
    ----------
    flux_density_rate : float or array
        dB/dt, [T/s].
    sense_turns : float
        N_c, [-].
    sense_area : float
        A_c, [m^2].
    """
    return -sense_turns * sense_area * flux_density_rate


def flux_density_amplitude_from_voltage(voltage_amplitude, frequency, sense_turns,
                                        sense_area):
    """B_m = E_m / (w N_c A_c), eq 22, [T].

    Parameters
    ----------
    voltage_amplitude : float
        E_m, [V].
    frequency : float
        f, [Hz].
    sense_turns : float
        N_c, [-].
    sense_area : float
        A_c, [m^2].

    Examples
    --------
    Table 1, 50 Hz: E_m = 1.14 V gives B_m = 0.0637 T.

    >>> round(flux_density_amplitude_from_voltage(1.14, 50.0, 150, 380e-6), 4)
    0.0637
    """
    return voltage_amplitude / (2.0 * math.pi * frequency * sense_turns * sense_area)


def flux_density_from_voltage(time, voltage, sense_turns, sense_area):
    """Flux density waveform by integrating eq 21, mean removed, [T].

    The integration constant of eq 21 is unknown (the bias flux is invisible
    to the coil), so the result is the alternating part of B only.

    Parameters
    ----------
    time : array
        Sample times, [s], increasing.
    voltage : array
        Sensing-coil voltage E, [V].
    sense_turns, sense_area : float
        N_c [-], A_c [m^2].

    Returns
    -------
    array
        B(t) minus its mean, [T].
    """
    t = np.asarray(time, dtype=float)
    e = np.asarray(voltage, dtype=float)
    increments = 0.5 * (e[1:] + e[:-1]) * np.diff(t)
    b = -np.concatenate(([0.0], np.cumsum(increments))) / (sense_turns * sense_area)
    return b - b.mean()
