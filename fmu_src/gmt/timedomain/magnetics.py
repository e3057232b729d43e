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
smooth there), safeguarded by bisection inside a bracket known in advance.

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
from ..errors import ParameterError
from ..forward import Magnetics, StepResult, bias_displacement
from ..magnetostriction import magnetostriction
from ..parameters import TransducerParameters
from .hysteresis import BranchFunction, SteinmetzHysteresis
from .parameters import TimeDomainParameters
from .separation import eddy_field_coefficient, excess_field_coefficient

__all__ = ["TimeDomainMagnetics", "TimeDomainStepper"]

#: Newton's iterations stop when the change in B is below this, [T].
B_TOLERANCE = 1e-12
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
        self.branch = BranchFunction(p.hysteresis_coefficient, p.steinmetz_exponent,
                                     td.steinmetz_lower, td.steinmetz_upper)
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
        """The solver's last slope (its next first guess), then the hysteresis memory."""
        return (self._slope,) + self.hysteresis.get_state()

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        self._slope = float(state[0])
        self.hysteresis.set_state(state[1:])
        self._last = (math.nan, math.nan)

    # -- the field separation -----------------------------------------------
    def field(self, flux_density: float, step: float) -> float:
        """Applied field that takes B from now to ``flux_density`` over ``step``, [A/m].

        The backward-Euler form of the field separation, explicit in B: the
        inverse of :meth:`solve`. The memory is not changed.
        """
        b0 = self.hysteresis.b
        h_irr = (self._last[1] if flux_density == self._last[0]
                 else self.hysteresis.evaluate(flux_density)[0])
        rate = (flux_density - b0) / step
        root = math.sqrt(abs(rate))
        eddy = self.eddy_stiffness(1.0 if rate >= 0.0 else -1.0, step)
        return (self.nu * flux_density + h_irr + eddy * (flux_density - b0)
                + (self.k_ex * root if rate >= 0.0 else -self.k_ex * root))

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
        """
        if not (step > 0.0 and math.isfinite(step)):
            raise ParameterError(f"step = {step!r} s is outside the allowed range (0, inf) s")
        if not math.isfinite(field):
            raise ParameterError(f"field = {field!r} A/m is not finite")
        op = self.hysteresis
        b0 = op.b
        r0 = self.nu * b0 + op.h - field
        if r0 == 0.0:
            self._last = (b0, op.h)
            return b0
        s = -1.0 if r0 > 0.0 else 1.0
        excess = self.k_ex / math.sqrt(step)
        start, h_start, limit = op.branch_towards(s)
        eddy = self.eddy_stiffness(s, step, start)
        linear = eddy + self.nu
        # f(u) = s R(b0 + s u^2) rises from -|r0|; f(u) >= -|r0| + linear u^2 + excess u
        need = abs(r0)
        hi = (-excess + math.sqrt(excess * excess + 4.0 * linear * need)) / (2.0 * linear)
        lo = 0.0
        # first guess: the same quadratic with the operator's slope at the last solution
        steep = linear + self._slope
        u = (-excess + math.sqrt(excess * excess + 4.0 * steep * need)) / (2.0 * steep)
        g_branch = self.branch.value_and_slope
        for _ in range(_MAX_ITERATIONS):
            b = b0 + s * u * u
            if s * (b - limit) > 0.0 or start != start:  # wipes a reversal out, or virgin
                h_irr, slope = op.evaluate(b)
            else:  # on the branch the move starts on (the usual case)
                g, slope = g_branch(s * (b - start))
                h_irr = h_start + s * g
            self._slope = slope
            f = s * (self.nu * b + h_irr - field) + eddy * u * u + excess * u
            if f > 0.0:
                hi = u
            else:
                lo = u
            df = 2.0 * u * (linear + slope) + excess
            new = u - f / df if df > 0.0 else 0.5 * (lo + hi)
            if lo <= new <= hi and abs(new * new - u * u) <= B_TOLERANCE:
                self._last = (b, h_irr)  # converged: this B (within the tolerance of new)
                return b
            if not lo < new < hi:
                new = 0.5 * (lo + hi)
            if hi - lo <= 1e-15:
                break
            u = new
        else:  # pragma: no cover - the bracket halves at worst, 60 halvings suffice
            raise ParameterError(f"no flux density found for field = {field:g} A/m")
        self._last = (b, h_irr)
        return b

    def step(self, field: float, step: float) -> float:
        """Advance B over a step with ``field`` held; commit the memory; return B [T]."""
        b = self.solve(field, step)
        self.move(b)
        return b

    def move(self, flux_density: float) -> None:
        """Commit the memory to B = ``flux_density`` [T] (reached monotonically from now)."""
        last_b, last_h = self._last
        self.hysteresis.move(flux_density, last_h if flux_density == last_b else None)

    def flux_density_for(self, magnetization: float) -> float:
        """B at which M = B/mu_0 - H_hys(B) equals ``magnetization`` [A/m], from here, [T].

        dM/dB lies between ``smallest_magnetization_slope`` and
        1/mu_0 - 1/(mu_0 mu_rev) on every branch, which brackets the root; the
        memory is not changed.
        """
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
        b = b0 + miss / max(steep - self._slope, flat)
        start, h_start, limit = op.branch_towards(s)
        g_branch = self.branch.value_and_slope
        for _ in range(_MAX_ITERATIONS):
            if not lo <= b <= hi:
                b = 0.5 * (lo + hi)
            if s * (b - limit) > 0.0 or start != start:  # wipes a reversal out, or virgin
                h_irr, slope = op.evaluate(b)
            else:
                g, slope = g_branch(s * (b - start))
                h_irr = h_start + s * g
            self._slope = slope
            g = b / MU_0 - self.nu * b - h_irr - magnetization
            if g > 0.0:
                hi = b
            else:
                lo = b
            new = b - g / (steep - slope)
            if lo <= new <= hi and abs(new - b) <= B_TOLERANCE:
                self._last = (b, h_irr)
                return b
            if not lo < new < hi:
                new = 0.5 * (lo + hi)
            b = new
        self._last = (math.nan, math.nan)
        return b


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
