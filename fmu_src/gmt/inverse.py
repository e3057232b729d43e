"""Inverse model and inverse compensator, eqs 31-37 and Figure 9.

Derivation (eq 32 to eq 33, re-derived)
---------------------------------------
With i tan(w t) = s sqrt(I_m^2 - i^2), s = +-1 (eq 31), eq 30 reads

    i (mu' - 1) + s mu'' sqrt(I_m^2 - i^2) = phi_0,                      (32)

    phi_0 = (k_f L / N) (sqrt((m y'' + c y' + K y) / (A_r E^H K_lambda)) - M_b)   (34)

(phi_0 is the coil magnetisation the displacement needs, expressed in
amperes). Moving i (mu' - 1) across and squaring removes s:

    [(mu' - 1)^2 + mu''^2] i^2 - 2 (mu' - 1) phi_0 i + phi_0^2 - (I_m mu'')^2 = 0   (33)

The paper prints the first coefficient as (mu' - 1)^2 + mu'' (a typo); the
square is what the algebra gives and what its roots (35)-(37) use. With
D = (mu' - 1)^2 + mu''^2 the roots are

    i = (phi_0 (mu' - 1) -+ phi_1) / D,   phi_1 = mu'' sqrt(D I_m^2 - phi_0^2)   (35)-(37)

(eq 37 simplifies to this). Real roots exist for |phi_0| <= sqrt(D) I_m,
the amplitude of the coil's magnetisation; any real root has |i| <= I_m.

Which root
----------
In the (i, M) plane the model's loop is the ellipse i = I_m cos(theta),
M = H_m [(mu' - 1) cos(theta) + mu'' sin(theta)], traversed with theta
increasing. The horizontal line M = phi_0 N/(k_f L) cuts it twice: once on the
arc on which M rises (the right-hand arc, through i = +I_m) and once on the
arc on which M falls (through i = -I_m). So a rising demand takes the larger
root, "+phi_1" (the paper's eq 36), and a falling one the smaller, "-phi_1"
(eq 35). Figure 9's text assigns eq 35 to a rising u; that pairing puts the
current on the falling arc, and the forward model then does not reproduce
y_d (``tests/test_inverse.py`` shows both). The compensator keeps Figure 9's
structure -- the branch is chosen by the sign of u(n) - u(n-1), ties go to the
"else" branch -- with the pairing the derivation gives.

Figure 9's rule and the mechanics
---------------------------------
Eq 34 inverts the mechanics too: the damping term c y_d' makes the demanded
magnetisation phi_0 peak before u does (by about arctan(c w / K): 2.7 deg at
50 Hz). Between the two peaks Figure 9 still takes the rising root while
phi_0 already falls, so the current runs backwards along its arc and the
forward model, which only sees the current, lands on the other arc: the
compensated displacement dips at each extreme of u. ``branch_rule="demand"``
picks the root by the sign of phi_0(n) - phi_0(n-1) instead, which agrees
with Figure 9 away from the extremes and tracks y_d through them. Both are
measured in the tests and by ``smeha paper``; ``"demand"`` is the default
(:data:`gmt.parameters.BRANCH_RULE`), for the reason below.

Sampling: why Figure 9's rule does not converge in T_c
------------------------------------------------------
With Figure 9's rule the compensator stays on the rising root from phi_0's
peak until the first sample after u's peak, then jumps to the falling root
(at 50 Hz and the paper's a = 2.2 V, from 0.92 to 0.70 A: near the top of
the stroke the two roots lie far apart). The forward model puts the current
that runs backwards on the other arc of eq 31, so M drops and the rod dips
by ~7 um within ~0.3 ms, a transient of the mechanics (eq 27). Where that dip
falls against u's peak, the instant the valves switch (eq 41), is set by
where the samples fall in the 0.15 ms between the two peaks: at T_c = 100 us
the switch comes one sample after u's peak and the window sees the stroke
before the dip (dy' 44.0 um, the free transducer at 50 Hz), at T_c <= 10 us
it sees the dip (37.1 um; 36.8 um at 2 us). So this rule converges only for
T_c well below 0.15 ms, and the co-simulation's host must then step at T_c
too: the compensator differentiates u (eq 34), and a u held over a longer
communication step is a staircase (dy' 25 um at T_c = 10 us under a 100 us
step). The demand rule switches where the roots meet (phi_0's peak): the
current changes no arc the forward model sees, there is no dip, and dy' is
44.0 um from T_c = 2 us to 100 us (30.0 um at 100 Hz), within 0.2 %
(``benchmarks/compensator_convergence.py``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .errors import ParameterError
from .forward import OperatingPoint, bias_displacement
from .parameters import DriveParameters, TransducerParameters


def required_magnetization(params: TransducerParameters, displacement, velocity=0.0,
                           acceleration=0.0):
    """Coil magnetisation M that produces a displacement history, from eqs 25, 27-28, [A/m].

    M = sqrt((m y'' + c y' + K y) / (A_r E^H K_lambda)) - M_b, the bracket of
    eq 34. A negative radicand (a demand below zero strain) is returned as NaN;
    :func:`demand_current_coordinate` saturates it.

    Parameters
    ----------
    displacement, velocity, acceleration : float or array
        y [m], y' [m/s], y'' [m/s^2] of the demanded motion (absolute y,
        including the bias displacement).
    """
    force = params.mass * acceleration + params.damping * velocity + params.stiffness * displacement
    if isinstance(force, float):  # one sample (the compensator's): plain floats, same arithmetic
        radicand = force / (params.rod_area * params.youngs_modulus
                            * params.magnetostriction_coefficient)
        return (math.sqrt(radicand) if radicand >= 0.0 else math.nan) - params.bias_magnetization
    radicand = np.asarray(force / (params.rod_area * params.youngs_modulus
                                   * params.magnetostriction_coefficient), dtype=float)
    root = np.sqrt(np.where(radicand >= 0.0, radicand, np.nan))
    return (root - params.bias_magnetization)[()]


def demand_current_coordinate(params: TransducerParameters, magnetization):
    """phi_0 = (k_f L / N) M, eq 34, [A]."""
    return magnetization / params.field_per_ampere


def quadratic_coefficients(mu_real, mu_imag, phi0, current_amplitude):
    """Coefficients (a, b, c) of a i^2 + b i + c = 0, eq 33 with its typo corrected."""
    g = mu_real - 1.0
    return (g * g + mu_imag * mu_imag, -2.0 * g * phi0,
            phi0 * phi0 - (current_amplitude * mu_imag) ** 2)


class Roots(NamedTuple):
    """The two currents of eqs 35-36 and whether eq 37's radicand was negative."""

    falling: float  #: eq 35, (phi_0 (mu'-1) - phi_1) / D, [A]
    rising: float  #: eq 36, (phi_0 (mu'-1) + phi_1) / D, [A]
    out_of_reach: bool  #: |phi_0| > sqrt(D) I_m; phi_0 was clamped


def current_roots(mu_real, mu_imag, phi0, current_amplitude) -> Roots:
    """Roots of eq 33, eqs 35-37, saturating an out-of-reach phi_0.

    When |phi_0| exceeds sqrt(D) I_m (negative discriminant) phi_0 is clamped
    to +-sqrt(D) I_m, the nearest reachable magnetisation, where the two roots
    meet. NaN phi_0 (a demand below zero strain) clamps to the lower bound.
    """
    g = mu_real - 1.0
    d = g * g + mu_imag * mu_imag
    reach = math.sqrt(d) * current_amplitude
    out = False
    if math.isnan(phi0) or phi0 < -reach:
        phi0, out = -reach, True
    elif phi0 > reach:
        phi0, out = reach, True
    phi1 = mu_imag * math.sqrt(max(d * current_amplitude ** 2 - phi0 * phi0, 0.0))
    return Roots((phi0 * g - phi1) / d, (phi0 * g + phi1) / d, out)


def stroke(params: TransducerParameters, point: OperatingPoint) -> tuple[float, float]:
    """Lowest and highest static displacement reachable at an operating point, [m].

    The coil's magnetisation spans +-|mu - 1| H_m about the bias (eq 5), so
    the quasi-static displacement K_lambda L (M_b + M)^2 (eqs 25, 28-29 at
    s = 0) spans these two values. Because eq 25 is quadratic the bias
    displacement is not the middle of the stroke.
    """
    amp = point.magnetization_amplitude
    mb = params.bias_magnetization
    scale = bias_displacement(params) / (mb * mb)
    low = 0.0 if amp >= mb else scale * (mb - amp) ** 2
    return low, scale * (mb + amp) ** 2


#: Two samples closer than this, relative to their size, are a tie (Figure 9's "else"
#: branch): exact arithmetic gives a tie for samples placed symmetrically about an extreme
#: of u (80 Hz sampled at 10 kHz: the minimum falls half-way between two samples), and the
#: last bits of two evaluations of u must not decide the root.
TIE = 1e-12


def _rises(value, previous) -> bool:
    """value > previous by more than :data:`TIE` of their size."""
    return value - previous > TIE * max(abs(value), abs(previous))


class CompensatorOutput(NamedTuple):
    """One sample of the compensator."""

    current: float  #: coil current to drive, [A]
    demand: float  #: y_d, absolute demanded displacement, [m]
    saturated: bool  #: demand out of reach or current limited this sample


class InverseCompensator:
    """The inverse compensator of Figure 9, sample by sample.

    The control signal u [V] asks for the displacement
    y_d = y_bottom + displacement_per_volt (u - control_offset) (10 um/V in
    the paper), measured from the bottom of the stroke about the bias
    (:func:`stroke`), as Table 3 measures from the lowest point. Its
    derivatives come from backward differences of the samples. phi_0 follows
    from eq 34, the current from eq 35 or 36 by the sign of u(n) - u(n-1); the
    amplifier delivers it (i = K_a * (i_required / K_a)) up to the current
    limit. An out-of-reach demand saturates to the nearest reachable current
    and is counted in :attr:`saturation_count`; the output is never NaN.

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
    drive : DriveParameters
    """

    def __init__(self, params: TransducerParameters, point: OperatingPoint,
                 drive: DriveParameters):
        self.params = params
        self.point = point
        self.drive = drive
        self._bottom = stroke(params, point)[0]
        self.reset()

    def reset(self):
        """Forget the sample history and the saturation count."""
        self.previous_control = math.nan
        self.previous_demand = math.nan
        self.previous_rate = 0.0
        self.previous_phi0 = math.nan
        self.saturation_count = 0

    def get_state(self) -> tuple:
        """Every piece of state, as a tuple of floats."""
        return (self.previous_control, self.previous_demand, self.previous_rate,
                self.previous_phi0, float(self.saturation_count))

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        pc, pd, pr, pp, n = (float(s) for s in state)
        self.previous_control, self.previous_demand, self.previous_rate = pc, pd, pr
        self.previous_phi0 = pp
        self.saturation_count = int(n)

    def demand(self, control: float) -> float:
        """Absolute demanded displacement y_d for a control signal u, [m]."""
        return self._bottom + self.drive.displacement_per_volt * (
            control - self.drive.control_offset)

    def step(self, control: float, elapsed: float) -> CompensatorOutput:
        """Coil current for the control signal u(n).

        Parameters
        ----------
        control : float
            u(n), [V].
        elapsed : float
            Time since the previous sample t_n - t_{n-1}, [s]; ignored at the
            first sample.
        """
        if not math.isfinite(control):
            raise ParameterError(f"control = {control!r} V is not finite")
        y = self.demand(control)
        first = math.isnan(self.previous_control)
        if first:
            rate, accel = 0.0, 0.0
        else:
            if not elapsed > 0.0:
                raise ParameterError(f"elapsed = {elapsed!r} s is outside the allowed range (0, inf) s")
            rate = (y - self.previous_demand) / elapsed
            accel = (rate - self.previous_rate) / elapsed
        m = required_magnetization(self.params, y, rate, accel)
        phi0 = float(demand_current_coordinate(self.params, m))
        roots = current_roots(self.point.mu_real, self.point.mu_imag, phi0,
                              self.point.current_amplitude)
        if self.drive.branch_rule == "control":  # Figure 9: u(n) > u(n-1)
            rising = (not first) and _rises(control, self.previous_control)
        else:  # "demand": direction of the magnetisation eq 34 asks for
            rising = (not first) and _rises(phi0, self.previous_phi0)
        current = roots.rising if rising else roots.falling
        limit = self.drive.current_limit
        saturated = roots.out_of_reach or abs(current) > limit
        current = min(max(current, -limit), limit)
        if saturated:
            self.saturation_count += 1
        self.previous_control = control
        self.previous_demand = y
        self.previous_rate = rate
        self.previous_phi0 = phi0
        return CompensatorOutput(current, y, saturated)
