"""Continuous signals switched on with the drive, and their exact passage through systems.

A ``Waveform`` is zero for t < 0 (the drive switches on at t = 0) and for t >= 0

    x(t) = Re[ sum_g exp(-sigma_g t) sum_n a_gn exp(j n w t) + sum_i c_i exp(lam_i t) ] + d(t)

* harmonic groups: the periodic steady state (sigma = 0) and slowly decaying modulations of
  it (thermal drift, sigma = 1 / tau_th);
* free exponentials: transients of linear systems (pole terms of eq (*) in ``lti``);
* d(t): a deviation known on a uniform grid t_j = j h and linear between grid points (first-
  order hold), zero after the grid; used only for transients of nonlinear stages.

Linear systems act on the first two kinds exactly (``lti`` eq (*)); on d(t) they act exactly
for the piecewise-linear input (first-order-hold discretisation of each mode; Franklin,
Powell and Workman, Digital Control of Dynamic Systems, 3rd ed., sec. 6.3.2), so the only
approximation is the linear interpolation of d between grid points.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from .lti import Modal

_EMPTY = np.zeros(0, dtype=complex)


@dataclass(frozen=True)
class Waveform:
    """A drive-locked signal; see the module docstring. SI units of the quantity it holds."""

    omega: float
    decays: tuple[float, ...] = ()
    harmonics: tuple[np.ndarray, ...] = ()
    exponents: np.ndarray = field(default_factory=lambda: _EMPTY)
    amplitudes: np.ndarray = field(default_factory=lambda: _EMPTY)
    grid_step: float = 0.0
    grid: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @staticmethod
    def sinusoid(omega: float, phasor: complex) -> "Waveform":
        """Re(phasor exp(j w t)) switched on at t = 0."""
        return Waveform(omega, (0.0,), (np.array([0.0, phasor], dtype=complex),))

    @staticmethod
    def periodic(omega: float, coefficients, decay: float = 0.0) -> "Waveform":
        """Re sum_n a_n exp((j n w - sigma) t), switched on at t = 0."""
        return Waveform(omega, (decay,), (np.asarray(coefficients, dtype=complex),))

    def __add__(self, other: "Waveform") -> "Waveform":
        decays = list(self.decays)
        harmonics = [h.copy() for h in self.harmonics]
        for sigma, coef in zip(other.decays, other.harmonics):
            if sigma in decays:
                k = decays.index(sigma)
                harmonics[k] = _padded_sum(harmonics[k], coef)
            else:
                decays.append(sigma)
                harmonics.append(coef.copy())
        step, grid = _grid_sum(self, other)
        return Waveform(
            self.omega,
            tuple(decays),
            tuple(harmonics),
            np.concatenate([self.exponents, other.exponents]),
            np.concatenate([self.amplitudes, other.amplitudes]),
            step,
            grid,
        )

    def scaled(self, factor: float) -> "Waveform":
        """factor * x(t)."""
        return Waveform(
            self.omega,
            self.decays,
            tuple(h * factor for h in self.harmonics),
            self.exponents,
            self.amplitudes * factor,
            self.grid_step,
            self.grid * factor,
        )

    def steady(self) -> np.ndarray:
        """Harmonic coefficients a_n of the periodic (sigma = 0) group (empty if none)."""
        for sigma, coef in zip(self.decays, self.harmonics):
            if sigma == 0.0:
                return coef
        return np.zeros(1, dtype=complex)

    def terms(self) -> tuple[np.ndarray, np.ndarray]:
        """All exponential terms as (exponents lam, coefficients a): x = Re sum a exp(lam t)."""
        lams, coefs = [self.exponents], [self.amplitudes]
        for sigma, coef in zip(self.decays, self.harmonics):
            n = np.arange(coef.size)
            lams.append(1j * n * self.omega - sigma)
            coefs.append(coef)
        return np.concatenate(lams), np.concatenate(coefs)

    @property
    def has_transient_deviation(self) -> bool:
        """True if the signal is not a switched periodic function plus drift groups."""
        return self.exponents.size > 0 or self.grid.size > 0

    def evaluate(self, t) -> np.ndarray:
        """x(t), zero for t < 0."""
        t = np.asarray(t, dtype=float)
        value = np.zeros(t.shape)
        for sigma, coef in zip(self.decays, self.harmonics):
            part = harmonic_sum(coef, self.omega, t)
            value += part if sigma == 0.0 else part * np.exp(-sigma * t)
        if self.exponents.size:
            value += _exponential_sum(self.exponents, self.amplitudes, t)
        if self.grid.size:
            tj = np.arange(self.grid.size) * self.grid_step
            value += np.interp(t, tj, self.grid, left=0.0, right=0.0)
        return np.where(t >= 0.0, value, 0.0)


def _padded_sum(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(max(a.size, b.size), dtype=complex)
    out[: a.size] += a
    out[: b.size] += b
    return out


def _grid_sum(a: Waveform, b: Waveform) -> tuple[float, np.ndarray]:
    if not b.grid.size:
        return a.grid_step, a.grid.copy()
    if not a.grid.size:
        return b.grid_step, b.grid.copy()
    if a.grid_step != b.grid_step:
        raise ValueError("cannot add waveforms on different transient grids")
    n = max(a.grid.size, b.grid.size)
    out = np.zeros(n)
    out[: a.grid.size] += a.grid
    out[: b.grid.size] += b.grid
    return a.grid_step, out


def _exponential_sum(exponents, amplitudes, t) -> np.ndarray:
    """Re sum c exp(lam t); each term is evaluated only while it is above 1e-18 of the largest
    coefficient (decayed transients cost nothing)."""
    out = np.zeros(t.shape)
    if not t.size or not exponents.size:
        return out
    t = np.clip(t, 0.0, None)
    floor = 1e-18 * np.max(np.abs(amplitudes))
    rate = -exponents.real
    with np.errstate(divide="ignore"):
        room = np.log(np.abs(amplitudes) / floor)  # e-folds until the term is negligible
    until = np.where(rate > 0, room / np.where(rate > 0, rate, 1.0), np.inf)
    ordered = bool(np.all(np.diff(t) >= 0))
    for lam, amp, stop in zip(exponents, amplitudes, until):
        if ordered:
            part = slice(0, int(np.searchsorted(t, stop, side="right")))
        else:
            part = t <= stop
        out[part] += (amp * np.exp(lam * t[part])).real
    return out


def harmonic_sum(coefficients: np.ndarray, omega: float, t) -> np.ndarray:
    """Re sum_n a_n exp(j n w t) at times t.

    Few harmonics: summed directly (Horner in exp(j w t)). Many: evaluated by inverse FFT on a
    phase grid of at least 16 points per period of the highest harmonic, then cubic Hermite
    interpolation with exact derivatives; the relative error for harmonic n is below
    (2 pi n / P)^4 / 384 <= 6e-5 at n = P/16 and far smaller for the low harmonics that carry
    the signal.
    """
    t = np.asarray(t, dtype=float)
    a = np.asarray(coefficients, dtype=complex)
    if a.size <= 24 or a.size * t.size < 400_000:
        z = np.exp(1j * omega * t)
        acc = np.zeros(t.shape, dtype=complex)
        for coef in a[::-1]:
            acc = acc * z + coef
        return acc.real
    points = 1 << max(10, int(math.ceil(math.log2(16 * a.size))))
    spectrum = np.zeros(points // 2 + 1, dtype=complex)
    spectrum[: a.size] = a * (points / 2.0)
    spectrum[0] = a[0].real * points
    values = np.fft.irfft(spectrum, points)
    n = np.arange(spectrum.size)
    slopes = np.fft.irfft(spectrum * 1j * n, points)  # d x / d theta
    values = np.append(values, values[0])
    slopes = np.append(slopes, slopes[0])
    h = 2.0 * math.pi / points
    theta = np.mod(omega * t, 2.0 * math.pi)
    j = np.minimum((theta / h).astype(int), points - 1)
    s = theta / h - j
    h00 = (1 + 2 * s) * (1 - s) ** 2
    h10 = s * (1 - s) ** 2
    h01 = s**2 * (3 - 2 * s)
    h11 = s**2 * (s - 1)
    return h00 * values[j] + h10 * h * slopes[j] + h01 * values[j + 1] + h11 * h * slopes[j + 1]


def respond(system: Modal, signal: Waveform, keep_grid: bool = False) -> Waveform:
    """The system's output for the signal from rest, as a Waveform (exact; see ``lti`` (*)).

    The grid part of the input is not carried (use ``evaluate_response`` for it).
    """
    if signal.grid.size and not keep_grid:
        raise ValueError("respond() does not carry a grid deviation; use evaluate_response()")
    harmonics = []
    for sigma, coef in zip(signal.decays, signal.harmonics):
        n = np.arange(coef.size)
        harmonics.append(coef * system.transfer(1j * n * signal.omega - sigma))
    images = (signal.amplitudes * system.transfer(signal.exponents)
              if signal.exponents.size else _EMPTY)
    lams, coefs = signal.terms()
    # pole terms: - sum_k exp(p_k t) r_k sum_i a_i / (lam_i - p_k)
    weights = -system.residues * np.sum(
        coefs[None, :] / (lams[None, :] - system.poles[:, None]), axis=1
    )
    return Waveform(
        signal.omega,
        signal.decays,
        tuple(harmonics),
        np.concatenate([signal.exponents, system.poles]),
        np.concatenate([images, weights]),
    )


def evaluate_response(system: Modal, signal: Waveform, t) -> np.ndarray:
    """The system's output for the signal from rest, at times t (zero for t < 0)."""
    t = np.asarray(t, dtype=float)
    smooth = Waveform(signal.omega, signal.decays, signal.harmonics, signal.exponents,
                      signal.amplitudes)
    out = respond(system, smooth).evaluate(t)
    if signal.grid.size:
        out += _grid_response(system, signal.grid_step, signal.grid, t)
    return out


def _phi(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(exp(z) - 1) / z and (exp(z) - 1 - z) / z^2, accurate for small |z|."""
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < 1e-3
    zs = np.where(small, 1.0, z)
    e = np.expm1(zs)
    phi1 = np.where(small, 1 + z / 2 + z**2 / 6 + z**3 / 24, e / zs)
    phi2 = np.where(small, 0.5 + z / 6 + z**2 / 24 + z**3 / 120, (e - zs) / zs**2)
    return phi1, phi2


def _grid_response(system: Modal, h: float, d: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Exact response of each mode to the piecewise-linear d(t) (first-order hold)."""
    count = d.size
    tj_last = (count - 1) * h
    inside = (t >= 0.0) & (t < tj_last)
    j = np.clip(np.floor(t / h).astype(int), 0, count - 2)
    delta = np.where(inside, t - j * h, 0.0)
    out = np.zeros(t.shape)
    for p, r in zip(system.poles, system.residues):
        phi1, phi2 = _phi(p * h)
        a = np.exp(p * h)
        b1 = r * h * phi2  # weight of d_{j+1}
        b0 = r * h * (phi1 - phi2)  # weight of d_j
        states, _ = lfilter([b1, b0], [1.0, -a], d.astype(complex), zi=[-b1 * d[0]])
        q1, q2 = _phi(p * delta)
        frac = delta / h
        partial = np.exp(p * delta) * states[j] + r * delta * (
            (q1 - frac * q2) * d[j] + frac * q2 * d[j + 1]
        )
        after = states[-1] * np.exp(p * np.clip(t - tj_last, 0.0, None))
        value = np.where(inside, partial, after)
        out += np.where(t >= 0.0, value.real, 0.0)
    if system.direct:
        tj = np.arange(count) * h
        out += system.direct * np.interp(t, tj, d, left=0.0, right=0.0)
    return out
