"""Truth of ``thermal_drift``: coil heating i^2 R(T) through a first-order thermal model.

The temperature rise changes K_lambda and offsets the displacement sensor (G. Engdahl
(ed.), *Handbook of Giant Magnetostrictive Materials*, Academic Press 2000; A. E. Clark,
in Ferromagnetic Materials vol. 1, North-Holland 1980, for K_lambda(T)).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["temperature_rise"]

def temperature_rise(time, current_amplitude, frequency, truth):
    """Coil temperature rise Delta T(t), [K], from a first-order thermal model.

        tau dDT/dt = R_th i(t)^2 R_0 (1 + alpha_R DT) - DT,  DT(0) = 0,

    (tau = R_th C_th) with i = I_m cos(w t), the true current: the coil's Joule
    heat with a copper resistance rising with temperature, lost to the ambient
    through R_th. The equation is linear in DT, dDT/dt = a(t) DT + b(t), so

        DT(t) = int_0^t exp(Phi(t) - Phi(s)) b(s) ds,  Phi(t) = int_0^t a,

    with Phi in closed form (cos^2 = (1 + cos 2wt)/2) and the outer integral by
    the trapezoid rule on a grid four times finer than the samples (relative
    error ~ (w h / 4)^2 / 12, 4e-6 at 256 samples a period). Each run starts
    at the ambient temperature.
    """
    t = np.asarray(time, dtype=float)
    r_th = truth["thermal_resistance"]
    if r_th == 0.0:
        return np.zeros_like(t)
    tau = truth["thermal_time_constant"]
    r0, alpha = truth["coil_resistance"], truth["resistance_coefficient"]
    w = 2.0 * math.pi * frequency
    c = r_th * r0 * current_amplitude ** 2 / tau  # heating rate per cos^2, [K/s]
    fine = 4
    tf = np.linspace(t[0], t[-1], fine * (t.size - 1) + 1)
    cos2 = np.cos(w * tf) ** 2
    phi = alpha * c * (0.5 * (tf - t[0]) + (np.sin(2 * w * tf) - np.sin(2 * w * t[0])) / (4 * w)) \
        - (tf - t[0]) / tau
    g = np.exp(-phi) * c * cos2
    integral = np.concatenate(([0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(tf))))
    return (np.exp(phi) * integral)[::fine]
