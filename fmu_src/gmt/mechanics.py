"""Mass-spring-damper of the transducer, eqs 27 and 29.

Transfer function, state space and frequency response through python-control;
the per-step ZOH discretisation the steppers use in closed form
(:func:`zoh_closed_form`, checked against python-control).

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

from .errors import ParameterError


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


def zoh_closed_form(mass, damping, stiffness, step):
    """Exact ZOH discretisation of eq 27 in closed form, for any damping.

    With x = [y, v] and A = [[0, 1], [-K/m, -c/m]], the Cayley-Hamilton
    theorem gives e^{A h} = alpha_0 I + alpha_1 A. Writing the eigenvalues as
    r +- s with r = -c/(2m) and s^2 = (c/(2m))^2 - K/m:

        alpha_1 = e^{r h} h sinh(s h)/(s h),
        alpha_0 = e^{r h} (cosh(s h) - r h sinh(s h)/(s h)),

    real for every sign of s^2 (sinh/cosh become sin/cos for an under-damped
    rod, and the ratio tends to 1 at critical damping, so no branch loses
    digits there). Far from critical damping the same coefficients are taken
    from e^{(r+-s) h} directly, which cannot overflow. The input column
    follows from B_d = A^-1 (A_d - I) B with B = [0, 1/m]:
    b_1 = (1 - alpha_0)/K, b_2 = alpha_1/m.

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg] > 0, c [N s/m] >= 0, K [N/m] > 0.
    step : float
        h, [s], > 0.

    Returns
    -------
    tuple of float
        (a11, a12, a21, a22, b1, b2): y+ = a11 y + a12 v + b1 F, v+ = a21 y +
        a22 v + b2 F, F = net force held over the step [N].
    """
    m, c, k, h = float(mass), float(damping), float(stiffness), float(step)
    if not (m > 0.0 and k > 0.0 and c >= 0.0 and h > 0.0
            and all(math.isfinite(q) for q in (m, c, k, h))):
        raise ParameterError(f"zoh_closed_form needs m > 0, c >= 0, K > 0, h > 0; got "
                         f"m = {m!r} kg, c = {c!r} N s/m, K = {k!r} N/m, h = {h!r} s")
    r = -c / (2.0 * m)
    s2 = r * r - k / m
    if s2 > 0.0 and math.sqrt(s2) * h > 0.5:
        s = math.sqrt(s2)  # over-damped, well separated roots r1 > r2
        e1, e2 = math.exp((r + s) * h), math.exp((r - s) * h)
        alpha1 = (e1 - e2) / (2.0 * s)
        alpha0 = ((r + s) * e2 - (r - s) * e1) / (2.0 * s)
    else:
        x = math.sqrt(abs(s2)) * h
        if s2 > 0.0:
            even, ratio = math.cosh(x), (math.sinh(x) / x if x > 0.0 else 1.0)
        else:
            even, ratio = math.cos(x), (math.sin(x) / x if x > 0.0 else 1.0)
        e = math.exp(r * h)
        alpha1 = e * h * ratio
        alpha0 = e * (even - r * h * ratio)
    return (alpha0, alpha1, -k / m * alpha1, alpha0 - c / m * alpha1,
            (1.0 - alpha0) / k, alpha1 / m)


@lru_cache(maxsize=256)
def _zoh_cached(mass, damping, stiffness, step):
    return zoh_closed_form(mass, damping, stiffness, step)


def zoh_matrices(mass, damping, stiffness, step):
    """Exact ZOH discretisation of eq 27 for one step (:func:`zoh_closed_form`).

    x[k+1] = A_d x[k] + B_d F[k], with F held constant over the step. Equal
    to python-control's ``sample_system(..., method="zoh")`` (matrix
    exponential) to ~1e-13, ``tests/test_physics_forward.py``; the closed form
    costs about a microsecond where python-control took milliseconds, which
    matters when a host varies its step (every distinct step was a new
    discretisation).

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    step : float
        Step h, [s], > 0.

    Returns
    -------
    tuple of float
        (a11, a12, a21, a22, b1, b2); cached per (m, c, K, h).
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
