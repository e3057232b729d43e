"""Continuous-time linear systems in modal (pole-residue) form.

A strictly proper rational transfer function with simple poles is
G(s) = D + sum_k r_k / (s - p_k). Its response to a switched exponential a exp(lam t) u(t)
from rest is exactly

    a [G(lam) exp(lam t) - sum_k r_k exp(p_k t) / (lam - p_k)]                     (*)

(convolution of r exp(p t) with exp(lam t); Kailath, Linear Systems, 1980, ch. 2). labsim
builds every continuous signal out of such terms, so mechanics, filters and diffusion act on
them exactly, without time steps. Systems are given as zeros, poles and gain (zpk) and
cascaded by concatenating them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.special import ive, jn_zeros

from .constants import LabsimError


@dataclass(frozen=True)
class Zpk:
    """G(s) = gain * prod(s - z) / prod(s - p)."""

    zeros: tuple[complex, ...]
    poles: tuple[complex, ...]
    gain: float

    def __mul__(self, other: "Zpk") -> "Zpk":
        return Zpk(self.zeros + other.zeros, self.poles + other.poles, self.gain * other.gain)

    def __call__(self, s):
        s = np.asarray(s, dtype=complex)
        num = np.ones_like(s) * self.gain
        for z in self.zeros:
            num = num * (s - z)
        for p in self.poles:
            num = num / (s - p)
        return num


@dataclass(frozen=True)
class Modal:
    """G(s) = direct + sum_k residues[k] / (s - poles[k]); ``exact`` (optional) is the exact
    transfer function used for steady states when the modal sum is a truncated series."""

    poles: np.ndarray
    residues: np.ndarray
    direct: float = 0.0
    exact: Callable | None = field(default=None, compare=False)

    def transfer(self, s):
        """G(s) for complex s (array or scalar)."""
        s = np.asarray(s, dtype=complex)
        if self.exact is not None:
            return self.exact(s)
        return self.direct + np.sum(
            self.residues[:, None] / (s.reshape(1, -1) - self.poles[:, None]), axis=0
        ).reshape(s.shape)

    @property
    def slowest_rate(self) -> float:
        """Smallest decay rate -Re(p) of the modes, [1/s]."""
        return float(np.min(-self.poles.real)) if self.poles.size else math.inf


def modal(zpk: Zpk) -> Modal:
    """Partial fractions of a strictly proper zpk with simple poles (Heaviside cover-up)."""
    poles = np.asarray(zpk.poles, dtype=complex)
    zeros = np.asarray(zpk.zeros, dtype=complex)
    if zeros.size >= poles.size:
        raise LabsimError("modal(): the transfer function must be strictly proper")
    residues = np.empty_like(poles)
    for k, p in enumerate(poles):
        others = np.delete(poles, k)
        gap = np.min(np.abs(others - p)) if others.size else math.inf
        if gap <= 1e-9 * max(abs(p), 1.0):
            raise LabsimError(f"modal(): repeated pole near {p:.6g}")
        residues[k] = zpk.gain * np.prod(p - zeros) / np.prod(p - others)
    return Modal(poles, residues, 0.0)


def butterworth(order: int, cutoff: float) -> Zpk:
    """Analog Butterworth low-pass, |G(j w)|^2 = 1 / (1 + (w / w_c)^(2 n)), unit DC gain.

    Poles w_c exp(j pi (2k + n - 1) / (2n)), k = 1..n (Butterworth 1930; e.g. Oppenheim and
    Schafer, Discrete-Time Signal Processing, 3rd ed., sec. 7.1).
    """
    if order < 1:
        raise LabsimError(f"anti-alias filter order = {order}: must be >= 1")
    if not cutoff > 0:
        raise LabsimError(f"anti-alias cutoff = {cutoff} Hz: must be > 0")
    w_c = 2.0 * math.pi * cutoff
    k = np.arange(1, order + 1)
    poles = w_c * np.exp(1j * math.pi * (2 * k + order - 1) / (2 * order))
    return Zpk((), tuple(poles), w_c**order)


def mass_spring_damper(mass: float, damping: float, stiffness: float) -> Zpk:
    """y / F = 1 / (m s^2 + c s + K), eq 27, [m/N]."""
    poles = np.roots([mass, damping, stiffness])
    return Zpk((), tuple(poles.astype(complex)), 1.0 / mass)


def two_mass(mass, damping, stiffness, out_mass, out_damping, out_stiffness) -> Zpk:
    """Displacement of an output mass m2 coupled to the rod tip (m, c, K of eq 27) by a
    spring k2 and damper c2, per force on the tip, [m/N].

    m s^2 y1 = F - (c s + K) y1 - (c2 s + k2)(y1 - y2),  m2 s^2 y2 = (c2 s + k2)(y1 - y2)
    => y2 / F = (c2 s + k2) / [(m s^2 + (c + c2) s + K + k2)(m2 s^2 + c2 s + k2) - (c2 s + k2)^2]
    (a two-degree-of-freedom chain; e.g. Inman, Engineering Vibration, 4th ed., ch. 4).
    """
    a = np.array([mass, damping + out_damping, stiffness + out_stiffness])
    b = np.array([out_mass, out_damping, out_stiffness])
    coupling = np.array([out_damping, out_stiffness])
    den = np.polysub(np.polymul(a, b), np.polymul(coupling, coupling))
    poles = np.roots(den).astype(complex)
    return Zpk((-out_stiffness / out_damping,), tuple(poles), out_damping / den[0])


def derivative(gain: float) -> Zpk:
    """G(s) = gain * s (a zero at the origin)."""
    return Zpk((0.0,), (), gain)


def cylinder_diffusion(diffusion_time: float, modes: int = 60) -> Modal:
    """Mean flux over a solid conducting cylinder per surface field, 1-D radial diffusion.

    With tau = mu sigma a^2 and q = sqrt(s tau), the exact transfer is
    F(s) = 2 I_1(q) / (q I_0(q)) (Stoll, The Analysis of Eddy Currents, 1974, ch. 3;
    Lammeraner and Stafl, Eddy Currents, 1964). Its Mittag-Leffler expansion over the zeros
    j_{0,n} of J_0 is F(s) = sum_n 4 / (j_{0,n}^2 + s tau): first-order modes with poles
    -j_{0,n}^2 / tau and residues 4 / tau. ``modes`` of them are kept; the rest, faster than
    tau / j_{0,modes}^2, enter as an instantaneous term 1 - sum 4 / j_{0,n}^2.
    """
    if not diffusion_time > 0:
        raise LabsimError(f"diffusion time = {diffusion_time} s: must be > 0")
    zeros = jn_zeros(0, modes)
    poles = -(zeros**2) / diffusion_time
    residues = np.full(modes, 4.0 / diffusion_time)
    direct = 1.0 - float(np.sum(4.0 / zeros**2))

    def exact(s):
        q = np.sqrt(np.asarray(s, dtype=complex) * diffusion_time)
        small = np.abs(q) < 1e-4
        q_safe = np.where(small, 1.0, q)
        value = 2.0 * ive(1, q_safe) / (q_safe * ive(0, q_safe))
        return np.where(small, 1.0 - q**2 / 8.0, value)

    return Modal(poles.astype(complex), residues.astype(complex), direct, exact)


def slab_diffusion(diffusion_time: float, modes: int = 60) -> Modal:
    """Mean flux over a conducting lamination (slab of thickness d) per surface field, 1-D
    diffusion across the thickness.

    With tau = mu sigma d^2 / 4 and q = sqrt(s tau), the exact transfer is
    F(s) = tanh(q) / q (the averaged permeability of a lamination, mu_avg / mu; Stoll, The
    Analysis of Eddy Currents, 1974, ch. 3; Lammeraner and Stafl, Eddy Currents, 1966).
    tanh(q)/q is even in q and meromorphic in q^2 with simple poles where cosh q = 0,
    q_k^2 = -((2k + 1) pi / 2)^2; its residue in q^2 there is sinh q / (q d(cosh q)/d(q^2))
    = 2, and it vanishes as |q| -> infinity, so (Mittag-Leffler)
    F(s) = sum_k 2 / (q^2 + (2k + 1)^2 pi^2 / 4) = sum_k [8 / ((2k + 1)^2 pi^2)]
    / (1 + s tau / ((2k + 1)^2 pi^2 / 4)), weights summing to 1 (sum of 1 / odd^2 = pi^2 / 8):
    first-order modes with poles -(2k + 1)^2 pi^2 / (4 tau) and residues 2 / tau. ``modes``
    of them are kept, the rest enter as an instantaneous term 1 - sum of their weights.
    """
    if not diffusion_time > 0:
        raise LabsimError(f"diffusion time = {diffusion_time} s: must be > 0")
    odd = 2.0 * np.arange(modes) + 1.0
    poles = -((odd * math.pi / 2.0) ** 2) / diffusion_time
    residues = np.full(modes, 2.0 / diffusion_time)
    direct = 1.0 - float(np.sum(8.0 / (odd * math.pi) ** 2))

    def exact(s):
        q = np.sqrt(np.asarray(s, dtype=complex) * diffusion_time)
        small = np.abs(q) < 1e-4
        q_safe = np.where(small, 1.0, q)
        return np.where(small, 1.0 - q**2 / 3.0, np.tanh(q_safe) / q_safe)

    return Modal(poles.astype(complex), residues.astype(complex), direct, exact)


def shorted_turn(time_constant: float, coupling: float) -> Modal:
    """Field in the rod per coil field with a conducting loop (housing, coil former) around it.

    The loop, of inductance L_h and resistance R_h, links the fraction kappa of the flux
    path; its induced current opposes the coil's MMF, so
    H_eff / H = 1 - kappa s tau / (1 + s tau) = (1 - kappa) + kappa / (1 + s tau),
    tau = L_h / R_h (a transformer with a short-circuited secondary; e.g. Fitzgerald,
    Kingsley and Umans, Electric Machinery, 6th ed., sec. 2.4). kappa = 1: a first-order lag.
    """
    if not time_constant > 0:
        raise LabsimError(f"housing time constant = {time_constant} s: must be > 0")
    if not 0.0 < coupling <= 1.0:
        raise LabsimError(f"housing coupling = {coupling}: must be in (0, 1]")
    pole = -1.0 / time_constant
    return Modal(np.array([pole], dtype=complex), np.array([coupling / time_constant],
                                                           dtype=complex), 1.0 - coupling)


def bessel(order: int, group_delay: float) -> Zpk:
    """Bessel (Thomson) low-pass normalised to the group delay tau at DC: G(s) = theta_n(0) /
    theta_n(s tau), theta_n the reverse Bessel polynomial with coefficients
    (2n - k)! / (2^(n-k) k! (n-k)!) of s^k (Thomson 1949; e.g. Williams and Taylor, Electronic
    Filter Design Handbook, 4th ed., sec. 2.7). Maximally flat group delay."""
    if order < 1:
        raise LabsimError(f"Bessel order = {order}: must be >= 1")
    if not group_delay > 0:
        raise LabsimError(f"sensor group delay = {group_delay} s: must be > 0")
    coefficients = [
        math.factorial(2 * order - k) / (2 ** (order - k) * math.factorial(k)
                                         * math.factorial(order - k))
        for k in range(order, -1, -1)  # highest power first
    ]
    poles = np.roots(coefficients).astype(complex) / group_delay
    return Zpk((), tuple(poles), coefficients[-1] / group_delay**order)


def as_modal(system) -> Modal:
    """A Modal for a Zpk or Modal."""
    return system if isinstance(system, Modal) else modal(system)


def chain(*systems) -> Modal:
    """The cascade of Zpk and Modal systems as one Modal.

    Zpk factors are multiplied first. A Modal factor a (poles p, residues r, direct D_a) with
    b: a b has residue r_k b(p_k) at p_k, rho_j a(q_j) at the poles q_j of b and direct
    D_a D_b (distinct simple poles); exact transfers multiply.
    """
    rational = [s for s in systems if isinstance(s, Zpk)]
    result = None
    if rational:
        product = rational[0]
        for s in rational[1:]:
            product = product * s
        result = modal(product)
    for system in systems:
        if isinstance(system, Modal):
            result = system if result is None else _cascade(result, system)
    return result


def _cascade(a: Modal, b: Modal) -> Modal:
    exact = None
    if a.exact is not None or b.exact is not None:
        def exact(s):
            return a.transfer(s) * b.transfer(s)
    poles = np.concatenate([a.poles, b.poles])
    residues = np.concatenate([a.residues * b.transfer(a.poles),
                               b.residues * a.transfer(b.poles)])
    return Modal(poles, residues, a.direct * b.direct, exact)
