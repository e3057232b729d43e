"""Mass-spring-damper of the transducer, eqs 27 and 29.

Poles, frequency response (continuous and at the samples of the ZOH-discretised
system) and the per-step ZOH discretisation the steppers use, all in closed
form with numpy (the FMU's run time imports numpy only). The tests check each
against python-control's transfer function, state space and matrix-exponential
ZOH (``tests/test_physics_forward.py``).

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

import numpy as np

from .errors import ParameterError


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


def frequency_response(mass, damping, stiffness, angular_frequency, step=None):
    """Complex response of y and v to a sinusoidal force, per newton (eq 29).

    Continuous: Y/F = G(j w) = 1 / (K - m w^2 + j c w), V/F = j w G(j w).
    With ``step``, the ZOH-discretised system at its samples, z = exp(j w h):
    with (A_d, B_d) of :func:`zoh_closed_form`,
    [Y, V]/F = (z I - A_d)^-1 B_d, the 2x2 inverse written out.

    Parameters
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    angular_frequency : float or array
        w, [rad/s]; 0 gives the static compliance 1/K.
    step : float, optional
        If given, the response G_d(exp(j w h)) of the ZOH-discretised system
        rather than the continuous G(j w).

    Returns
    -------
    (array, array)
        Y/F [m/N] and V/F [m/(N s)], complex.
    """
    w = np.atleast_1d(np.asarray(angular_frequency, dtype=float))
    m, c, k = float(mass), float(damping), float(stiffness)
    if step is None:
        s = 1j * w
        gy = 1.0 / (m * s * s + c * s + k)
        return gy, s * gy
    a11, a12, a21, a22, b1, b2 = zoh_matrices(m, c, k, step)
    z = np.exp(1j * w * step)
    det = (z - a11) * (z - a22) - a12 * a21
    return ((z - a22) * b1 + a12 * b2) / det, (a21 * b1 + (z - a11) * b2) / det


def poles(mass, damping, stiffness):
    """Poles of eq 29, the roots of m s^2 + c s + K, [rad/s] (complex array).

    Written -c/(2m) -+ sqrt((c/(2m))^2 - K/m); for real roots the smaller one
    is taken as K/(m p_1) (Vieta), which keeps its digits when c^2 >> 4 K m.
    """
    m, c, k = float(mass), float(damping), float(stiffness)
    r = -c / (2.0 * m)
    disc = r * r - k / m
    if disc >= 0.0:
        big = r - math.copysign(math.sqrt(disc), c) if c else -math.sqrt(disc)
        small = (k / m) / big if big else 0.0
        return np.array([big, small], dtype=complex)
    root = 1j * math.sqrt(-disc)
    return np.array([r - root, r + root])
