"""The composed forward model of the transducer, eq 30.

    y = [N i/(k_f L) (mu' - 1 + mu'' tan(w t)) + M_b]^2 A_r E^H K_lambda / (m s^2 + c s + K)

in three forms that share one set of formulas:

* :func:`operating_point` -- mu', mu'', lag and losses at a sinusoidal
  excitation (eqs 1, 12-20);
* :class:`ForwardStepper` and :func:`simulate` -- a time-stepping model that
  takes the coil current sample by sample, with the mechanics (eq 27) advanced
  by their exact zero-order-hold discretisation, stable for any step;
* :func:`periodic_response` -- the periodic steady state for i = I_m cos(w t)
  in closed form (harmonic balance: the strain of eq 25 has exactly a mean,
  a fundamental and a second harmonic).

The quadrature term
-------------------
The paper's i tan(w t) is the quadrature part I_m sin(w t) of a sinusoidal
current (for i = I_m cos(w t), i tan(w t) = I_m sin(w t)). Sample by sample, it is rebuilt as eq 31 does:
i tan(w t) = +-sqrt(I_m^2 - i^2), with the sign of sin(w t), which is the
current's direction: falling current +, rising -. Taken from two samples,
sign(i[k-1] - i[k]) is the sign of sin(w t) half a step earlier, wrong at the
one sample that follows a reversal of a sinusoid. So within one step of the
sinusoid's own reversal (I_m^2 - i^2 <= (I_m w h)^2) the sign is taken from
i[k-1] - i[k] cos(w h) = I_m sin(w t_k) sin(w h), exact for a sinusoid at
(I_m, w). Elsewhere the plain direction is used: a current that stands still
at |i| < I_m (the compensated current at the extremes of its demand) is not
that sinusoid, and only its direction says which arc of the loop it is on.
A current that does not change keeps the previous sample's branch (it has not
moved along the loop), and the first sample takes +. |i| > I_m gives a zero
quadrature term. So the
time-stepping model reproduces the paper's model exactly for the sinusoid it
is defined for, and for other waveforms (the compensated current, a host's
arbitrary input) it applies eq 31 as the inverse model (eqs 32-37) assumes.

Time alignment
--------------
A step takes the current at t_k, holds it (and the external force) over
[t_k, t_k + h) as an FMI co-simulation input is held, and returns the
mechanical state at t_k + h.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import mechanics
from .calibration import DEFAULT_CALIBRATION
from .errors import ParameterError
from .field import applied_field
from .losses import LossBreakdown, imaginary_permeability, separate_losses
from .magnetostriction import magnetostriction, magnetostrictive_force
from .parameters import Excitation, TransducerParameters
from .permeability import (amplitude_permeability, flux_density, lag_angle,
                           magnetization, magnetization_phasor, real_permeability)


@dataclass(frozen=True)
class OperatingPoint:
    """Complex permeability and losses at one sinusoidal excitation.

    Attributes
    ----------
    frequency : float
        f, [Hz].
    current_amplitude : float
        I_m, [A].
    field_amplitude : float
        H_m = N I_m / (k_f L), [A/m] (eq 1).
    flux_density_amplitude : float
        B_m, [T].
    flux_density_source : str
        ``"measured"`` (given in the Excitation) or ``"calibration"``.
    mu_real, mu_imag : float
        mu' (eq 20) and mu'' (eq 16), [-].
    losses : LossBreakdown
        P_h, P_eddy, P_ex for the rod volume, [W] (eqs 7, 9, 11).
    """

    frequency: float
    current_amplitude: float
    field_amplitude: float
    flux_density_amplitude: float
    flux_density_source: str
    mu_real: float
    mu_imag: float
    losses: LossBreakdown

    @property
    def angular_frequency(self) -> float:
        """w = 2 pi f, [rad/s]."""
        return 2.0 * math.pi * self.frequency

    @property
    def lag(self) -> float:
        """Lag of B behind H, arctan(mu''/mu'), [rad] (eq 18)."""
        return lag_angle(self.mu_real, self.mu_imag)

    @property
    def magnetization_amplitude(self) -> float:
        """Amplitude of the coil's magnetisation, |mu - 1| H_m, [A/m] (eq 5)."""
        return abs(magnetization_phasor(self.mu_real, self.mu_imag)) * self.field_amplitude


def operating_point(params: TransducerParameters, excitation: Excitation,
                    calibration=DEFAULT_CALIBRATION, regime: str = "intermediate",
                    mu_imag: float | None = None) -> OperatingPoint:
    """Complex permeability at a sinusoidal excitation, eqs 1, 12-20.

    Parameters
    ----------
    params : TransducerParameters
    excitation : Excitation
        f, I_m and (optionally) the measured B_m.
    calibration : FluxDensityCalibration
        Source of B_m when the excitation carries none (default: Table 1).
    regime : {"intermediate", "low"}
        Hysteresis law for mu'': eq 16 (default) or eq 15.
    mu_imag : float, optional
        Impose mu'' instead of computing it from the losses (as the paper's
        identification scan does, 0 to 10).

    Raises
    ------
    ParameterError
        When B_m makes mu' imaginary (eq 20).
    """
    f = excitation.frequency
    im = excitation.current_amplitude
    hm = applied_field(im, params.coil_turns, params.leakage_coefficient, params.rod_length)
    if excitation.has_measured_flux_density:
        bm, source = excitation.flux_density_amplitude, "measured"
    else:
        bm, source = calibration.flux_density_amplitude(f, im), "calibration"
    losses = separate_losses(params, f, hm, bm, regime)
    if mu_imag is None:
        mu_i = imaginary_permeability(losses.total, hm, f, params.rod_volume)
    else:
        if not (mu_imag >= 0.0 and math.isfinite(mu_imag)):
            raise ParameterError(f"mu_imag = {mu_imag:g} is outside the allowed range [0, inf)")
        mu_i = float(mu_imag)
    if mu_imag is None and not amplitude_permeability(bm, hm) > mu_i:
        bmax = largest_flux_density_amplitude(params, f, hm, regime)
        raise ParameterError(
            f"flux_density_amplitude = {bm:g} T ({source}) makes mu' imaginary (eq 20) at "
            f"f = {f:g} Hz, I_m = {im:g} A: mu'' from the losses (eq 16) grows with B_m "
            f"faster than B_m/(mu_0 H_m), so B_m must lie in the allowed range "
            f"(0, {bmax:.6g}) T")
    mu_r = real_permeability(bm, hm, mu_i)
    return OperatingPoint(f, im, hm, bm, source, mu_r, mu_i, losses)


def largest_flux_density_amplitude(params: TransducerParameters, frequency: float,
                                   field_amplitude: float, regime: str = "intermediate") -> float:
    """Largest B_m for which eq 20 gives a real mu' with mu'' from the losses, [T].

    B_m / (mu_0 H_m) grows linearly with B_m while mu'' of eq 16 grows as
    B_m^n, B_m^2 and B_m^1.5 (all faster), so eq 20 is real on (0, B_max) and
    B_max is the root of B/(mu_0 H_m) = mu''(B).
    """
    def margin(b):
        losses = separate_losses(params, frequency, field_amplitude, b, regime)
        return (amplitude_permeability(b, field_amplitude)
                - imaginary_permeability(losses.total, field_amplitude, frequency,
                                         params.rod_volume))
    hi = 1e-3
    while margin(hi) > 0.0 and hi < 1e3:
        hi *= 2.0
    lo = hi / 2.0
    while margin(lo) <= 0.0 and lo > 1e-12:
        lo /= 2.0
    while hi - lo > 1e-15 + 1e-12 * hi:
        mid = 0.5 * (lo + hi)
        if margin(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def quadrature_current(current, previous_current, current_amplitude,
                       angular_frequency, step, previous_sign=1.0):
    """The paper's i tan(w t) = +-sqrt(I_m^2 - i^2), eq 31, [A].

    Parameters
    ----------
    current : float or array
        i at t_k, [A].
    previous_current : float or array
        i at t_k - h, [A] (equal to ``current`` at the first sample).
    current_amplitude : float
        I_m, [A].
    angular_frequency : float
        w, [rad/s].
    step : float or array
        h = t_k - t_{k-1}, [s].
    previous_sign : float
        Branch (+1 or -1) of the previous sample, kept while the current
        stands still.

    Returns
    -------
    (float or array, float or array)
        i tan(w t) = I_m sin(w t_k) for a sinusoid at (I_m, w), [A], and its
        branch sign; see the module docstring for the rule.
    """
    amp2 = current_amplitude ** 2
    if isinstance(current, float) and isinstance(previous_current, float) \
            and isinstance(step, float):
        # one sample (the stepper's, every step): the same arithmetic on plain
        # floats, without numpy's per-call overhead on scalars (~6 us -> ~1 us)
        curvature = (math.cos(angular_frequency * step)
                     if amp2 - current ** 2 <= amp2 * (angular_frequency * step) ** 2 else 1.0)
        direction = previous_current - current * curvature
        sign = 1.0 if direction > 0.0 else (-1.0 if direction < 0.0 else float(previous_sign))
        return sign * math.sqrt(max(amp2 - current ** 2, 0.0)), sign
    near_reversal = amp2 - current ** 2 <= amp2 * (angular_frequency * step) ** 2
    curvature = np.where(near_reversal, np.cos(angular_frequency * step), 1.0)
    direction = previous_current - current * curvature
    sign = np.where(direction > 0.0, 1.0, np.where(direction < 0.0, -1.0, previous_sign))
    magnitude = np.sqrt(np.maximum(amp2 - current ** 2, 0.0))
    return (sign * magnitude)[()], sign[()]


class Magnetics(NamedTuple):
    """Instantaneous magnetic and magnetostrictive quantities (SI)."""

    field: float  #: H, [A/m] (eq 1)
    quadrature_field: float  #: H tan(w t) = H_m sin(w t), [A/m] (eq 4)
    flux_density: float  #: B, [T] (eq 4)
    magnetization: float  #: M, [A/m] (eq 5)
    strain: float  #: lambda, [-] (eq 25)
    force: float  #: F = A_r E^H lambda, [N] (eq 28)


def magnetics(params: TransducerParameters, point: OperatingPoint, current,
              quadrature):
    """H, B, M, lambda and F for a current and its quadrature part, eqs 1, 4, 5, 25, 28.

    Parameters
    ----------
    current, quadrature : float or array
        i and i tan(w t), [A].
    """
    fpa = params.field_per_ampere
    h = fpa * current
    hq = fpa * quadrature
    b = flux_density(h, hq, point.mu_real, point.mu_imag)
    m = magnetization(h, hq, point.mu_real, point.mu_imag)
    lam = magnetostriction(m, params.bias_magnetization, params.magnetostriction_coefficient)
    force = magnetostrictive_force(lam, params.rod_area, params.youngs_modulus)
    return Magnetics(h, hq, b, m, lam, force)


def bias_displacement(params: TransducerParameters) -> float:
    """Static displacement from the magnet alone, A_r E^H K_lambda M_b^2 / K, [m] (eq 30, i = 0).

    Equal to L K_lambda M_b^2, 73.5 um with Table 2.
    """
    return magnetostrictive_force(
        magnetostriction(0.0, params.bias_magnetization, params.magnetostriction_coefficient),
        params.rod_area, params.youngs_modulus) / params.stiffness


class StepResult(NamedTuple):
    """Outputs of one time step (mechanical state at the end of the step)."""

    magnetics: Magnetics
    displacement: float  #: y at t + h, [m]
    velocity: float  #: dy/dt at t + h, [m/s]


class ForwardStepper:
    """Eq 30 advanced sample by sample (see module docstring).

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
        mu', mu'', I_m and w the complex-permeability model is evaluated at.

    Notes
    -----
    The state is (y, v, previous current, how long it has been held, the
    quadrature's branch); it starts at rest at the bias displacement
    (:func:`bias_displacement`).
    """

    def __init__(self, params: TransducerParameters, point: OperatingPoint):
        self.params = params
        self.point = point
        self.reset()

    def reset(self):
        """Back to rest at the bias operating point."""
        self.displacement = bias_displacement(self.params)
        self.velocity = 0.0
        self.previous_current = math.nan
        self.previous_step = math.nan
        self.branch = 1.0

    def get_state(self) -> tuple:
        """Every piece of state, as a tuple of floats."""
        return (self.displacement, self.velocity, self.previous_current,
                self.previous_step, self.branch)

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        (self.displacement, self.velocity, self.previous_current,
         self.previous_step, self.branch) = (float(s) for s in state)

    def _quadrature(self, current: float, step: float, external_force: float,
                    held: bool = False) -> float:
        """Check one step's inputs; the quadrature current of eq 30 at ``current`` [A].

        Updates the branch memory (the sign of the quadrature current); a
        ``held`` current keeps it.
        """
        if not step > 0.0 or not math.isfinite(step):
            raise ParameterError(f"step = {step!r} s is outside the allowed range (0, inf) s")
        if not math.isfinite(current):
            raise ParameterError(f"current = {current!r} A is not finite")
        if not math.isfinite(external_force):
            raise ParameterError(f"external_force = {external_force!r} N is not finite")
        if held:  # the same sample: the same branch, so the same quadrature part (eq 31)
            amp = self.point.current_amplitude
            return self.branch * math.sqrt(max(amp * amp - current * current, 0.0))
        first = not math.isfinite(self.previous_current)
        prev = current if first else self.previous_current
        h_prev = step if first else self.previous_step
        q, branch = quadrature_current(current, prev, self.point.current_amplitude,
                                       self.point.angular_frequency, h_prev, self.branch)
        self.branch = float(branch)
        return float(q)

    def _advance(self, force, current, step, external_force, mass, damping, stiffness,
                 held=False):
        """Eq 27 over one step by its exact ZOH, the net force F - F_ext held [N]."""
        a11, a12, a21, a22, b1, b2 = mechanics.zoh_matrices(mass, damping, stiffness, step)
        net = float(force) - external_force
        y, v = self.displacement, self.velocity
        self.displacement = a11 * y + a12 * v + b1 * net
        self.velocity = a21 * y + a22 * v + b2 * net
        self._remember(current, step, held)

    def _remember(self, current, step, held):
        """Keep the current and how long it has been held: eq 31's sample interval.

        The pieces of one held sample (a DAC between a digital controller's
        samples) count as one step, so the next sample's quadrature rule sees
        the time since the current was last set.
        """
        self.previous_step = self.previous_step + step if held else step
        self.previous_current = current

    def step(self, current: float, step: float, external_force: float = 0.0,
             held: bool = False) -> StepResult:
        """Advance by ``step`` with ``current`` and ``external_force`` held.

        Parameters
        ----------
        current : float
            Coil current i at the start of the step, [A].
        step : float
            h, [s], > 0.
        external_force : float
            Axial force on the output rod opposing elongation, [N].
        held : bool
            The last step's current, still held (a further piece of one
            sample of a digital controller): its branch of eq 31 is kept.
        """
        q = self._quadrature(current, step, external_force, held)
        mag = magnetics(self.params, self.point, current, q)
        self._advance(mag.force, current, step, external_force, self.params.mass,
                      self.params.damping, self.params.stiffness, held)
        return StepResult(mag, self.displacement, self.velocity)


def simulate(params: TransducerParameters, point: OperatingPoint, current, step: float,
             external_force=0.0) -> dict:
    """Run the time-stepping model over a sampled current at a fixed step.

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
    current : array
        i at t_k = k h, [A].
    step : float
        h, [s].
    external_force : float or array
        F_ext at t_k, [N].

    Returns
    -------
    dict of arrays
        ``time``, ``current``, ``field``, ``quadrature_field``,
        ``flux_density``, ``magnetization``, ``strain``, ``force`` at t_k, and
        ``displacement``, ``velocity`` at t_k (the state before step k is
        taken; index 0 is the initial rest state). Identical, sample for
        sample, to :class:`ForwardStepper`.
    """
    i = np.asarray(current, dtype=float)
    if i.ndim != 1 or i.size == 0:
        raise ParameterError("current must be a non-empty 1-D array")
    if not np.all(np.isfinite(i)):
        raise ParameterError("current contains non-finite values")
    fext = np.broadcast_to(np.asarray(external_force, dtype=float), i.shape)
    prev = np.concatenate((i[:1], i[:-1]))
    _, sign = quadrature_current(i, prev, point.current_amplitude, point.angular_frequency,
                                 step, previous_sign=0.0)
    # a tie (current standing still) keeps the last branch; the first sample takes +1
    sign = np.atleast_1d(sign).copy()
    sign[0] = sign[0] or 1.0
    last = np.maximum.accumulate(np.where(sign != 0.0, np.arange(sign.size), 0))
    sign = sign[last]
    q = sign * np.sqrt(np.maximum(point.current_amplitude ** 2 - i * i, 0.0))
    mag = magnetics(params, point, i, q)
    net = (mag.force - fext).tolist()
    a11, a12, a21, a22, b1, b2 = mechanics.zoh_matrices(
        params.mass, params.damping, params.stiffness, step)
    y = bias_displacement(params)
    v = 0.0
    ys = [0.0] * i.size
    vs = [0.0] * i.size
    for k, f in enumerate(net):
        ys[k] = y
        vs[k] = v
        y, v = a11 * y + a12 * v + b1 * f, a21 * y + a22 * v + b2 * f
    out = {"time": step * np.arange(i.size), "current": i}
    out.update(mag._asdict())
    out["displacement"] = np.array(ys)
    out["velocity"] = np.array(vs)
    return out


def strain_harmonics(params: TransducerParameters, point: OperatingPoint):
    """Complex harmonics (Lambda_0, Lambda_1, Lambda_2) of lambda(t), eq 25.

    For i = I_m cos(w t), M = H_m Re(m e^{jwt}) with m = (mu' - 1) - j mu''
    (eq 5), so lambda = K_lambda (M_b + M)^2 = Re(sum_k Lambda_k e^{jkwt}):
    Lambda_0 = K_lambda (M_b^2 + H_m^2 |m|^2 / 2), Lambda_1 = 2 K_lambda M_b H_m m,
    Lambda_2 = K_lambda H_m^2 m^2 / 2.
    """
    kl = params.magnetostriction_coefficient
    mb = params.bias_magnetization
    hm = point.field_amplitude
    m = magnetization_phasor(point.mu_real, point.mu_imag)
    return (kl * (mb * mb + hm * hm * abs(m) ** 2 / 2.0),
            2.0 * kl * mb * hm * m,
            kl * hm * hm * m * m / 2.0)


def periodic_response(params: TransducerParameters, point: OperatingPoint, time,
                      step: float | None = None, external_force: float = 0.0) -> dict:
    """Periodic steady state of eq 30 for i = I_m cos(w t), in closed form.

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
    time : array
        Times at which to evaluate, [s].
    step : float, optional
        If given, the steady state of the time-stepping model at that step
        (the ZOH-held force through G_d(exp(j k w h))), which the stepper
        reaches once its transient has died; ``time`` should then be
        multiples of ``step``. If omitted, the continuous model.
    external_force : float
        Constant F_ext, [N].

    Returns
    -------
    dict of arrays
        Same keys as :func:`simulate`.
    """
    t = np.asarray(time, dtype=float)
    w = point.angular_frequency
    i = point.current_amplitude * np.cos(w * t)
    q = point.current_amplitude * np.sin(w * t)
    mag = magnetics(params, point, i, q)
    lam = strain_harmonics(params, point)
    gain = params.rod_area * params.youngs_modulus
    gy, gv = mechanics.frequency_response(params.mass, params.damping, params.stiffness,
                                          [0.0, w, 2 * w], step=step)
    y = (gain * lam[0] - external_force) * gy[0].real + np.zeros_like(t)
    v = np.zeros_like(t)
    for k in (1, 2):
        e = np.exp(1j * k * w * t)
        y = y + np.real(gain * lam[k] * gy[k] * e)
        v = v + np.real(gain * lam[k] * gv[k] * e)
    out = {"time": t, "current": i}
    out.update(mag._asdict())
    out["displacement"] = y
    out["velocity"] = v
    return out


def loop_metrics(params: TransducerParameters, point: OperatingPoint,
                 samples: int = 4096) -> dict:
    """Peak-to-peak displacement and dy = y(i = I_m) - y(i = -I_m) in steady state.

    dy is the stroke between the two instants an uncompensated valve drive
    switches (eq 40), [m]; ``peak_to_peak`` is max - min of y, [m]. ``samples``
    must be even: i = +I_m and i = -I_m are then samples 0 and samples/2.
    """
    if samples < 2 or samples % 2:
        raise ParameterError(f"samples = {samples} must be an even number >= 2")
    period = 1.0 / point.frequency
    t = np.linspace(0.0, period, samples, endpoint=False)
    y = periodic_response(params, point, t)["displacement"]
    return {"peak_to_peak": float(y.max() - y.min()), "dy": float(y[0] - y[samples // 2]),
            "y_max": float(y.max()), "y_min": float(y.min())}
