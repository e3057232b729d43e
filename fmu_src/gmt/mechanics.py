"""Mass-spring-damper of the transducer, eqs 27 and 29, through python-control.

The rod, output rod and prestress spring act on the load as one degree of
freedom, m y'' + c y' + K y = F - F_ext (eq 27 with an external axial force
F_ext on the output rod, e.g. pump-chamber pressure times piston area).

With Table 2 values the system is over-damped (zeta = 2.35) with poles at
about -7.0e3 and -1.40e5 rad/s. Explicit Euler would need steps below
~14 us to stay stable; the time-stepping model uses the exact zero-order-hold
(ZOH) discretisation instead, which is stable for any step.
"""
from __future__ import annotations

import math
from functools import lru_cache

import control
import numpy as np


def transfer_function(mass, damping, stiffness):
    """Eq 29: displacement per unit force, Y(s)/F(s) = 1 / (m s^2 + c s + K), [m/N].

    Multiply by the blocked force A_r E^H lambda (eq 28) to get eq 29 itself.

    Returns
    -------
    control.TransferFunction
    """
    return control.tf([1.0], [mass, damping, stiffness])


def state_space(mass, damping, stiffness):
    """Eq 27 in state-space form with physical states x = [y, v].

    Input: net force F - F_ext [N]. Outputs: displacement y [m] and velocity
    v [m/s].

    Returns
    -------
    control.StateSpace
    """
    a = [[0.0, 1.0], [-stiffness / mass, -damping / mass]]
    b = [[0.0], [1.0 / mass]]
    c = [[1.0, 0.0], [0.0, 1.0]]
    d = [[0.0], [0.0]]
    return control.ss(a, b, c, d)


@lru_cache(maxsize=256)
def _zoh_cached(mass, damping, stiffness, step):
    sysd = control.sample_system(state_space(mass, damping, stiffness), step,
                                 method="zoh")
    ad = np.array(sysd.A, dtype=float)
    bd = np.array(sysd.B, dtype=float).ravel()
    return (float(ad[0, 0]), float(ad[0, 1]), float(ad[1, 0]), float(ad[1, 1]),
            float(bd[0]), float(bd[1]))


def zoh_matrices(mass, damping, stiffness, step):
    """Exact ZOH discretisation of eq 27 for one step, via python-control.

    x[k+1] = A_d x[k] + B_d F[k], with F held constant over the step.

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    step : float
        Step h, [s], > 0.

    Returns
    -------
    tuple of float
        (a11, a12, a21, a22, b1, b2); cached per (m, c, K, h), so a fixed
        step costs one discretisation.
    """
    return _zoh_cached(float(mass), float(damping), float(stiffness), float(step))


def discrete_system(mass, damping, stiffness, step):
    """The ZOH-discretised eq 27 as a python-control system (outputs y, v)."""
    return control.sample_system(state_space(mass, damping, stiffness), step,
                                 method="zoh")


def frequency_response(mass, damping, stiffness, angular_frequency, step=None):
    """Complex response of y and v to a sinusoidal force, per newton.

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    angular_frequency : float or array
        w, [rad/s]; 0 gives the static compliance 1/K.
    step : float, optional
        If given, the response of the ZOH-discretised system at its samples,
        G_d(exp(j w h)), rather than the continuous G(j w).

    Returns
    -------
    (array, array)
        Y/F [m/N] and V/F [m/(N s)], complex.
    """
    w = np.atleast_1d(np.asarray(angular_frequency, dtype=float))
    sys = state_space(mass, damping, stiffness)
    if step is not None:
        sys = control.sample_system(sys, step, method="zoh")
    resp = sys(np.exp(1j * w * step) if step is not None else 1j * w)
    resp = np.asarray(resp).reshape(2, 1, -1)
    return resp[0, 0], resp[1, 0]


def phase_lag(mass, damping, stiffness, frequency):
    """Lag of displacement behind force, -arg G(j 2 pi f), [rad] (eq 29)."""
    gy, _ = frequency_response(mass, damping, stiffness, 2 * math.pi * frequency)
    return float(-np.angle(gy[0]))


def poles(mass, damping, stiffness):
    """Poles of eq 29, [rad/s]."""
    return np.asarray(control.poles(transfer_function(mass, damping, stiffness)))
