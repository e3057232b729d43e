"""B(t) from any coil current: the field separation solved per step, then M, lambda, F.

The applied field H = N i / (k_f L) (eq 1) is split as (Bertotti, see
:mod:`gmt.timedomain.separation`)

    H = H_hys(B, history) + k_e dB/dt + k_ex |dB/dt|^(1/2) sign(dB/dt),
    H_hys = B / (mu_0 mu_rev) + H_irr(B, history),

H_irr the hysteresis operator of :mod:`gmt.timedomain.hysteresis`. Over a
step h with the current (so H) held, as an FMI input is held, the equation is
solved implicitly for the B at the end of the step (backward Euler in B,
dB/dt = (B - B_0)/h). Every term is non-decreasing in B and k_e/h + 1/(mu_0
mu_rev) > 0, so the step equation has exactly one root for any h: the step is
stable at any co-simulation step and cannot oscillate. The root is found by
Newton's method in u = sqrt(|B - B_0|) (the excess term is linear in u, so
smooth there), safeguarded by bisection inside a bracket known in advance;
one solver (:func:`_safeguarded_newton`) serves this and the inverse's
:meth:`TimeDomainMagnetics.flux_density_for`, and raises
:class:`gmt.ConvergenceError` when it does not converge.

The extended dynamic law of :mod:`gmt.timedomain.dynamic` (off by default)
adds the rate field k_w dB_pp^(beta - q) |dB/dt|^(q - 1) sign(dB/dt) and the
relaxation field k_r dB_pp^(beta - 2) x to H. Both are non-decreasing in the
step's B (the relaxation's lag advances exactly, x(h) = x_0 e^(-h/tau) +
dB/dt tau (1 - e^(-h/tau))), dB_pp is read from the hysteresis memory at the
step's start, so the step equation keeps its single root and its bracket.
A second stop density (``second_hysteresis_coefficient``, also off by
default) is superposed on the operator's
(:class:`gmt.timedomain.hysteresis.BranchSum`): H_irr stays non-decreasing
along every branch, and the same holds.

Magnetisation
-------------
The eddy and excess terms are the mean field of the currents induced in the
rod (for a lamination of thickness delta, the classical eddy field varies
across it with mean (gamma delta^2/12) dB/dt, eq 8); the material itself sees
the field H_hys. So its magnetisation is

    M = B / mu_0 - H_hys(B, history),

a function of B and its history only, as eq 5's M = B/mu_0 - H is for the
sinusoid the paper's mu', mu'' describe (there H's quadrature part carries
the lag of every loss). Taking the applied H instead would make M jump
against a current step (it would contain -k_e dB/dt) and the transducer
non-minimum-phase, with no stable inverse. The operator is built so that
dM/dB > 0 on every branch (:class:`TimeDomainMagnetics` checks it), so M and B
determine each other given the history: the inverse is explicit.

Then lambda = K_lambda (M + M_b)^2 (eq 25), F = A_r E^H lambda (eq 28), and
the rod follows eq 27. B is continuous, so F is: the mechanics take the mean
of the step's end forces, held over the step (second order).
"""
from __future__ import annotations

import math

from .. import mechanics
from ..constants import MU_0
from ..errors import ConvergenceError, ParameterError
from ..forward import Magnetics, StepResult, bias_displacement
from ..magnetostriction import magnetostriction
from ..parameters import TransducerParameters
from .dynamic import rate_field, relaxation_lag
from .hysteresis import BranchFunction, BranchSum, SteinmetzHysteresis
from .parameters import TimeDomainParameters
from .separation import eddy_field_coefficient, excess_field_coefficient

__all__ = ["TimeDomainMagnetics", "TimeDomainStepper"]

#: Newton's iterations stop when the change in B is below this, [T].
B_TOLERANCE = 1e-12
#: Evaluations the safeguarded Newton may take (the bracket at least halves in each).
_MAX_ITERATIONS = 60


class TimeDomainMagnetics:
    """The field separation of one rod with its hysteresis memory (module docstring).

    Parameters
    ----------
    params : TransducerParameters
        K_h, n, K_e, K_ex and the coil (Table 2).
    td : TimeDomainParameters

    Raises
    ------
    ParameterError
        When the hysteresis operator's reversal slope reaches 1/mu_0 (M would
        fall as B rises just after a reversal): a smaller K_h or a larger
        ``steinmetz_lower`` or ``reversible_permeability`` is needed.
    """

    def __init__(self, params: TransducerParameters | None = None,
                 td: TimeDomainParameters | None = None):
        self.params = params or TransducerParameters()
        self.td = td or TimeDomainParameters()
        p, td = self.params, self.td
        self.k_e = eddy_field_coefficient(p.eddy_coefficient)
        self.k_ex = excess_field_coefficient(p.excess_coefficient)
        self.nu = td.reversible_field_per_tesla
        limits = (td.steinmetz_lower, td.steinmetz_upper, td.steinmetz_break,
                  td.steinmetz_exponent_high)
        self.branch = BranchFunction(p.hysteresis_coefficient, p.steinmetz_exponent, *limits)
        if td.second_hysteresis_coefficient > 0.0:
            self.branch = BranchSum(self.branch, BranchFunction(
                td.second_hysteresis_coefficient, td.second_steinmetz_exponent, *limits))
        steepest = self.nu + self.branch.reversal_slope
        if not steepest < 1.0 / MU_0:
            raise ParameterError(
                f"steinmetz_lower = {td.steinmetz_lower:g} T with reversible_permeability = "
                f"{td.reversible_permeability:g} and hysteresis_coefficient = "
                f"{p.hysteresis_coefficient:g}: dH_hys/dB at a reversal is {steepest:.4g} A/(m T), "
                f"which must stay below 1/mu_0 = {1.0 / MU_0:.4g} A/(m T) (M rising with B); "
                "raise steinmetz_lower or reversible_permeability")
        #: smallest dM/dB on any branch, [A/(m T)]
        self.smallest_magnetization_slope = 1.0 / MU_0 - steepest
        self.hysteresis = SteinmetzHysteresis(self.branch)
        self.reset()  # the solver keeps the operator's last dH_irr/dB as its next guess

    # -- state ---------------------------------------------------------------
    def reset(self):
        """Demagnetised, at rest: B = 0 (the bias point), no reversals."""
        self.hysteresis.reset()
        self._slope = self.branch.reversal_slope
        self._last = (math.nan, math.nan)  # the last B solved for and its H_irr
        self._lag = 0.0  # x of the relaxation (gmt.timedomain.dynamic), [T]
        self._step = math.nan  # the step of the last solve or field, [s]

    @property
    def flux_density(self) -> float:
        """B now, [T] (about the bias)."""
        return self.hysteresis.b

    def static_field(self) -> float:
        """H_hys now, [A/m]."""
        return self.nu * self.hysteresis.b + self.hysteresis.h

    def magnetization(self) -> float:
        """M = B/mu_0 - H_hys now, [A/m]."""
        return self.hysteresis.b / MU_0 - self.static_field()

    def get_state(self) -> tuple:
        """The solver's last slope (its next first guess), the relaxation lag, then the
        hysteresis memory."""
        return (self._slope, self._lag) + self.hysteresis.get_state()

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        self._slope = float(state[0])
        self._lag = float(state[1])
        self.hysteresis.set_state(state[2:])
        self._last = (math.nan, math.nan)

    # -- the field separation -----------------------------------------------
    def field(self, flux_density: float, step: float) -> float:
        """Applied field that takes B from now to ``flux_density`` over ``step``, [A/m].

        The backward-Euler form of the field separation, explicit in B: the
        inverse of :meth:`solve`. The memory is not changed.
        """
        b0 = self.hysteresis.b
        self._step = step
        h_irr = (self._last[1] if flux_density == self._last[0]
                 else self.hysteresis.evaluate(flux_density)[0])
        rate = (flux_density - b0) / step
        root = math.sqrt(abs(rate))
        eddy = self.eddy_stiffness(1.0 if rate >= 0.0 else -1.0, step)
        h = (self.nu * flux_density + h_irr + eddy * (flux_density - b0)
             + (self.k_ex * root if rate >= 0.0 else -self.k_ex * root))
        td = self.td
        if td.has_extension:
            stiffness, held = self._relaxation_terms(step)
            h += held + stiffness * (flux_density - b0) + rate_field(
                rate, self.loop_swing(), td.rate_coefficient, td.rate_exponent,
                td.swing_exponent)
        return h

    def eddy_stiffness(self, direction: float, step: float, start: float | None = None) -> float:
        """The eddy term's dH per dB over a step, k_e/h fitted to the exponential, [A/(m T)].

        Over a step with H held, the eddy term alone relaxes B towards the static
        curve as exp(-t S/k_e), S = dH_hys/dB along the branch the move starts on.
        Backward Euler's k_e/h gives that relaxation to first order in x = h S/k_e;
        S/(e^x - 1) gives it exactly for the linearised curve (exponential fitting,
        Liniger & Willoughby 1970; Hairer & Wanner, *Solving Ordinary Differential
        Equations II*, 1996, IV.3), and tends to k_e/h as h -> 0. So one step of the
        held current lands where fine steps would: the forward model barely depends
        on the step, and an inverse that plans a sample in one step stays in tune
        with a forward model stepped more finely. Forward (:meth:`solve`) and inverse
        (:meth:`field`) use the same value. ``start``: the branch's reversal point
        (:meth:`SteinmetzHysteresis.branch_towards`), when the caller has it.
        """
        op = self.hysteresis
        if start is None:
            start = op.branch_towards(direction)[0]
        swing = 2.0 * abs(op.b) if start != start else abs(op.b - start)
        if not self.k_e > 0.0:
            return 0.0
        slope = self.nu + self.branch.slope(swing)
        x = step * slope / self.k_e
        if x < 1e-8:
            return self.k_e / step
        return slope * math.exp(-x) if x > 50.0 else slope / math.expm1(x)

    def solve(self, field: float, step: float) -> float:
        """B at the end of a step of ``step`` [s] with the applied ``field`` [A/m] held, [T].

        The root of the step equation (module docstring); the memory is not changed.

        Raises
        ------
        ParameterError
            A step outside (0, inf) s or a field that is not finite.
        ConvergenceError
            When the safeguarded Newton iteration does not converge.
        """
        if not (step > 0.0 and math.isfinite(step)):
            raise ParameterError(f"step = {step!r} s is outside the allowed range (0, inf) s")
        if not math.isfinite(field):
            raise ParameterError(f"field = {field!r} A/m is not finite")
        op = self.hysteresis
        b0 = op.b
        self._step = step
        relax_stiffness, relax_held = self._relaxation_terms(step)
        r0 = self.nu * b0 + op.h + relax_held - field
        if r0 == 0.0:
            self._last = (b0, op.h)
            return b0
        s = -1.0 if r0 > 0.0 else 1.0
        excess = self.k_ex / math.sqrt(step)
        start, h_start, limit = op.branch_towards(s)
        eddy = self.eddy_stiffness(s, step, start) + relax_stiffness
        linear = eddy + self.nu
        rate_gain, rate_power = self._rate_terms(step)
        # f(u) = s R(b0 + s u^2) rises from -|r0|; f(u) >= -|r0| + linear u^2 + excess u
        need = abs(r0)
        hi = (-excess + math.sqrt(excess * excess + 4.0 * linear * need)) / (2.0 * linear)
        # first guess: the same quadratic with the operator's slope at the last solution
        steep = linear + self._slope
        u = (-excess + math.sqrt(excess * excess + 4.0 * steep * need)) / (2.0 * steep)

        def residual(u):
            b = b0 + s * u * u
            h_irr, slope = self._irreversible(b, s, start, h_start, limit)
            f = s * (self.nu * b + h_irr - field) + eddy * u * u + excess * u
            df = 2.0 * u * (linear + slope) + excess
            if rate_gain:
                f += rate_gain * u ** rate_power
                df += rate_power * rate_gain * u ** (rate_power - 1.0) if u > 0.0 else 0.0
            return f, df, (b, h_irr)

        b, h_irr = _safeguarded_newton(residual, 0.0, hi, u, lambda u: u * u,
                                       f"flux density for field = {field:g} A/m")
        self._last = (b, h_irr)
        return b

    def _irreversible(self, b, s, start, h_start, limit):
        """(H_irr, dH_irr/dB) at ``b`` reached in direction ``s`` from now; keeps the slope."""
        if s * (b - limit) > 0.0 or start != start:  # wipes a reversal out, or virgin
            h_irr, slope = self.hysteresis.evaluate(b)
        else:  # on the branch the move starts on (the usual case)
            g, slope = self.branch.value_and_slope(s * (b - start))
            h_irr = h_start + s * g
        self._slope = slope
        return h_irr, slope

    def loop_swing(self) -> float:
        """dB_pp of the loop now, from the hysteresis memory, [T] (at least 2 r_0).

        The larger of the last two reversals' distance and the distance from the
        last reversal to B; 2 |B| before any reversal.
        """
        op = self.hysteresis
        rb = op.reversals
        swing = 2.0 * abs(op.b)
        if rb:
            swing = max(abs(op.b - rb[-1]), 2.0 * abs(rb[-1]) if len(rb) == 1
                        else abs(rb[-1] - rb[-2]))
        return max(swing, 2.0 * self.td.steinmetz_lower)

    def _rate_terms(self, step):
        """(g, p): the rate field's s H_w over a step is g u^p, u = sqrt(|dB|)."""
        td = self.td
        if not td.rate_coefficient > 0.0:
            return 0.0, 0.0
        q = td.rate_exponent
        gain = (td.rate_coefficient * self.loop_swing() ** (td.swing_exponent - q)
                * step ** (1.0 - q))
        return gain, 2.0 * q - 2.0

    def _relaxation_terms(self, step):
        """(dH_r/dB over the step, H_r with B held), the relaxation field at the step's end."""
        td = self.td
        if not td.relaxation_coefficient > 0.0:
            return 0.0, 0.0
        k = td.relaxation_coefficient * self.loop_swing() ** (td.swing_exponent - 2.0)
        tau = td.relaxation_time
        return (-k * tau * math.expm1(-step / tau) / step,
                k * relaxation_lag(self._lag, 0.0, step, tau))

    def step(self, field: float, step: float) -> float:
        """Advance B over a step with ``field`` held; commit the memory; return B [T]."""
        b = self.solve(field, step)
        self.move(b)
        return b

    def move(self, flux_density: float) -> None:
        """Commit the memory to B = ``flux_density`` [T] (reached monotonically from now).

        The relaxation lag advances over the step of the last :meth:`solve` or
        :meth:`field`.
        """
        last_b, last_h = self._last
        if self.td.relaxation_coefficient > 0.0:
            rate = (flux_density - self.hysteresis.b) / self._step
            self._lag = relaxation_lag(self._lag, rate, self._step, self.td.relaxation_time)
        self.hysteresis.move(flux_density, last_h if flux_density == last_b else None)

    def flux_density_for(self, magnetization: float) -> float:
        """B at which M = B/mu_0 - H_hys(B) equals ``magnetization`` [A/m], from here, [T].

        dM/dB lies between ``smallest_magnetization_slope`` and
        1/mu_0 - 1/(mu_0 mu_rev) on every branch, which brackets the root; the
        memory is not changed.

        Raises
        ------
        ParameterError
            A magnetization that is not finite.
        ConvergenceError
            When the safeguarded Newton iteration does not converge.
        """
        if not math.isfinite(magnetization):
            raise ParameterError(f"magnetization = {magnetization!r} A/m is not finite")
        op = self.hysteresis
        b0 = op.b
        miss = magnetization - (b0 / MU_0 - self.nu * b0 - op.h)
        if miss == 0.0:
            return b0
        s = 1.0 if miss > 0.0 else -1.0
        steep, flat = 1.0 / MU_0 - self.nu, self.smallest_magnetization_slope
        near, far = b0 + miss / steep, b0 + miss / flat
        lo, hi = (near, far) if miss > 0.0 else (far, near)
        # first guess: the slope of M(B) at the last solution
        guess = b0 + miss / max(steep - self._slope, flat)
        start, h_start, limit = op.branch_towards(s)

        def residual(b):
            h_irr, slope = self._irreversible(b, s, start, h_start, limit)
            return b / MU_0 - self.nu * b - h_irr - magnetization, steep - slope, (b, h_irr)

        b, h_irr = _safeguarded_newton(residual, lo, hi, guess, lambda b: b,
                                       f"flux density for magnetization = {magnetization:g} A/m")
        self._last = (b, h_irr)
        return b


def _safeguarded_newton(residual, lo, hi, x, flux_of, what):
    """Root of a rising ``residual`` in [lo, hi]: Newton's steps, bisection when they leave it.

    Parameters
    ----------
    residual : callable x -> (f, df/dx, payload)
        Rising in x on [lo, hi], f(lo) <= 0 <= f(hi).
    lo, hi, x : the bracket and the first guess.
    flux_of : callable x -> B [T]
        Convergence is judged in B: a Newton step that stays in the bracket and
        moves B by at most :data:`B_TOLERANCE`, or a bracket narrower than that in B.
    what : str
        The quantity, for the error message.

    Returns
    -------
    payload of the last evaluation

    Raises
    ------
    ConvergenceError
        After :data:`_MAX_ITERATIONS` evaluations without convergence.
    """
    for _ in range(_MAX_ITERATIONS):
        if not lo <= x <= hi:
            x = 0.5 * (lo + hi)
        f, df, payload = residual(x)
        if f > 0.0:
            hi = x
        else:
            lo = x
        new = x - f / df if df > 0.0 else 0.5 * (lo + hi)
        if lo <= new <= hi and abs(flux_of(new) - flux_of(x)) <= B_TOLERANCE:
            return payload
        if abs(flux_of(hi) - flux_of(lo)) <= B_TOLERANCE:
            return payload
        x = new if lo < new < hi else 0.5 * (lo + hi)
    raise ConvergenceError(
        f"{what}: no convergence in {_MAX_ITERATIONS} iterations (bracket [{flux_of(lo):.12g}, "
        f"{flux_of(hi):.12g}] T)")


class TimeDomainStepper:
    """Eq 27 driven by the time-domain magnetics, step by step (any current waveform).

    The same interface as :class:`gmt.forward.ForwardStepper`: a step takes
    the current at its start, holds it over the step, and returns the
    mechanical state at its end. The returned magnetics are those at the
    step's start (B, M, lambda, F before the step, H the held field), as the
    paper stepper's are; ``quadrature_field`` is 0 (there is no sinusoid).

    Parameters
    ----------
    params : TransducerParameters
    td : TimeDomainParameters
    """

    def __init__(self, params: TransducerParameters | None = None,
                 td: TimeDomainParameters | None = None):
        self.params = params or TransducerParameters()
        self.magnetics = TimeDomainMagnetics(self.params, td)
        self.td = self.magnetics.td
        p = self.params
        self._fpa = p.field_per_ampere
        self._force_per_strain = p.rod_area * p.youngs_modulus  # eq 28
        self._mechanics = (p.mass, p.damping, p.stiffness)
        self.reset()

    def reset(self):
        """Back to rest at the bias operating point, demagnetised."""
        self.magnetics.reset()
        self.displacement = bias_displacement(self.params)
        self.velocity = 0.0

    def get_state(self) -> tuple:
        """(y, v, then the hysteresis memory), floats."""
        return (self.displacement, self.velocity) + self.magnetics.get_state()

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        state = tuple(float(v) for v in state)
        self.displacement, self.velocity = state[:2]
        self.magnetics.set_state(state[2:])

    def force_of(self, magnetization: float) -> tuple[float, float]:
        """(lambda, F) for a magnetisation, eqs 25 and 28."""
        p = self.params
        lam = magnetostriction(magnetization, p.bias_magnetization,
                               p.magnetostriction_coefficient)
        return lam, self._force_per_strain * lam

    def step(self, current: float, step: float, external_force: float = 0.0,
             held: bool = False) -> StepResult:
        """Advance by ``step`` [s] with ``current`` [A] and ``external_force`` [N] held.

        ``held`` is accepted for the paper stepper's interface; the
        time-domain state needs no branch memory for it.
        """
        if not math.isfinite(current):
            raise ParameterError(f"current = {current!r} A is not finite")
        if not math.isfinite(external_force):
            raise ParameterError(f"external_force = {external_force!r} N is not finite")
        mag = self.magnetics
        h = self._fpa * current
        b0, m0 = mag.flux_density, mag.magnetization()
        lam0, f0 = self.force_of(m0)
        mag.step(h, step)
        _, f1 = self.force_of(mag.magnetization())
        a11, a12, a21, a22, b1, b2 = mechanics.zoh_matrices(*self._mechanics, step)
        net = 0.5 * (f0 + f1) - external_force
        y, v = self.displacement, self.velocity
        self.displacement = a11 * y + a12 * v + b1 * net
        self.velocity = a21 * y + a22 * v + b2 * net
        return StepResult(Magnetics(h, 0.0, b0, m0, lam0, f0), self.displacement, self.velocity)
