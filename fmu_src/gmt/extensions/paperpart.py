"""The paper's part of the permeability beside the extensions: eq 16 solved for B_m.

The coil measures the total flux density. Where an extension adds to the magnetisation
(a hysteresis, a saturation) or makes the field inside lag (eddy currents), the paper's
part of the magnetisation is the one that makes the total's |B_1| the run's measured B_m:
|mu_p(a) g + p| = modulus, a = |mu_p|, mu''_p from eq 16 at the part's own flux density
and mu'_p from eq 20 (:func:`paper_permeability`; the stages are described in
:mod:`gmt.extensions.steady`).

Two iterations solve it. Where the magnetisation stage's fundamental p does not depend on
the paper's part (outputs that are operators of H alone: the Preisach density, the
Prandtl-Ishlinskii operator; :func:`gmt.extensions.steady.stage_adder` gives it as a
constant), |mu_p(a) g + p| and its derivative in a are explicit and Newton's method
solves it (:func:`_newton`), the least root by a scan and a bracketed Newton iteration
(:func:`_first_root_newton`). Otherwise (a saturation maps M through its law) the secant
method (:func:`_secant`) and regula falsi (:func:`_first_root`) need only the function.
Both end where |err| is within 1e-13 of the modulus, each run held from the iteration
it gets there: a run's root does not depend on the runs solved with it (the diagnosis
evaluates a point and its finite-difference steps as one batch,
``smeha.diagnose.differences``; a run iterated on while others converged moved by up to
that tolerance, 1e-5 of a derivative over a step of 1.5e-8).
"""
from __future__ import annotations

import math

import numpy as np

from ..constants import MU_0

__all__ = ["LOSS_ANGLE_CAP", "SECANT_TRUSTED", "ROOT_SCAN", "mu_imag_from_losses",
           "paper_permeability", "uncapped_limit"]

#: mu'' of eq 16 is held at most this fraction of |mu| (a loss angle short of 90 degrees:
#: mu' of eq 20 stays real); where eq 16 asks more the permeability is on its cap.
LOSS_ANGLE_CAP = 0.999

def mu_imag_from_losses(loss, frequency, flux_density_amplitude, field_amplitude):
    """mu'' of eq 16 (eqs 7, 9, 11, 13) for loss = (K_h, n, K_e, K_ex), [-] (arrays allowed).

    pi f mu_0 mu'' H_m^2 = K_h B_m^n f + K_e (B_m f)^2 + K_ex (B_m f)^1.5.
    """
    kh, n, ke, kex = loss
    bm, f = flux_density_amplitude, frequency
    p = kh * bm ** n * f + ke * (bm * f) ** 2 + kex * (bm * f) ** 1.5
    return p / (math.pi * f * MU_0 * field_amplitude * field_amplitude)


def paper_permeability(loss, frequency, field_amplitude, modulus, gain=1.0, adder=None,
                       loss_flux_factor=1.0, vacuum=0.0):
    """mu_p = mu' - j mu'' of the paper's part of the magnetisation, [-] (arrays allowed).

    The coil measures |B_1| = mu_0 H_m |mu_p g + p| = mu_0 H_m ``modulus`` (eq 22),
    where g is the field stage's mean field per applied field (1 without eddy
    currents) and p the fundamental the magnetisation stage adds to M per unit
    H_m, ``adder(M_1)`` of the paper part's fundamental M_1 = (mu_p - 1) g H_m
    (None: p = 0). mu''_p follows eq 16 at the paper part's own flux density
    amplitude, mu_0 |mu_p| H_m times ``loss_flux_factor`` (capped just below
    |mu_p|), and mu'_p eq 20, mu'_p = sqrt(|mu_p|^2 - mu''_p^2). For p = 0 this
    is |mu_p| = modulus / |g| in closed form (the paper's eqs 16, 20 for g = 1);
    otherwise |mu_p| = a is the least root of |mu_p(a) g + p| - modulus, the one on the
    branch where mu'' is short of its cap (:func:`_first_root`). ``vacuum`` is the
    unshielded vacuum field per H_m the coil sees outside the field stage's lag
    (:meth:`gmt.extensions.Extension.vacuum_share`), added to p.
    """
    g = np.asarray(gain, dtype=complex)
    hm = np.asarray(field_amplitude, dtype=float)

    def mu_of(a):
        mu_i = np.minimum(mu_imag_from_losses(loss, frequency, MU_0 * a * hm * loss_flux_factor,
                                              hm), LOSS_ANGLE_CAP * a)
        return np.sqrt(a * a - mu_i * mu_i) - 1j * mu_i

    a = modulus / np.abs(g)
    if np.any(vacuum):  # unshielded vacuum flux the coil sees adds a constant to p
        inner = adder

        def adder(m1):
            return vacuum + (0.0 if inner is None else inner(m1))
        if inner is None or getattr(inner, "constant", None) is not None:
            adder.constant = vacuum + (0.0 if inner is None else inner.constant)
    if adder is None:
        return mu_of(a)
    constant = getattr(adder, "constant", None)
    if constant is not None:
        law = _permeability_law(loss, frequency, hm, loss_flux_factor)

        def err(a):
            mu, slope = law(a)
            z = mu * g + constant
            size = np.abs(z)
            return size - modulus, np.real(np.conj(z) * g * slope) / size

        a, converged = _newton(err, a, modulus, np.abs(g))
        first_root = _first_root_newton
    else:
        def err(a):
            mu = mu_of(a)
            return np.abs(mu * g + adder((mu - 1.0) * g * hm)) - modulus

        a, converged = _secant(err, a, modulus, np.abs(g))
        first_root = _first_root
    # a root where eq 16's loss angle is large may be the second one by the cap
    # (_first_root): there, and where the iteration did not converge, the least root
    suspect = ~converged | (-mu_of(a).imag / a > SECANT_TRUSTED)
    if np.any(suspect):
        first, found = first_root(err, modulus / np.abs(g), uncapped_limit(
            loss, frequency, hm, loss_flux_factor), modulus)
        a = np.where(suspect & found, first, a)
    return mu_of(a)


def _loss_coefficients(loss, frequency, field_amplitude, loss_flux_factor=1.0):
    """(c_h, c_e, c_x), each per run: eq 16 at B_m = mu_0 a H_m (times
    ``loss_flux_factor``) is mu'' = c_h a^n + c_e a^2 + c_x a^1.5, [-]."""
    kh, n, ke, kex = loss
    hm = np.asarray(field_amplitude, dtype=float)
    f = np.asarray(frequency, dtype=float)
    b1 = MU_0 * hm * loss_flux_factor  # B_m per unit a
    d = math.pi * f * MU_0 * hm * hm
    return kh * b1 ** n * f / d, ke * (b1 * f) ** 2 / d, kex * (b1 * f) ** 1.5 / d


def _permeability_law(loss, frequency, field_amplitude, loss_flux_factor=1.0):
    """a -> (mu_p(a), d mu_p / d a): mu'' of eq 16 at a = |mu_p| (:func:`_loss_coefficients`),
    capped at :data:`LOSS_ANGLE_CAP` a, and mu' = sqrt(a^2 - mu''^2) of eq 20, [-]: the
    value of ``mu_of`` in :func:`paper_permeability` (to rounding), with its derivative."""
    n = loss[1]
    c_h, c_e, c_x = _loss_coefficients(loss, frequency, field_amplitude, loss_flux_factor)

    def law(a):
        root = np.sqrt(a)
        raw = c_h * a ** n + (c_e * a + c_x * root) * a
        raw_slope = n * c_h * a ** (n - 1.0) + 2.0 * c_e * a + 1.5 * c_x * root
        capped = raw > LOSS_ANGLE_CAP * a
        mu_i = np.where(capped, LOSS_ANGLE_CAP * a, raw)
        mu_i_slope = np.where(capped, LOSS_ANGLE_CAP, raw_slope)
        mu_r = np.sqrt(a * a - mu_i * mu_i)
        return mu_r - 1j * mu_i, (a - mu_i * mu_i_slope) / mu_r - 1j * mu_i_slope
    return law


#: mu''/|mu_p| of eq 16 up to which the secant's root is taken as it is, without the scan
#: of :func:`_first_root` (a saving: the scan costs some 20 evaluations of the stage). The
#: spurious roots seen lay at 0.999 (on the cap), the least roots beside them at 0.83 and
#: 0.93 (labsim's Preisach density with saturation and with eddy diffusion, 200 Hz at 1 A);
#: a heuristic bound, not a proof that no second root lies lower.
SECANT_TRUSTED = 0.9


#: Points of the scan for the first root of |mu_p g + p| - modulus (:func:`_first_root`).
ROOT_SCAN = 12


def _first_root(err, a0, a_cap, modulus):
    """(a, found): the least a in (0, min(a_cap, 4 a0)] with err(a) = 0, per run, and
    whether there is one; ``a0`` the closed form modulus / |g| (arrays of runs).

    |mu_p g + p| grows with a = |mu_p| while eq 16's mu'' is well below a, but near the
    cap (:data:`LOSS_ANGLE_CAP`) mu' = sqrt(a^2 - mu''^2) collapses and |mu_p g + p| can
    fall again: a second, spurious root lies there, the loss angle near 90 degrees. The
    secant iteration from the closed form found either (labsim's Preisach density with
    saturation at 200 Hz and 1 A: it stalled by the cap as M_b/M_s passed 0.006, y's
    fundamental by 11 um, and the combination's fit could not descend). So the first sign
    change on :data:`ROOT_SCAN` points is bracketed and refined by regula falsi with the
    Illinois modification (Dowell & Jarratt, BIT 11 (1971) 168-174).
    """
    top = np.minimum(a_cap, 4.0 * a0)
    lo = 1e-9 * np.asarray(a0, dtype=float)
    e_lo = err(lo)
    hi = np.full_like(a0, np.nan)
    e_hi = np.full_like(a0, np.nan)
    for k in range(1, ROOT_SCAN + 1):
        a = top * k / ROOT_SCAN
        e = err(a)
        open_ = np.isnan(hi)
        found = open_ & (e >= 0.0) & (e_lo < 0.0)
        hi, e_hi = np.where(found, a, hi), np.where(found, e, e_hi)
        step_up = open_ & ~found & (e < 0.0)
        lo, e_lo = np.where(step_up, a, lo), np.where(step_up, e, e_lo)
    bracketed = ~np.isnan(hi)
    if not np.any(bracketed):
        return a0, bracketed
    hi = np.where(bracketed, hi, lo)
    e_hi = np.where(bracketed, e_hi, e_lo)
    side = np.zeros(np.shape(a0))
    a = lo
    done = ~bracketed
    for _ in range(60):
        a = np.where(done, a, np.where(e_hi != e_lo, (lo * e_hi - hi * e_lo) / np.where(
            e_hi != e_lo, e_hi - e_lo, 1.0), lo))
        e = err(a)
        done = done | (np.abs(e) <= 1e-13 * modulus)
        if np.all(done):
            break
        up = e < 0.0
        # Illinois: halve the value kept at the end that stayed twice in a row
        e_hi = np.where(up & (side < 0), 0.5 * e_hi, e_hi)
        e_lo = np.where(~up & (side > 0), 0.5 * e_lo, e_lo)
        lo, e_lo = np.where(up, a, lo), np.where(up, e, e_lo)
        hi, e_hi = np.where(up, hi, a), np.where(up, e_hi, e)
        side = np.where(up, -1.0, 1.0)
    return a, bracketed


def _secant(err, a, modulus, gain_modulus):
    """(a, converged): the root of err by the secant method from the closed form ``a``,
    a fixed-point step off it first (steps within a factor 2, so that a stays positive; a
    slope that is not positive replaced by |g|), and whether |err| fell to 1e-13 of the
    modulus, per run."""
    e0 = err(a)
    a1 = a * modulus / (e0 + modulus)
    done = np.zeros(np.shape(a1), dtype=bool)
    for _ in range(30):
        e1 = err(a1)
        done = done | (np.abs(e1) <= 1e-13 * modulus)
        if np.all(done):
            return a1, np.full(np.shape(a1), True)
        slope = np.where(a1 != a, (e1 - e0) / np.where(a1 != a, a1 - a, 1.0), gain_modulus)
        slope = np.where(slope > 0.0, slope, gain_modulus)  # |mu_p g + p| grows with a
        a, e0, a1 = a1, e1, np.where(done, a1, np.clip(a1 - e1 / slope, 0.5 * a1, 2.0 * a1))
    return a1, np.abs(err(a1)) <= 1e-10 * modulus


def _newton(err, a, modulus, gain_modulus):
    """(a, converged) as :func:`_secant`, by Newton's method: ``err(a)`` gives the error
    and its derivative in a (steps within a factor 2; a slope that is not positive
    replaced by |g|); a run that has converged is held."""
    for _ in range(30):
        e, slope = err(a)
        done = np.abs(e) <= 1e-13 * modulus
        if np.all(done):
            return a, np.full(np.shape(a), True)
        slope = np.where(slope > 0.0, slope, gain_modulus)
        a = np.where(done, a, np.clip(a - e / slope, 0.5 * a, 2.0 * a))
    return a, np.abs(err(a)[0]) <= 1e-10 * modulus


def _first_root_newton(err, a0, a_cap, modulus):
    """(a, found) as :func:`_first_root`, ``err(a)`` giving the error and its derivative
    (:func:`_newton`): the :data:`ROOT_SCAN` points evaluated at once, the first sign
    change from below bracketed, and Newton's steps kept inside the bracket, bisection
    where one would leave it (the safeguard of Press et al., *Numerical Recipes*, 3rd
    ed., 2007, sec. 9.4)."""
    a0 = np.asarray(a0, dtype=float)
    top = np.minimum(a_cap, 4.0 * a0)
    tiny = 1e-9 * a0
    grid = np.concatenate((tiny[None], top[None] * (np.arange(1, ROOT_SCAN + 1)
                                                    / ROOT_SCAN).reshape((-1,) + (1,) * a0.ndim)))
    e = err(grid)[0]
    rising = (e[1:] >= 0.0) & (e[:-1] < 0.0)
    bracketed = np.any(rising, axis=0)
    if not np.any(bracketed):
        return a0, bracketed
    k = np.argmax(rising, axis=0)[None]
    lo = np.take_along_axis(grid, k, axis=0)[0]
    hi = np.take_along_axis(grid, k + 1, axis=0)[0]
    e_lo = np.take_along_axis(e, k, axis=0)[0]
    e_hi = np.take_along_axis(e, k + 1, axis=0)[0]
    lo, hi = np.where(bracketed, lo, a0), np.where(bracketed, hi, a0)
    span = np.where(bracketed, e_hi - e_lo, 1.0)
    a = np.where(bracketed, lo - e_lo * (hi - lo) / span, a0)  # the chord's root
    done = ~bracketed
    for _ in range(60):
        ea, slope = err(a)
        done = done | (np.abs(ea) <= 1e-13 * modulus)
        if np.all(done):
            break
        below = ea < 0.0
        lo, hi = np.where(below, a, lo), np.where(below, hi, a)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = a - ea / slope
        inside = np.isfinite(step) & (step > lo) & (step < hi)
        a = np.where(done, a, np.where(inside, step, 0.5 * (lo + hi)))
    return a, bracketed


def uncapped_limit(loss, frequency, field_amplitude, loss_flux_factor=1.0):
    """a_cap: the |mu_p| at which eq 16's mu'' reaches :data:`LOSS_ANGLE_CAP` |mu_p|, [-].

    At B_m = mu_0 a H_m (times ``loss_flux_factor``) eq 16 gives mu''/a = c_h a^(n-1) +
    c_e a + c_x a^0.5, all c >= 0 and n >= 1: ln(mu''/a) is a convex, nondecreasing
    function of ln a (a log-sum-exp), so Newton's method in ln a reaches its one crossing
    of ln(cap) monotonically after its first step. inf where the cap is never reached
    below a = 1e9, 1e-6 where it is reached already there. Arrays of runs allowed.
    """
    n = loss[1]
    coef = _loss_coefficients(loss, frequency, field_amplitude, loss_flux_factor)
    shape = np.broadcast(*coef).shape
    powers = (n - 1.0, 1.0, 0.5)
    u_lo, u_hi = math.log(1e-6), math.log(1e9)
    target = math.log(LOSS_ANGLE_CAP)

    def g_and_slope(u):
        terms = [c * np.exp(p * u) for c, p in zip(coef, powers)]
        total = sum(terms)
        slope = sum(p * t for p, t in zip(powers, terms))
        with np.errstate(divide="ignore"):
            return np.log(total) - target, slope / np.where(total > 0, total, 1.0)

    never = g_and_slope(np.full(shape, u_hi))[0] < 0.0
    always = g_and_slope(np.full(shape, u_lo))[0] >= 0.0
    u = np.full(shape, 0.0)
    done = np.zeros(shape, dtype=bool)
    for _ in range(60):
        g, slope = g_and_slope(u)
        step = np.where(slope > 0, g / np.where(slope > 0, slope, 1.0), 0.0)
        u = np.where(done, u, np.clip(u - step, u_lo, u_hi))
        done = done | (np.abs(step) <= 1e-12)
        if np.all(done):
            break
    return np.where(never, np.inf, np.where(always, 1e-6, np.exp(u)))

