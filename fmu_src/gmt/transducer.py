"""The transducer with its drive: control signal -> amplifier (and compensator) -> eq 30.

This is the unit the FMU wraps: one object, stepped with the control signal
u [V] and the external axial force on the output rod [N], holding every piece
of state (mechanics, compensator memory, counters, the model variant's memory)
so that it can be saved and restored exactly.

The transducer model is the paper's (eq 30) unless a
:class:`gmt.variants.ModelVariant` adds one extension (the cause
``smeha diagnose`` names); the compensator always inverts the paper's model,
as the product's compensator is designed on it, so with a variant it drives a
transducer it does not model exactly.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .calibration import DEFAULT_CALIBRATION
from .errors import ParameterError
from .forward import ForwardStepper, Magnetics, operating_point
from .inverse import InverseCompensator
from .parameters import DriveParameters, Excitation, TransducerParameters
from .variants import ModelVariant, make_stepper


class TransducerOutput(NamedTuple):
    """Outputs after one step (SI)."""

    current: float  #: coil current i, [A]
    magnetics: Magnetics  #: H, H_q, B, M, lambda, F at the held current
    displacement: float  #: y at the end of the step, [m]
    velocity: float  #: dy/dt at the end of the step, [m/s]
    demand: float  #: compensator's y_d, [m] (NaN when uncompensated)
    saturated: bool  #: current limited, or demand out of reach, this step
    saturation_count: int  #: steps saturated since start or reset
    #: what a displacement sensor on the rod reads at the end of the step, [m]: the
    #: displacement, except with a sensor delay (variant ``transport_delay``)
    sensed_displacement: float


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
    variant : ModelVariant, optional
        The paper's model (default) or the paper's plus one extension
        (:mod:`gmt.variants`).
    """

    def __init__(self, params: TransducerParameters | None = None,
                 excitation: Excitation | None = None,
                 drive: DriveParameters | None = None,
                 calibration=DEFAULT_CALIBRATION,
                 variant: ModelVariant | None = None):
        self.params = params or TransducerParameters()
        self.excitation = excitation or Excitation()
        self.drive = drive or DriveParameters()
        self.variant = variant or ModelVariant()
        if not isinstance(self.variant, ModelVariant):
            raise ParameterError(f"variant = {variant!r} must be a gmt.ModelVariant")
        self.point = operating_point(self.params, self.excitation, calibration)
        self.forward = make_stepper(self.params, self.point, self.variant)
        self.compensator = (InverseCompensator(self.params, self.point, self.drive)
                            if self.drive.compensated else None)
        # sizes of the fixed parts of the flat state (the paper stepper's values, the
        # compensator's), taken once: set_state runs at every retried co-simulation step
        self._nf = len(ForwardStepper.get_state(self.forward))
        self._nc = len(self.compensator.get_state()) if self.compensator is not None else 0
        self.reset()

    def reset(self):
        """Back to rest; counters to zero."""
        self.forward.reset()
        if self.compensator is not None:
            self.compensator.reset()
        self.saturation_count = 0
        self.previous_step = math.nan

    def get_state(self) -> tuple:
        """Every piece of state as a flat tuple of floats.

        The paper stepper's values, the compensator's, the saturation count and
        the previous step, then the variant's (none for the paper's model; for
        a sensor delay their number varies with the delay line).
        """
        comp = self.compensator.get_state() if self.compensator is not None else ()
        forward = self.forward.get_state()
        nf = self._nf
        return (forward[:nf] + comp + (float(self.saturation_count), self.previous_step)
                + forward[nf:])

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(map(float, state))
        nf, nc = self._nf, self._nc
        fixed = nf + nc + 2
        if self.variant.is_paper:
            bad, need = len(state) != fixed, f"{fixed}"
        else:  # the variant's elapsed time and sensed displacement, then its memory
            bad, need = len(state) < fixed + 2, f"at least {fixed + 2}"
        if bad:
            raise ParameterError(
                f"state has {len(state)} values; this transducer needs {need}")
        self.forward.set_state(state[:nf] + state[fixed:])
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
        sensed = getattr(res, "sensed_displacement", res.displacement)
        return TransducerOutput(current, res.magnetics, res.displacement, res.velocity,
                                demand, saturated, self.saturation_count, sensed)

    @property
    def sensed_displacement(self) -> float:
        """What a displacement sensor reads now, [m] (the rod's y unless delayed)."""
        return getattr(self.forward, "sensed_displacement", self.forward.displacement)
