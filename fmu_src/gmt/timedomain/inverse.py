"""The explicit inverse of the time-domain transducer, for any demanded stroke.

Each link of the forward chain (:mod:`gmt.timedomain.magnetics`) is inverted
in closed form or by a bracketed monotone solve, so the inverse holds for any
demand, not only a raised cosine:

1. the demanded motion y_d gives the force F = m y_d'' + c y_d' + K y_d
   (eq 27) and the strain lambda = F / (A_r E^H) (eq 28);
2. lambda gives M = sqrt(lambda / K_lambda) - M_b (eq 25, the root with
   M + M_b >= 0, as eq 34 takes it);
3. M gives B: M = B/mu_0 - H_hys(B, history) rises with B on every branch, so
   B is unique given the history (the hysteresis memory is carried along);
4. B and dB/dt give H through the field separation, in the same
   backward-Euler form the forward step solves: the forward model driven by
   this current reaches exactly this B at the end of the step;
5. H gives the current, i = k_f L H / N (eq 1).

What cannot be reached saturates and is flagged: a demanded strain below zero
(M + M_b < 0: eq 25 has no root) is held at lambda = 0, and a current beyond
the amplifier's limit is clipped; the B the forward model then reaches with
the clipped current is what the inverse remembers.

Timing: the current of sample n is held over [t_n, t_n + h); the forward
model's B (hence M and F) at t_n + h is the one step 3 gives, and its
mechanics see the mean of the step's end forces. So sample n aims at the
demand at t_n + h: :class:`TimeDomainInverse` takes that force, and the
sampled compensator (:class:`TimeDomainCompensator`) extrapolates its demand
one sample ahead (a quadratic through the last three samples; error ~
(w h)^3 of the stroke, 2.5e-4 at 100 Hz and 10 kHz).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from ..errors import ParameterError
from ..inverse import CompensatorOutput, required_magnetization
from ..parameters import DriveParameters, TransducerParameters
from .magnetics import TimeDomainMagnetics
from .parameters import TimeDomainParameters

__all__ = ["InverseStep", "TimeDomainInverse", "TimeDomainCompensator"]


class InverseStep(NamedTuple):
    """One sample of the inverse (SI)."""

    current: float  #: coil current to hold over the step, [A]
    flux_density: float  #: B the forward model reaches at the step's end, [T]
    strain_limited: bool  #: the demanded strain was below zero (held at lambda = 0)
    current_limited: bool  #: the current was clipped at the amplifier's limit

    @property
    def saturated(self) -> bool:
        """Either limit acted."""
        return self.strain_limited or self.current_limited


class TimeDomainInverse:
    """Force demanded at the end of a step -> coil current over the step (module docstring).

    Parameters
    ----------
    params : TransducerParameters
    td : TimeDomainParameters
    current_limit : float
        Largest current magnitude the amplifier delivers, [A].
    """

    def __init__(self, params: TransducerParameters | None = None,
                 td: TimeDomainParameters | None = None, current_limit: float = 3.0):
        self.params = params or TransducerParameters()
        self.magnetics = TimeDomainMagnetics(self.params, td)
        if not current_limit > 0.0:
            raise ParameterError(
                f"current_limit = {current_limit!r} A is outside the allowed range (0, inf) A")
        self.current_limit = float(current_limit)

    def reset(self):
        """Demagnetised, as the forward model starts."""
        self.magnetics.reset()

    def get_state(self) -> tuple:
        """The magnetic memory the inverse carries."""
        return self.magnetics.get_state()

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        self.magnetics.set_state(state)

    def step(self, magnetization: float, step: float) -> InverseStep:
        """Current that brings M to ``magnetization`` [A/m] (NaN: below zero strain) in ``step`` [s].

        Commits the memory to the B the forward model will reach.
        """
        mag = self.magnetics
        strain_limited = not math.isfinite(magnetization)
        if strain_limited:
            magnetization = -self.params.bias_magnetization  # lambda = 0
        b = mag.flux_density_for(magnetization)
        field = mag.field(b, step)
        fpa = self.params.field_per_ampere
        current = field / fpa
        limit = self.current_limit
        current_limited = abs(current) > limit
        if current_limited:
            current = math.copysign(limit, current)
            b = mag.solve(current * fpa, step)
        mag.move(b)
        return InverseStep(current, b, strain_limited, current_limited)

    def step_motion(self, displacement: float, velocity: float, acceleration: float,
                    step: float) -> InverseStep:
        """Current for the demanded motion (y, y', y'') at the step's end, eqs 27-28, 25."""
        m = required_magnetization(self.params, float(displacement), float(velocity),
                                   float(acceleration))
        return self.step(m, step)


class TimeDomainCompensator:
    """The inverse as a sampled compensator (the interface of :class:`gmt.inverse.InverseCompensator`).

    The control signal u asks for y_d = y_bottom + displacement_per_volt
    (u - control_offset), as the paper's compensator does (``bottom`` is its
    y_bottom, :func:`gmt.inverse.stroke`, so both compensators answer the same
    demand). Each sample extrapolates y_d one sample ahead by the quadratic
    through the last three samples (two at the second, one at the first),
    differentiates it by second-order backward differences and calls
    :class:`TimeDomainInverse`.

    Parameters
    ----------
    params : TransducerParameters
    td : TimeDomainParameters
    drive : DriveParameters
    bottom : float
        y_bottom, [m].
    """

    def __init__(self, params: TransducerParameters, td: TimeDomainParameters | None,
                 drive: DriveParameters, bottom: float):
        self.params = params
        self.drive = drive
        self.bottom = float(bottom)
        self.inverse = TimeDomainInverse(params, td, drive.current_limit)
        self.reset()

    def reset(self):
        """Forget the samples and the memory; counters to zero."""
        self.inverse.reset()
        self._demands = (math.nan, math.nan)  # y_d at the last two samples
        self.saturation_count = 0

    def get_state(self) -> tuple:
        """(the two last demands, saturation count, the inverse's memory), floats."""
        return self._demands + (float(self.saturation_count),) + self.inverse.get_state()

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(float(v) for v in state)
        self._demands = state[:2]
        self.saturation_count = int(state[2])
        self.inverse.set_state(state[3:])

    def demand(self, control: float) -> float:
        """Absolute demanded displacement y_d for a control signal u, [m]."""
        return self.bottom + self.drive.displacement_per_volt * (control - self.drive.control_offset)

    def step(self, control: float, elapsed: float) -> CompensatorOutput:
        """Coil current for u(n), held until the next sample ``elapsed`` [s] later.

        ``elapsed`` is the sample period (the time since the previous sample,
        taken as the time to the next); NaN at the first sample, where the
        drive's ``compensator_period`` is used.
        """
        if not math.isfinite(control):
            raise ParameterError(f"control = {control!r} V is not finite")
        h = elapsed if math.isfinite(elapsed) else self.drive.compensator_period
        if not h > 0.0:
            raise ParameterError(f"elapsed = {elapsed!r} s is outside the allowed range (0, inf) s")
        y0 = self.demand(control)
        y1, y2 = self._demands  # y_d at t_{n-1}, t_{n-2}
        if math.isnan(y1):  # the first sample: hold
            y1 = ahead = y0
        elif math.isnan(y2):  # the second: linear
            ahead = 2.0 * y0 - y1
        else:
            ahead = 3.0 * y0 - 3.0 * y1 + y2
        velocity = (3.0 * ahead - 4.0 * y0 + y1) / (2.0 * h)
        acceleration = (ahead - 2.0 * y0 + y1) / (h * h)
        out = self.inverse.step_motion(ahead, velocity, acceleration, h)
        self._demands = (y0, self._demands[0])
        if out.saturated:
            self.saturation_count += 1
        return CompensatorOutput(out.current, y0, out.saturated)
