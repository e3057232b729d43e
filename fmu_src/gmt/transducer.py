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

The compensator is a digital controller (Figure 9 works on samples u(n),
u(n-1)): with ``DriveParameters.compensator_period`` T_c > 0 it samples u at
t_n = n T_c from the start (the control signal held over a step is its value
at every sample the step reaches) and its DAC holds the current until the
next sample; a step that crosses a sample instant is split there. The
uncompensated amplifier follows u continuously: i = K_a u over each step.

With ``magnetics="time_domain"`` the transducer is the time-domain model of
:mod:`gmt.timedomain` instead (the paper's loss separation as a field
separation, valid for any current), and its compensator that model's explicit
inverse (``inverse="paper"`` keeps Figure 9's compensator in front of it).
Every drive is then inside the model: the monitor below stays quiet.

A :class:`gmt.design_point.DriveMonitor` watches the coil current the model
sees: ``outside_design_point`` in the output says when it departs from the
sinusoid at (f, I_m) the complex permeability is defined for, and with
``Excitation.follow_drive`` the operating point follows the measured drive
(the paper's model only; the compensator keeps the parameters' point, as the
product's compensator is designed on it).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .calibration import DEFAULT_CALIBRATION
from .design_point import DriveMonitor
from .errors import ParameterError
from .forward import ForwardStepper, Magnetics, operating_point
from .inverse import InverseCompensator
from .parameters import DriveParameters, Excitation, TransducerParameters
from .variants import ModelVariant, make_stepper

#: The transducer models :class:`Transducer` runs (``magnetics``) and the inverses its
#: compensator can use (``inverse``): the paper's complex permeability (eqs 1-37), or the
#: time-domain field separation (:mod:`gmt.timedomain`).
MAGNETICS = ("paper", "time_domain")


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
    #: the coil current departs from the model's operating point (gmt.design_point)
    outside_design_point: bool = False


class RodMechanics(NamedTuple):
    """The mechanics the magnetostrictive force drives (eq 27, or a variant's), SI.

    One mass (``output_mass`` 0): m y'' + c y' + K y = F - F_ext (eq 27). Two
    masses (a ``mechanical_resonance:two_dof`` variant): F drives the rod m on
    c and K, the output mass m_2 hangs on the joint k_j, c_j and carries F_ext
    and the output y (:class:`gmt.extensions.TwoMassMechanics`).
    """

    mass: float  #: m of eq 27, or the rod's m_1 with two masses, [kg]
    damping: float  #: c, [N s/m]
    stiffness: float  #: K, [N/m]
    output_mass: float = 0.0  #: m_2, [kg]; 0: one mass
    joint_stiffness: float = 0.0  #: k_j, [N/m]
    joint_damping: float = 0.0  #: c_j, [N s/m]


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
    magnetics : {"paper", "time_domain"}
        The transducer model: the paper's (default) or the time-domain one
        (:mod:`gmt.timedomain`; the paper's model variant only).
    inverse : {"paper", "time_domain"}, optional
        The model the compensator inverts; default: ``magnetics``.
    time_domain : gmt.timedomain.parameters.TimeDomainParameters, optional
        The time-domain model's parameters beyond Table 2 (default: their defaults).
    """

    def __init__(self, params: TransducerParameters | None = None,
                 excitation: Excitation | None = None,
                 drive: DriveParameters | None = None,
                 calibration=DEFAULT_CALIBRATION,
                 variant: ModelVariant | None = None, magnetics: str = "paper",
                 inverse: str | None = None, time_domain=None):
        self.params = params or TransducerParameters()
        self.excitation = excitation or Excitation()
        self.drive = drive or DriveParameters()
        self.variant = variant or ModelVariant()
        if not isinstance(self.variant, ModelVariant):
            raise ParameterError(f"variant = {variant!r} must be a gmt.ModelVariant")
        if self.excitation.follow_drive and not self.variant.is_paper:
            raise ParameterError("follow_drive = True needs the paper's model (model_variant "
                                 f"'paper'), not {self.variant.name!r}")
        inverse = magnetics if inverse is None else inverse
        for name, value in (("magnetics", magnetics), ("inverse", inverse)):
            if value not in MAGNETICS:
                raise ParameterError(f"{name} = {value!r} is not one of {MAGNETICS}")
        self.magnetics, self.inverse = magnetics, inverse
        self.calibration = calibration
        self.point = operating_point(self.params, self.excitation, calibration)
        self.design_point = self.point
        if magnetics == "paper":
            self.forward = make_stepper(self.params, self.point, self.variant)
        else:
            from .timedomain.transducer import time_domain_stepper
            self.forward = time_domain_stepper(self.params, self.excitation, self.variant,
                                               time_domain)
        if not self.drive.compensated:
            self.compensator = None
        elif inverse == "paper":
            self.compensator = InverseCompensator(self.params, self.point, self.drive)
        else:
            from .timedomain.transducer import time_domain_compensator
            self.compensator = time_domain_compensator(self.params, self.point, self.drive,
                                                       time_domain)
        # sizes of the fixed parts of the flat state (the paper stepper's values, the
        # compensator's), taken once: set_state runs at every retried co-simulation step.
        # The time-domain model's and inverse's memories vary in length: they go last,
        # after the forward part's length
        self._nf = len(ForwardStepper.get_state(self.forward)) if magnetics == "paper" else 0
        self._nc = (len(self.compensator.get_state())
                    if self.compensator is not None and inverse == "paper" else 0)
        self._tails = magnetics != "paper" or (self.compensator is not None
                                               and inverse != "paper")
        #: sample period of the compensator, [s]; 0: a sample at every step
        self.sample_period = (self.drive.compensator_period if self.compensator is not None
                              else 0.0)
        self._ns = 4 if self.sample_period > 0.0 else 0
        #: watches the coil current against the operating point (gmt.design_point)
        self.monitor = DriveMonitor(self.point.frequency, self.point.current_amplitude,
                                    steps=self.compensator is None,
                                    follow=self.excitation.follow_drive)
        self.reset()

    def reset(self):
        """Back to rest; counters to zero."""
        self.forward.reset()
        if self.compensator is not None:
            self.compensator.reset()
        self.saturation_count = 0
        self.previous_step = math.nan
        # the sampled compensator: time to its next sample [s] (the first is at 0), and
        # what its DAC holds: current [A], demand [m], saturated (1/0)
        self._to_sample = 0.0
        self._held = (math.nan, math.nan, 0.0)
        self.monitor.reset()
        self._move_point(self.monitor.model)

    def _move_point(self, model) -> None:
        """Evaluate the forward model at the operating point (f, I_m) = ``model``."""
        f, im = model
        point = self.point
        if (f, im) == (point.frequency, point.current_amplitude):
            return
        if (f, im) == self.monitor.design:
            self.point = self.design_point
        else:
            self.point = operating_point(self.params, Excitation(f, im, follow_drive=True),
                                         self.calibration)
        self.forward.point = self.point

    def _observe(self, current: float, duration: float) -> None:
        """Show the monitor the current held over ``duration``; follow the drive if asked.

        The time-domain model holds for any current: nothing to watch.
        """
        if self.magnetics != "paper":
            return
        model = self.monitor.observe(current, duration)
        if model is not None:
            try:
                self._move_point(model)
            except ParameterError:  # no operating point there: stay, and say so
                self.monitor.set_model((self.point.frequency, self.point.current_amplitude))
                self.monitor.depart(1)

    def get_state(self) -> tuple:
        """Every piece of state as a flat tuple of floats.

        The paper stepper's values, the compensator's, the saturation count and
        the previous step, the sampled compensator's time to its next sample and
        held current, demand and saturation flag (with ``compensator_period`` > 0
        only), the drive monitor's (which holds the operating point the model
        follows), then the variant's (none for the paper's model; for a sensor
        delay their number varies with the delay line).
        """
        comp = self.compensator.get_state() if self.compensator is not None else ()
        forward = self.forward.get_state()
        nf, nc = self._nf, self._nc
        sampler = (self._to_sample,) + self._held if self._ns else ()
        fixed = (forward[:nf] + comp[:nc] + (float(self.saturation_count), self.previous_step)
                 + sampler + self.monitor.get_state())
        if self._tails:  # variable lengths: the forward tail's length, both tails
            return fixed + (float(len(forward) - nf),) + forward[nf:] + comp[nc:]
        return fixed + forward[nf:]

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(map(float, state))
        nf, nc, ns, nm = self._nf, self._nc, self._ns, DriveMonitor.STATE_SIZE
        fixed = nf + nc + 2 + ns + nm
        if self._tails:
            k = int(state[fixed]) if len(state) > fixed else -1
            if not 0 <= k <= len(state) - fixed - 1:
                raise ParameterError(f"state has {len(state)} values; this transducer needs "
                                     f"more than {fixed}, with a valid length at {fixed}")
            tail = state[fixed + 1:]
            self.forward.set_state(state[:nf] + tail[:k])
            if self.compensator is not None:
                self.compensator.set_state(state[nf:nf + nc] + tail[k:])
            self._restore_counters(state, nf, nc, ns, fixed, nm)
            return
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
        self._restore_counters(state, nf, nc, ns, fixed, nm)

    def _restore_counters(self, state, nf, nc, ns, fixed, nm) -> None:
        """The counters, the sampler and the monitor of a flat state (:meth:`set_state`)."""
        self.saturation_count = int(state[nf + nc])
        self.previous_step = state[nf + nc + 1]
        if ns:
            self._to_sample = state[nf + nc + 2]
            self._held = state[nf + nc + 3:nf + nc + 2 + ns]
        self.monitor.set_state(state[fixed - nm:fixed])
        self._move_point(self.monitor.model)

    def rod_mechanics(self) -> RodMechanics:
        """What the magnetostrictive force drives: eq 27's m, c, K or the variant's masses.

        A co-simulation that integrates the rod outside the transducer (the force
        port of :mod:`system_models.cosim`) takes its mechanics from here (through
        the FMU's calculated parameters), so that one set of values drives both.
        """
        chain = getattr(self.forward, "chain", None)  # a variant's time-stepped forms
        system = getattr(chain.mechanical, "system", None) if chain is not None else None
        if system is not None:  # the two-mass variant's
            return RodMechanics(system.rod_mass, system.damping, system.stiffness,
                                system.output_mass, system.joint_stiffness,
                                system.joint_damping)
        m, c, k = (chain.mechanics if chain is not None
                   else (self.params.mass, self.params.damping, self.params.stiffness))
        return RodMechanics(float(m), float(c), float(k))

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
        """Advance by ``step`` [s] with the control signal u [V] and F_ext [N] held.

        With a sampled compensator the outputs' current and magnetics are those
        of the last sample the step reached (held over the step's end).
        """
        if not (step > 0.0 and math.isfinite(step)):
            raise ParameterError(f"step = {step!r} s is outside the allowed range (0, inf) s")
        if self._ns:
            return self._sampled_step(control, step, external_force)
        elapsed = self.previous_step
        current, demand, saturated = self.coil_current(control, elapsed)
        self._observe(current, step)
        res = self.forward.step(current, step, external_force)
        if saturated:
            self.saturation_count += 1
        self.previous_step = step
        sensed = getattr(res, "sensed_displacement", res.displacement)
        return TransducerOutput(current, res.magnetics, res.displacement, res.velocity,
                                demand, saturated, self.saturation_count, sensed,
                                self.monitor.outside)

    def _sampled_step(self, control, step, external_force):
        """One step with the compensator sampled every T_c and its current held between.

        The step is split at every sample instant it crosses; a sample instant
        within 1e-6 T_c of the step's end counts as the end (host clocks that
        add up steps in floating point).
        """
        period = self.sample_period
        tol = 1e-6 * period
        if not math.isfinite(control):
            raise ParameterError(f"control = {control!r} V is not finite")
        if not math.isfinite(external_force):
            raise ParameterError(f"external_force = {external_force!r} N is not finite")
        left = step
        while True:
            held = self._to_sample > tol  # else a sample instant: the compensator samples u
            if not held:
                first = math.isnan(self._held[0])
                out = self.compensator.step(control, math.nan if first else period)
                self._held = (out.current, out.demand, 1.0 if out.saturated else 0.0)
                if out.saturated:
                    self.saturation_count += 1
                self._to_sample += period
            piece = left if left - self._to_sample <= tol else self._to_sample
            self._observe(self._held[0], piece)
            res = self.forward.step(self._held[0], piece, external_force, held=held)
            self._to_sample -= piece
            left -= piece
            if left <= 0.0:
                break
        self.previous_step = step
        sensed = getattr(res, "sensed_displacement", res.displacement)
        return TransducerOutput(self._held[0], res.magnetics, res.displacement, res.velocity,
                                self._held[1], bool(self._held[2]), self.saturation_count,
                                sensed, self.monitor.outside)

    @property
    def sensed_displacement(self) -> float:
        """What a displacement sensor reads now, [m] (the rod's y unless delayed)."""
        return getattr(self.forward, "sensed_displacement", self.forward.displacement)
