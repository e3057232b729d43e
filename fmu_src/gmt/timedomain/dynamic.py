"""The extended dynamic loss law: a rate field steeper than eddy currents, and relaxation.

Bertotti's separation (:mod:`gmt.timedomain.separation`) gives the dynamic field
as k_e dB/dt + k_ex |dB/dt|^(1/2) sign(dB/dt): a loss per cycle that grows as
f or f^(1/2). Measured ferrites (docs/LOSSES.md) lose more on fast flux
transitions than either term allows and keep losing after a transition stops.
Two terms extend the field separation, each passive:

**Rate field** (the improved generalised Steinmetz equation written as a field,
Venkatachalam et al. [1]_, with its own exponents)::

    H_w = k_w dB_pp^(beta - q) |dB/dt|^(q - 1) sign(dB/dt)

absorbs k_w dB_pp^(beta - q) |dB/dt|^q >= 0 (dB_pp the peak-to-peak swing of
the loop). With q > 2 the loss of a transition rises faster with its speed
than the classical eddy loss: the Steinmetz exponent of the whole law grows
with frequency from n's 1 (hysteresis) towards q.

**Relaxation** (a spring and a dashpot in series, the Maxwell element of linear
viscoelasticity, as the magnetic after-effect is modelled by Neel and by
Bertotti [2]_; the loss that continues into the flat parts of a trapezoid,
Muehlethaler et al. [3]_)::

    H_r = k_r dB_pp^(beta - 2) x,      dx/dt = dB/dt - x / tau

x is the lag of the relaxed flux behind B. With k = k_r dB_pp^(beta - 2) the
power H_r dB/dt = k x (dx/dt + x/tau) is the spring's stored energy
d/dt(k x^2 / 2) plus the dashpot's dissipation k x^2 / tau >= 0, so the loss
per cycle is never negative. A
transition faster than tau loads the spring; the flat part that follows
lets it relax, as the i2GSE's (1 - exp(-t/tau)) term says.

For a periodic flux made of straight segments (triangles, trapezoids) and for
a sinusoid the losses per cycle have closed forms (:func:`segment_losses`,
:func:`sine_losses`); :class:`gmt.timedomain.magnetics.TimeDomainMagnetics`
steps the same fields (``tests/test_timedomain_losses.py`` checks one against
the other).

References
----------
.. [1] K. Venkatachalam, C. R. Sullivan, T. Abdallah, H. Tacca, "Accurate
   prediction of ferrite core loss with nonsinusoidal waveforms using only
   Steinmetz parameters", IEEE COMPEL 2002, 36-41.
.. [2] G. Bertotti, *Hysteresis in Magnetism*, Academic Press, 1998, ch. 12
   (dynamic losses) and ch. 3 (magnetic after-effect, relaxation).
.. [3] J. Muehlethaler, J. Biela, J. W. Kolar, A. Ecklebe, "Improved
   core-loss calculation for magnetic components employed in power
   electronic systems", IEEE Trans. Power Electron. 27(2), 2012, 964-973.
"""
from __future__ import annotations

import math

import numpy as np

from .separation import cos_power_mean

__all__ = ["rate_field", "relaxation_lag", "segment_losses", "sine_losses"]


def rate_field(rate: float, swing: float, k_w: float, q: float, beta: float) -> float:
    """H_w = k_w dB_pp^(beta - q) |dB/dt|^(q - 1) sign(dB/dt), [A/m].

    Parameters
    ----------
    rate : dB/dt, [T/s]
    swing : dB_pp, the loop's peak-to-peak flux density, [T], > 0
    k_w, q, beta : ``rate_coefficient``, ``rate_exponent``, ``swing_exponent`` of
        :class:`gmt.TimeDomainParameters`.
    """
    if k_w == 0.0 or rate == 0.0:
        return 0.0
    h = k_w * swing ** (beta - q) * abs(rate) ** (q - 1.0)
    return h if rate > 0.0 else -h


def relaxation_lag(lag: float, rate: float, step: float, tau: float) -> float:
    """x after ``step`` [s] of a constant ``rate`` [T/s], from ``lag`` [T]: exact, [T].

    dx/dt = rate - x/tau gives x(h) = x_0 e^(-h/tau) + rate tau (1 - e^(-h/tau)).
    """
    decay = math.exp(-step / tau)
    return lag * decay - rate * tau * math.expm1(-step / tau)


def _rate_sums(durations, swings, q):
    """sum over segments of t |dB/dt|^q, [T^q s^(1-q)] (rows of the arrays)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(durations > 0.0, swings / durations, 0.0)
    return np.sum(np.abs(rate) ** q * durations, axis=1), rate


def segment_losses(durations, swings, peak_to_peak, k_e, k_ex, k_w=0.0, q=2.0, beta=2.0,
                   k_r=0.0, tau=1e-6):
    """Dynamic losses per cycle of periodic, piecewise-linear flux waveforms, [J/m^3].

    Parameters
    ----------
    durations : array (rows, segments)
        Duration of each straight segment, [s]; a row sums to the period.
    swings : array (rows, segments)
        Change of B over each segment, [T]; a row sums to 0.
    peak_to_peak : array (rows,)
        dB_pp of each waveform, [T].
    k_e, k_ex : eddy and excess field coefficients (:mod:`gmt.timedomain.separation`).
    k_w, q, beta, k_r, tau : the extension (module docstring).

    Returns
    -------
    (eddy, excess, rate, relaxation) : arrays (rows,)
        Each term's loss per cycle. The relaxation's is the periodic steady
        state: the lag at the start of the cycle is x_0 = C / (1 - A) of the
        cycle's affine map x -> A x + C.
    """
    durations = np.asarray(durations, dtype=float)
    swings = np.asarray(swings, dtype=float)
    pp = np.asarray(peak_to_peak, dtype=float)
    e2, rate = _rate_sums(durations, swings, 2.0)
    eddy = k_e * e2
    excess = k_ex * _rate_sums(durations, swings, 1.5)[0]
    rated = (k_w * pp ** (beta - q) * _rate_sums(durations, swings, q)[0] if k_w
             else np.zeros(len(pp)))
    relax = np.zeros(len(pp))
    if k_r:
        relax = k_r * pp ** (beta - 2.0) * _relaxation_energy(durations, rate, tau)
    return eddy, excess, rated, relax


def _relaxation_energy(durations, rate, tau):
    """Per unit spring constant: the cycle integral of x dB for the Maxwell element, [T^2]."""
    decay = np.exp(-durations / tau)
    grow = -np.expm1(-durations / tau)
    a = np.ones(len(rate))
    c = np.zeros(len(rate))
    for j in range(rate.shape[1]):
        c = rate[:, j] * tau * grow[:, j] + decay[:, j] * c
        a = a * decay[:, j]
    x = c / (1.0 - a)
    energy = np.zeros(len(rate))
    for j in range(rate.shape[1]):
        r = rate[:, j]
        # integral of x over the segment: r tau t + (x_0 - r tau) tau (1 - e^(-t/tau))
        energy += r * (r * tau * durations[:, j] + (x - r * tau) * tau * grow[:, j])
        x = r * tau * grow[:, j] + decay[:, j] * x
    return energy


def sine_losses(frequency, amplitude, k_e, k_ex, k_w=0.0, q=2.0, beta=2.0, k_r=0.0, tau=1e-6):
    """Dynamic losses per cycle of B = B_m sin(2 pi f t), [J/m^3] (the closed forms).

    eddy 2 pi^2 k_e B_m^2 f (eq 9), excess C k_ex B_m^1.5 f^0.5 (eq 11), the rate
    field k_w (2 B_m)^(beta - q) (2 pi f B_m)^q <|cos|^q> / f, and the Maxwell
    element's pi k (B_m^2) w tau / (1 + (w tau)^2) (Debye's relaxation loss).

    Parameters
    ----------
    frequency : array, f [Hz]
    amplitude : array, B_m [T]
    """
    f = np.asarray(frequency, dtype=float)
    bm = np.asarray(amplitude, dtype=float)
    w = 2.0 * math.pi * f
    eddy = k_e * (w * bm) ** 2 * 0.5 / f
    excess = k_ex * (w * bm) ** 1.5 * cos_power_mean(1.5) / f
    rated = (k_w * (2.0 * bm) ** (beta - q) * (w * bm) ** q * cos_power_mean(q) / f
             if k_w else np.zeros(np.shape(f)))
    relax = (k_r * (2.0 * bm) ** (beta - 2.0) * math.pi * bm ** 2 * w * tau
             / (1.0 + (w * tau) ** 2) if k_r else np.zeros(np.shape(f)))
    return eddy, excess, rated, relax
