"""The transducer with its drive: control signal -> amplifier (and compensator) -> eq 30.

This is the unit the FMU wraps: one object, stepped with the control signal
u [V] and the external axial force on the output rod [N], holding every piece
of state (mechanics, compensator memory, counters) so that it can be saved
and restored exactly.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .calibration import DEFAULT_CALIBRATION
from .errors import ParameterError
from .forward import ForwardStepper, Magnetics, operating_point
from .inverse import InverseCompensator
from .parameters import DriveParameters, Excitation, TransducerParameters


class TransducerOutput(NamedTuple):
    """Outputs after one step (SI)."""

    current: float  #: coil current i, [A]
    magnetics: Magnetics  #: H, H_q, B, M, lambda, F at the held current
    displacement: float  #: y at the end of the step, [m]
    velocity: float  #: dy/dt at the end of the step, [m/s]
    demand: float  #: compensator's y_d, [m] (NaN when uncompensated)
    saturated: bool  #: current limited, or demand out of reach, this step
    saturation_count: int  #: steps saturated since start or reset


class Transducer:
    """Giant magnetostrictive transducer driven through its amplifier (Figure 9).

    Parameters
    ----------
    params : TransducerParameters
    excitation : Excitation
        Operating point of the complex-permeability model.
    drive : DriveParameters
        Amplifier gain, current limit, compensator switch.
    calibration : FluxDensityCalibration
        Source of B_m when the excitation carries none.
    """

    def __init__(self, params: TransducerParameters | None = None,
                 excitation: Excitation | None = None,
                 drive: DriveParameters | None = None,
                 calibration=DEFAULT_CALIBRATION):
        self.params = params or TransducerParameters()
        self.excitation = excitation or Excitation()
        self.drive = drive or DriveParameters()
        self.point = operating_point(self.params, self.excitation, calibration)
        self.forward = ForwardStepper(self.params, self.point)
        self.compensator = (InverseCompensator(self.params, self.point, self.drive)
                            if self.drive.compensated else None)
        self.reset()

    def reset(self):
        """Back to rest; counters to zero."""
        self.forward.reset()
        if self.compensator is not None:
            self.compensator.reset()
        self.saturation_count = 0
        self.previous_step = math.nan

    def get_state(self) -> tuple:
        """Every piece of state as a flat tuple of floats."""
        comp = self.compensator.get_state() if self.compensator is not None else ()
        return (self.forward.get_state() + comp
                + (float(self.saturation_count), self.previous_step))

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(float(s) for s in state)
        nf = len(self.forward.get_state())
        nc = len(self.compensator.get_state()) if self.compensator is not None else 0
        if len(state) != nf + nc + 2:
            raise ParameterError(
                f"state has {len(state)} values; this transducer needs {nf + nc + 2}")
        self.forward.set_state(state[:nf])
        if self.compensator is not None:
            self.compensator.set_state(state[nf:nf + nc])
        self.saturation_count = int(state[nf + nc])
        self.previous_step = state[nf + nc + 1]

    def coil_current(self, control: float, elapsed: float):
        """Current the amplifier delivers for u, and the compensator's demand and saturation."""
        if self.compensator is not None:
            out = self.compensator.step(control, elapsed)
            return out.current, out.demand, out.saturated
        if not math.isfinite(control):
            raise ParameterError(f"control = {control!r} V is not finite")
        limit = self.drive.current_limit
        i = self.drive.amplifier_gain * control
        return min(max(i, -limit), limit), math.nan, abs(i) > limit

    def step(self, control: float, step: float, external_force: float = 0.0) -> TransducerOutput:
        """Advance by ``step`` [s] with the control signal u [V] and F_ext [N] held."""
        if not (step > 0.0 and math.isfinite(step)):
            raise ParameterError(f"step = {step!r} s is outside the allowed range (0, inf) s")
        elapsed = self.previous_step
        current, demand, saturated = self.coil_current(control, elapsed)
        res = self.forward.step(current, step, external_force)
        if saturated:
            self.saturation_count += 1
        self.previous_step = step
        return TransducerOutput(current, res.magnetics, res.displacement, res.velocity,
                                demand, saturated, self.saturation_count)
