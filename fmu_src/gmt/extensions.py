"""Candidate extensions of the paper's model (issue #5), physics only.

The paper's model (eq 30) describes the rod by one complex permeability
mu = mu' - j mu'' per sinusoidal operating point (eqs 3-5, 16-20), eq 25 for the
strain and one mass-spring-damper (eq 27). Each class below adds one physical
effect the paper leaves out. They are *formulations* (what the effect does to
M, y or the mechanics), not fits: :mod:`smeha.diagnose` identifies their few
parameters from measured runs.

=============================  ========================================================
cause                          extension (this module)
=============================  ========================================================
rate-independent hysteresis    :class:`PrandtlIshlinskii`: weighted play operators of
                               the applied field (Krasnosel'skii & Pokrovskii 1989;
                               Kuhnen 2003; Brokate & Sprekels 1996)
magnetisation saturation       :class:`SoftSaturation`: tanh law of the *total*
                               magnetisation M_b + M about the bias
eddy-current diffusion         :class:`EddyCurrentLag`: the field inside the rod
                               lags the applied field, g(jw) = (1 + j w tau)^-alpha,
                               alpha = 1 (first order) or 1/2 (fractional, the
                               high-frequency law of 1-D diffusion)
transport delay                :class:`TransportDelay`: e^{-j k w tau} on the k-th
                               displacement harmonic (a pure delay of the sensor chain)
mechanical resonance           :class:`ReidentifiedMechanics`: eq 27 with its own
                               m, c, K (one degree of freedom, re-identified)
thermal drift                  :class:`LinearDrift`: offset and gain of y drifting
                               linearly in time, at rates proportional to the coil's
                               Joule heating (I_m^2)
=============================  ========================================================

How a magnetic extension meets the complex permeability
-------------------------------------------------------
mu' and mu'' of the paper are the *describing function* of the magnetisation
at the operating point: the first harmonic of M per unit H_m (Gelb & Vander
Velde 1968). B_m is measured (eq 22) and mu'' comes from the losses (eq 16),
so a memoryless or rate-independent nonlinearity must not change that first
harmonic again. :func:`harmonic_remainder` gives the part of an operator's
output over one period that is *not* its fundamental (mean and harmonics
2, 3, ...); the hysteresis and saturation extensions add only that remainder
to the paper's M. The eddy-current lag does change the fundamental (that is
its point); :func:`eddy_calibrated_permeability` re-solves eq 19 for mu' so
that the lagged model still reproduces the measured B_m.

Time-stepping forms
-------------------
Every class keeps whatever state a per-sample form needs: the play operators'
outputs (:meth:`PrandtlIshlinskii.step`), the lag filter's state
(:meth:`EddyCurrentLag.step`, first order), a delay line
(:meth:`TransportDelay.delay_samples`), the ZOH matrices of eq 27
(:func:`gmt.mechanics.zoh_matrices` with re-identified m, c, K) and the drift's
elapsed time. The periodic forms here (``periodic``, ``transfer``) are what
the diagnosis evaluates; the FMU would use the step forms (docs/DIAGNOSE.md).

References
----------
* M. A. Krasnosel'skii, A. V. Pokrovskii, *Systems with Hysteresis*,
  Springer 1989 (play and stop operators).
* M. Brokate, J. Sprekels, *Hysteresis and Phase Transitions*, Springer 1996,
  ch. 2 (Prandtl-Ishlinskii operator).
* K. Kuhnen, "Modeling, identification and compensation of complex hysteretic
  nonlinearities: a modified Prandtl-Ishlinskii approach", Eur. J. Control 9
  (2003) 407-418.
* D. C. Jiles, D. L. Atherton, "Theory of ferromagnetic hysteresis", J. Magn.
  Magn. Mater. 61 (1986) 48-60 (saturating anhysteretic; tanh-type laws in
  F. T. Calkins, R. C. Smith, A. B. Flatau, IEEE Trans. Magn. 36 (2000) 429).
* R. L. Stoll, *The Analysis of Eddy Currents*, Clarendon 1974; G. Bertotti,
  *Hysteresis in Magnetism*, Academic Press 1998, ch. 12 (diffusion, the
  sqrt(j w) high-frequency law).
* G. Engdahl (ed.), *Handbook of Giant Magnetostrictive Materials*, Academic
  Press 2000 (thermal behaviour of Terfenol-D transducers; transducer dynamics).
* A. Gelb, W. E. Vander Velde, *Multiple-Input Describing Functions and
  Nonlinear System Design*, McGraw-Hill 1968.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ParameterError, check_range

#: The causes the extensions stand for, in the order of the issue.
CAUSES = ("rate_independent_hysteresis", "magnetization_saturation",
          "eddy_current_diffusion", "transport_delay", "mechanical_resonance",
          "thermal_drift")


def harmonic_remainder(values):
    """One period of samples minus its fundamental (mean and harmonics >= 2 kept).

    Parameters
    ----------
    values : array
        Samples over exactly one period, uniformly spaced, last axis.

    Returns
    -------
    array
        ``values`` with the first harmonic removed.

    Examples
    --------
    >>> th = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> np.allclose(harmonic_remainder(1.0 + np.cos(th) + 0.5 * np.cos(3 * th)),
    ...             1.0 + 0.5 * np.cos(3 * th))
    True
    """
    x = np.asarray(values, dtype=float)
    spec = np.fft.rfft(x, axis=-1)
    spec[..., 1] = 0.0
    return np.fft.irfft(spec, n=x.shape[-1], axis=-1)


# ----------------------------------------------------------------- hysteresis


@dataclass(frozen=True)
class PrandtlIshlinskii:
    """Prandtl-Ishlinskii operator: a weighted sum of play operators.

    P[H](t) = sum_j w_j F_{r_j}[H](t), with the play (backlash) operator
    F_r[H](t_k) = max(H_k - r, min(H_k + r, F_r[H](t_{k-1}))) (Krasnosel'skii &
    Pokrovskii 1989; Kuhnen 2003). Rate independent: only the order of the
    input's values matters, so the loop it adds persists as f -> 0, has pointed
    reversal tips and depends on the amplitude (a play of threshold r is
    inactive below H_m = r).

    Attributes
    ----------
    thresholds : tuple of float
        r_j >= 0, [A/m].
    weights : tuple of float
        w_j, magnetisation per unit play output, [-].
    """

    thresholds: tuple
    weights: tuple

    def __post_init__(self):
        if len(self.thresholds) != len(self.weights) or not self.thresholds:
            raise ParameterError("thresholds and weights must be non-empty and of equal "
                                 f"length (got {len(self.thresholds)} and {len(self.weights)})")
        for r in self.thresholds:
            check_range("threshold", r, 0.0, math.inf, unit="A/m", low_open=False)
        for w in self.weights:
            if not math.isfinite(w):
                raise ParameterError(f"weight = {w!r} is not finite")

    def step(self, field, state):
        """One sample of every play: returns (output, new state).

        Parameters
        ----------
        field : float
            H at this sample, [A/m].
        state : array
            The plays' previous outputs (zeros for the demagnetised state), [A/m].
        """
        r = np.asarray(self.thresholds)
        z = np.maximum(field - r, np.minimum(field + r, state))
        return float(np.dot(self.weights, z)), z

    def apply(self, field, state=None):
        """The operator over a sampled input, from ``state`` (default demagnetised), [A/m]."""
        z = np.zeros(len(self.thresholds)) if state is None else np.asarray(state, float)
        out = np.empty(len(field))
        for k, h in enumerate(np.asarray(field, dtype=float)):
            out[k], z = self.step(h, z)
        return out

    def periodic(self, field_amplitude, phase):
        """Periodic output for H = H_m cos(theta), closed form, [A/m].

        After one period from the demagnetised state a play of threshold
        r < H_m runs: falling (0 <= theta <= pi) min(H_m - r, H + r), rising
        max(-H_m + r, H - r); a play with r >= H_m stays at 0.

        Parameters
        ----------
        field_amplitude : float
            H_m, [A/m].
        phase : array
            theta, [rad].
        """
        th = np.mod(np.asarray(phase, dtype=float), 2 * np.pi)
        h = field_amplitude * np.cos(th)
        falling = th <= np.pi
        out = np.zeros_like(h)
        for r, w in zip(self.thresholds, self.weights):
            if r >= field_amplitude:
                continue
            z = np.where(falling, np.minimum(field_amplitude - r, h + r),
                         np.maximum(-field_amplitude + r, h - r))
            out += w * z
        return out


# ----------------------------------------------------------------- saturation


@dataclass(frozen=True)
class SoftSaturation:
    """tanh saturation of the total magnetisation about the bias.

    The paper's M (eq 5) is the linear response about the bias M_b. With a
    saturation magnetisation M_s the total follows

        M_b + M_sat = M_s tanh(x_b + M / (M_s (1 - m_b^2))),
        m_b = M_b / M_s, x_b = artanh(m_b),

    which keeps the bias (M = 0 gives M_b) and the slope there (d M_sat/dM = 1),
    so it reduces to eq 5 as M_s -> inf, while the top of the loop (towards
    saturation) flattens and the bottom steepens, more at larger amplitude
    (a tanh-type anhysteretic; Jiles & Atherton 1986, Calkins et al. 2000).

    Attributes
    ----------
    saturation_magnetization : float
        M_s, [A/m], > M_b.
    bias_magnetization : float
        M_b, [A/m].
    """

    saturation_magnetization: float
    bias_magnetization: float

    def __post_init__(self):
        check_range("saturation_magnetization", self.saturation_magnetization,
                    self.bias_magnetization, math.inf, unit="A/m")

    def magnetization(self, magnetization):
        """Coil magnetisation after saturation, M_sat, [A/m] (memoryless: per sample as is)."""
        ms = self.saturation_magnetization
        mb = self.bias_magnetization / ms
        x = math.atanh(mb) + np.asarray(magnetization, dtype=float) / (ms * (1.0 - mb * mb))
        return ms * np.tanh(x) - self.bias_magnetization


# ----------------------------------------------------------------- eddy currents


@dataclass(frozen=True)
class EddyCurrentLag:
    """Lag of the field inside the rod behind the applied field (eddy shielding).

    H_in(jw) = g(jw) H(jw), g = (1 + j w tau)^(-alpha): alpha = 1 is the
    first-order (lumped) lag; alpha = 1/2 is the fractional lag whose high-
    frequency limit (j w tau)^(-1/2) is that of 1-D diffusion into a slab or
    cylinder (Stoll 1974; Bertotti 1998), with phase tending to alpha 90 deg and
    an amplitude falling as f^-alpha, where the classical eddy loss of eq 9
    would keep growing as f. Inside the rod M = (mu - 1) H_in and
    B = mu_0 mu H_in (the coil sees the mean B over the section).

    Attributes
    ----------
    time_constant : float
        tau, [s] (of order mu sigma d^2 / 8 for a rod of diameter d).
    order : float
        alpha in (0, 1].
    """

    time_constant: float
    order: float = 1.0

    def __post_init__(self):
        check_range("time_constant", self.time_constant, 0.0, math.inf, unit="s",
                    low_open=False)
        check_range("order", self.order, 0.0, 1.0, unit="-", high_open=False)

    def transfer(self, angular_frequency):
        """g(j w), [-]."""
        w = np.asarray(angular_frequency, dtype=float)
        return (1.0 + 1j * w * self.time_constant) ** (-self.order)

    def step(self, field, state, step):
        """First-order form (alpha = 1): H_in after one step of ``step`` [s], exact for H held."""
        if self.order != 1.0:
            raise ParameterError(f"order = {self.order:g}: the step form exists for order 1 "
                                 "only (a fractional lag needs an Oustaloup or "
                                 "Grunwald-Letnikov approximation, docs/DIAGNOSE.md)")
        if self.time_constant == 0.0:
            return float(field)
        a = math.exp(-step / self.time_constant)
        return a * state + (1.0 - a) * field


def eddy_calibrated_permeability(flux_density_amplitude, field_amplitude, mu_imag, lag):
    """mu' such that the rod's mean flux density has the measured amplitude, eqs 19-20 with the lag.

    Inside the rod H_in = g H, B_in = mu_0 mu H_in and M_in = (mu - 1) H_in;
    the sensing coil sees the mean B_in, so |mu| |g| = B_m / (mu_0 H_m) and
    mu' = sqrt(|mu|^2 - mu''^2) (eq 20 with B_m / |g|).

    Parameters
    ----------
    flux_density_amplitude, field_amplitude : float
        B_m [T], H_m [A/m].
    mu_imag : float
        mu'' of the material (eq 16), [-].
    lag : complex
        g(j w) of :class:`EddyCurrentLag` at the excitation frequency.

    Returns
    -------
    float
        mu'; NaN if |mu| <= mu''.
    """
    from .constants import MU_0

    mod = flux_density_amplitude / (MU_0 * field_amplitude * abs(lag))
    if not mod > mu_imag:
        return math.nan
    return math.sqrt(mod * mod - mu_imag * mu_imag)


# ----------------------------------------------------------------- delay


@dataclass(frozen=True)
class TransportDelay:
    """A pure delay tau in the drive or sensor chain, y_meas(t) = y(t - tau).

    On the k-th harmonic of a period it is the phase factor e^{-j k w tau}:
    an extra lag exactly linear in frequency and no change of amplitude.

    Attributes
    ----------
    delay : float
        tau, [s], >= 0.
    """

    delay: float

    def __post_init__(self):
        check_range("delay", self.delay, 0.0, math.inf, unit="s", low_open=False)

    def factor(self, angular_frequency):
        """e^{-j w tau}, [-]."""
        return np.exp(-1j * np.asarray(angular_frequency, dtype=float) * self.delay)

    def delay_samples(self, step):
        """Delay in samples of ``step`` [s]: a FIFO this long, the fraction interpolated."""
        return self.delay / step


# ----------------------------------------------------------------- mechanics


@dataclass(frozen=True)
class ReidentifiedMechanics:
    """Eq 27 with re-identified m, c, K (one degree of freedom).

    The blocked force A_r E^H lambda (eq 28) is the rod's and keeps Table 2's
    E^H; m, c, K are those of the mass-spring-damper the force drives, so a
    compliant output joint or an added mass shows as another m, c (a resonance
    moving into the band shows as amplitude rising with f).

    Attributes
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    """

    mass: float
    damping: float
    stiffness: float

    def __post_init__(self):
        check_range("mass", self.mass, 0.0, math.inf, unit="kg")
        check_range("damping", self.damping, 0.0, math.inf, unit="N s/m", low_open=False)
        check_range("stiffness", self.stiffness, 0.0, math.inf, unit="N/m")

    def response(self, angular_frequency, step=None):
        """Y/F at w, [m/N]: continuous, or the ZOH-sampled model at ``step`` [s]."""
        return zoh_frequency_response(self.mass, self.damping, self.stiffness,
                                      angular_frequency, step)


def zoh_frequency_response(mass, damping, stiffness, angular_frequency, step=None):
    """Displacement per newton of eq 27, G(jw) or its ZOH-sampled G_d(e^{jwh}), [m/N].

    The same quantity as :func:`gmt.mechanics.frequency_response` (first output)
    without python-control, for use inside fits.

    Examples
    --------
    >>> g = zoh_frequency_response(0.02, 2945.0, 1.963e7, [0.0])
    >>> bool(np.isclose(g[0].real, 1 / 1.963e7))
    True
    """
    w = np.atleast_1d(np.asarray(angular_frequency, dtype=float))
    if step is None:
        return 1.0 / (stiffness - mass * w * w + 1j * damping * w)
    ad, bd = _zoh_matrices(mass, damping, stiffness, step)
    z = np.exp(1j * w * step)
    # [1 0] (z I - Ad)^-1 Bd, 2x2 inverse in closed form
    det = (z - ad[0, 0]) * (z - ad[1, 1]) - ad[0, 1] * ad[1, 0]
    return ((z - ad[1, 1]) * bd[0] + ad[0, 1] * bd[1]) / det


def _zoh_matrices(mass, damping, stiffness, step):
    """A_d = e^{A h}, B_d = A^-1 (A_d - I) B of eq 27 (x = [y, v], input F), closed form.

    e^{A h} = (l1 e^{l2 h} - l2 e^{l1 h})/(l1 - l2) I + (e^{l1 h} - e^{l2 h})/(l1 - l2) A
    with the eigenvalues l1, l2 of A (Sylvester's formula; the limit for a double
    root). Small 2x2 arithmetic, no BLAS.
    """
    a = np.array([[0.0, 1.0], [-stiffness / mass, -damping / mass]])
    tr, det = a[0, 0] + a[1, 1], a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    disc = complex(tr * tr / 4.0 - det) ** 0.5
    l1, l2 = tr / 2.0 + disc, tr / 2.0 - disc
    e1, e2 = np.exp(l1 * step), np.exp(l2 * step)
    if abs(l1 - l2) > 1e-9 * max(abs(l1), abs(l2), 1.0 / step):
        c0 = (l1 * e2 - l2 * e1) / (l1 - l2)
        c1 = (e1 - e2) / (l1 - l2)
    else:  # double root l: e^{Ah} = e^{lh} (I + (A - l I) h)
        c0 = e1 * (1.0 - l1 * step)
        c1 = e1 * step
    ad = (c0 * np.eye(2) + c1 * a).real
    # B_d = A^-1 (A_d - I) B, B = [0, 1/m]; A^-1 = [[a11, -a01], [-a10, a00]] / det
    col = (ad - np.eye(2))[:, 1] / mass
    inv = np.array([[a[1, 1], -a[0, 1]], [-a[1, 0], a[0, 0]]]) / det
    bd = inv @ col
    return ad, bd


# ----------------------------------------------------------------- drift


@dataclass(frozen=True)
class LinearDrift:
    """Offset and gain of y drifting with the coil's heating, linearly in time at first.

    Coil heating i^2 R (mean I_m^2 R / 2 for a sinusoid) warms rod and sensor
    mount. K_lambda and M_b fall with temperature and the rod and mount expand
    (Engdahl 2000, ch. 2 and 4; Clark 1980), so with the heating "dose"
    u(t) = I_m^2 t_th (1 - e^{-t/t_th}) (first-order thermal lag; u = I_m^2 t,
    a linear drift, for t_th -> inf, the default)

        y_meas(t) = (1 + g u(t)) y(t) + o u(t),

    t from the start of the run, with o [m/(A^2 s)] and g [1/(A^2 s)].

    Attributes
    ----------
    offset_rate : float
        o, [m/(A^2 s)].
    gain_rate : float
        g, [1/(A^2 s)].
    thermal_time_constant : float
        t_th, [s], > 0; inf (default) for a drift linear in time.
    """

    offset_rate: float
    gain_rate: float
    thermal_time_constant: float = math.inf

    def __post_init__(self):
        for name in ("offset_rate", "gain_rate"):
            if not math.isfinite(getattr(self, name)):
                raise ParameterError(f"{name} = {getattr(self, name)!r} is not finite")
        check_range("thermal_time_constant", self.thermal_time_constant, 0.0, math.inf,
                    unit="s", high_open=False)

    def dose(self, time, current_amplitude):
        """u(t) = I_m^2 t_th (1 - e^{-t/t_th}), [A^2 s]; t from the start of the run."""
        t = np.asarray(time, dtype=float)
        tc = self.thermal_time_constant
        base = t if math.isinf(tc) else -tc * np.expm1(-t / tc)
        return current_amplitude ** 2 * base

    def apply(self, displacement, time, current_amplitude):
        """y_meas from the drift-free y (about its mean), [m]; per sample as is."""
        u = self.dose(time, current_amplitude)
        return (1.0 + self.gain_rate * u) * displacement + self.offset_rate * u
