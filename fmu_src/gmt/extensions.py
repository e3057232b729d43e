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
                               high-frequency law of 1-D diffusion);
                               :class:`EddyCurrentDiffusion`: the exact 1-D
                               diffusion of the field into a lamination (slab,
                               tanh q / q) or a solid rod (cylinder, Bessel
                               functions), with the field's profile across the
                               section (Stoll 1974; Bertotti 1998)
transport delay                :class:`TransportDelay`: e^{-j k w tau} on the k-th
                               displacement harmonic (a pure delay of the sensor chain)
mechanical resonance           :class:`ReidentifiedMechanics`: eq 27 with its own
                               m, c, K (one degree of freedom, re-identified);
                               :class:`TwoMassMechanics`: rod and output mass on a
                               compliant joint (two degrees of freedom)
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
(:meth:`EddyCurrentLag.step`, first order; :meth:`EddyCurrentDiffusion.step`,
the diffusion's mean field as its modal sum of first-order lags), a delay line
(:meth:`TransportDelay.delay_samples`), the ZOH matrices of eq 27
(:func:`gmt.mechanics.zoh_matrices` with re-identified m, c, K;
:meth:`TwoMassMechanics.zoh_matrices` for the two masses) and the drift's
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
* W. T. Thomson, M. D. Dahleh, *Theory of Vibration with Applications*, 5th ed.,
  Prentice Hall 1998, ch. 5 (two-degree-of-freedom systems).
* C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE
  Trans. Autom. Control 23 (1978) 395-404 (ZOH discretisation by one
  exponential); G. F. Franklin, J. D. Powell, M. L. Workman, *Digital Control
  of Dynamic Systems*, 3rd ed., Addison-Wesley 1998, ch. 4.
* A. Gelb, W. E. Vander Velde, *Multiple-Input Describing Functions and
  Nonlinear System Design*, McGraw-Hill 1968.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .errors import ParameterError, check_range
from .mechanics import zoh_closed_form

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


#: Geometries of :class:`EddyCurrentDiffusion`.
DIFFUSION_GEOMETRIES = ("slab", "cylinder")


@dataclass(frozen=True)
class EddyCurrentDiffusion:
    """Magnetic diffusion into a conducting lamination or rod: the exact 1-D field profile.

    Inside a conductor of permeability mu and conductivity sigma the field
    obeys the diffusion equation mu_0 mu sigma dH/dt = div grad H (Maxwell's
    equations without displacement current, linear material). With the
    applied field H e^{j w t} on the surface, its phasor inside depends on
    q = sqrt(j w tau), tau = mu_0 mu sigma a^2 (Stoll 1974, ch. 2 and 4;
    Bertotti 1998, ch. 12), derived for this module as follows:

    * **slab** (a lamination of thickness 2a, the field along it, x from the
      mid-plane): H'' = (j w tau / a^2) H with H'(0) = 0 gives
      g(x) = H(x)/H = cosh(q x/a) / cosh(q);
    * **cylinder** (a solid rod of radius a, axial field): the radial
      equation (1/r)(r H')' = (j w tau / a^2) H, regular on the axis, gives
      g(r) = I_0(q r/a) / I_0(q) (modified Bessel functions).

    The coil sees the section's mean flux, so the lag of the mean field is
    the transfer (:meth:`transfer`)

        slab      <g> = tanh(q) / q,
        cylinder  <g> = 2 I_1(q) / (q I_0(q)),

    both 1 - j w tau/3 (slab) or 1 - j w tau/8 (cylinder) at low frequency
    (a first-order lag of tau/3 or tau/8) and (j w tau)^(-1/2) times 1 or 2 at
    high frequency (phase -> 45 deg, the skin effect). Magnetostriction is
    local, while the rod's section moves as one, so the force of eq 28 takes
    the section mean of lambda = K_lambda (M_b + M(x))^2; with
    M(x) = Re(M g(x) e^{j w t}) that needs <g^2> and <|g|^2>
    (:meth:`mean_squares`), integrated here in closed form:

        slab      <g^2> = (1/cosh^2 q + tanh(q)/q) / 2,
                  <|g|^2> = Im(q tanh q) / (w tau),
        cylinder  <g^2> = 1 - (I_1(q)/I_0(q))^2,
                  <|g|^2> = 2 Im(q I_1(q)/I_0(q)) / (w tau)

    (the cylinder's from Lommel's integrals of products of Bessel
    functions; <|g|^2> is, as it must be, proportional to the power the
    surface impedance absorbs). All tend to 1 as w tau -> 0.

    Attributes
    ----------
    time_constant : float
        tau = mu_0 mu sigma a^2, [s], a the half thickness (slab) or the
        radius (cylinder); the skin depth sqrt(2/(w mu_0 mu sigma)) equals a
        at w tau = 2.
    geometry : {"slab", "cylinder"}
    """

    time_constant: float
    geometry: str = "cylinder"

    def __post_init__(self):
        check_range("time_constant", self.time_constant, 0.0, math.inf, unit="s",
                    low_open=False)
        if self.geometry not in DIFFUSION_GEOMETRIES:
            raise ParameterError(f"geometry = {self.geometry!r} is not one of "
                                 f"{DIFFUSION_GEOMETRIES}")

    def _q(self, angular_frequency):
        """(w tau, q = sqrt(j w tau)) with Re q >= 0, arrays."""
        wt = np.asarray(angular_frequency, dtype=float) * self.time_constant
        return wt, np.sqrt(1j * wt)

    def _ratio(self, q):
        """tanh(q) (slab) or I_1(q)/I_0(q) (cylinder); exponentially scaled, no overflow."""
        if self.geometry == "slab":
            return np.tanh(q)
        from scipy.special import ive
        return ive(1, q) / ive(0, q)

    def profile(self, position, angular_frequency):
        """g = H(x)/H at the relative position x/a in [0, 1] (0: mid-plane or axis), [-]."""
        _, q = self._q(angular_frequency)
        u = np.asarray(position, dtype=float)
        if self.geometry == "slab":
            # cosh(q u)/cosh(q) = e^{q (u - 1)} (1 + e^{-2 q u}) / (1 + e^{-2 q})
            return np.exp(q * (u - 1.0)) * (1.0 + np.exp(-2.0 * q * u)) / (1.0 + np.exp(-2.0 * q))
        from scipy.special import ive
        # I_0(q u)/I_0(q) with the scaling e^{-Re q}: ive(0, z) = I_0(z) e^{-|Re z|}
        return ive(0, q * u) / ive(0, q) * np.exp(q.real * (u - 1.0))

    def transfer(self, angular_frequency):
        """<g>(j w): the section's mean field per unit applied field, [-]."""
        wt, q = self._q(angular_frequency)
        zero = wt == 0.0
        qs = np.where(zero, 1.0, q)
        factor = 1.0 if self.geometry == "slab" else 2.0
        return np.where(zero, 1.0 + 0j, factor * self._ratio(qs) / qs)

    def mean_squares(self, angular_frequency):
        """(<g^2>, <|g|^2>) over the section, [-] (class docstring)."""
        wt, q = self._q(angular_frequency)
        zero = wt == 0.0
        qs = np.where(zero, 1.0, q)
        wts = np.where(zero, 1.0, wt)
        r = self._ratio(qs)
        if self.geometry == "slab":
            e = np.exp(-2.0 * qs)
            sech2 = 4.0 * e / (1.0 + e) ** 2
            sq = 0.5 * (sech2 + r / qs)
            mod = np.imag(qs * r) / wts
        else:
            sq = 1.0 - r * r
            mod = 2.0 * np.imag(qs * r) / wts
        return np.where(zero, 1.0 + 0j, sq), np.where(zero, 1.0, mod)

    def modes(self, count=8):
        """The mean field as a sum of first-order lags: (time constants [s], weights [-]).

        <g> is meromorphic in s = j w tau with simple poles on the negative
        axis, at the zeros of cosh q (slab: q = j (n - 1/2) pi) or of I_0(q)
        (cylinder: q = j j_{0,n}, j_{0,n} the zeros of J_0); by partial
        fractions

            slab      <g> = sum_n 2 / (s + ((n - 1/2) pi)^2),
            cylinder  <g> = sum_n 4 / (s + j_{0,n}^2),

        i.e. lags of time constant tau/p_n^2 and weight 2/p_n^2 (slab) or
        4/p_n^2 (cylinder), whose weights add up to 1. ``count`` modes are
        kept and the rest, whose lags are the shortest, is taken as
        instantaneous: a last entry with time constant 0 carries the missing
        weight, so the static gain stays exactly 1.
        """
        if count < 1:
            raise ParameterError(f"count = {count!r} is outside the allowed range [1, inf)")
        if self.geometry == "slab":
            p = (np.arange(1, count + 1) - 0.5) * math.pi
            w = 2.0 / p ** 2
        else:
            from scipy.special import jn_zeros
            p = jn_zeros(0, count)
            w = 4.0 / p ** 2
        taus = np.append(self.time_constant / p ** 2, 0.0)
        return taus, np.append(w, 1.0 - w.sum())

    def step(self, field, state, step, count=8):
        """One step of the modal form (:meth:`modes`), exact for H held: (mean H_in, state).

        Parameters
        ----------
        field : float
            Applied field H over the step, [A/m].
        state : array or None
            The lags' outputs (``count`` values; None: at rest at ``field``).
        step : float
            h, [s].
        """
        taus, weights = self.modes(count)
        x = np.full(count, float(field)) if state is None else np.asarray(state, dtype=float)
        a = np.exp(-step / taus[:-1])
        x = a * x + (1.0 - a) * field
        return float(weights[:-1] @ x + weights[-1] * field), x


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
    """A_d = e^{A h}, B_d of eq 27 (x = [y, v], input F) as arrays (:func:`gmt.mechanics.zoh_closed_form`)."""
    a11, a12, a21, a22, b1, b2 = zoh_closed_form(mass, damping, stiffness, step)
    return np.array([[a11, a12], [a21, a22]]), np.array([b1, b2])


@dataclass(frozen=True)
class TwoMassMechanics:
    """Rod and output mass joined by a compliant joint: two degrees of freedom.

    Eq 27 lumps rod, output rod and load into one mass. When the joint
    between the rod's end and the output (a push rod, a piston, a bolted or
    glued interface) is compliant, the output mass m_2 moves on its own
    spring k_j and damper c_j (the standard two-degree-of-freedom model of
    vibration texts, e.g. Thomson & Dahleh, *Theory of Vibration with
    Applications*, 5th ed. 1998, ch. 5; Inman, *Engineering Vibration*,
    ch. 4). With the magnetostrictive force F on the rod (eq 28) and the
    sensor on the output:

        m_1 y_1'' + c y_1' + K y_1 + c_j (y_1' - y_2') + k_j (y_1 - y_2) = F
        m_2 y_2'' + c_j (y_2' - y_1') + k_j (y_2 - y_1) = 0

    In the frequency domain (dynamic stiffness D = K - m w^2 + j w c)

        Y_2 / F = Z_j / [(D_1 + Z_j)(D_2 + Z_j) - Z_j^2],
        Z_j = k_j + j w c_j, D_1 = K - m_1 w^2 + j w c, D_2 = -m_2 w^2,

    which tends to eq 27's 1/(K - (m_1 + m_2) w^2 + j w c) as the joint
    stiffens (Z_j -> inf), and has the same static compliance 1/K.

    Attributes
    ----------
    rod_mass, output_mass : float
        m_1, m_2, [kg].
    damping, stiffness : float
        c [N s/m] and K [N/m] of the rod and prestress spring (eq 27).
    joint_stiffness, joint_damping : float
        k_j [N/m], c_j [N s/m].
    """

    rod_mass: float
    output_mass: float
    damping: float
    stiffness: float
    joint_stiffness: float
    joint_damping: float

    def __post_init__(self):
        for name, unit in (("rod_mass", "kg"), ("output_mass", "kg"), ("stiffness", "N/m"),
                           ("joint_stiffness", "N/m")):
            check_range(name, getattr(self, name), 0.0, math.inf, unit=unit)
        for name in ("damping", "joint_damping"):
            check_range(name, getattr(self, name), 0.0, math.inf, unit="N s/m",
                        low_open=False)

    @classmethod
    def from_joint(cls, mass, damping, stiffness, output_fraction, joint_frequency,
                   joint_damping_ratio):
        """From eq 27's m, c, K, the output's share m_2/m of m, and the joint's own mode.

        The joint's natural frequency is that of m_2 on k_j with the rod held,
        f_j = sqrt(k_j/m_2)/(2 pi) [Hz], and its damping ratio
        c_j / (2 sqrt(k_j m_2)); m_1 + m_2 = m.
        """
        check_range("output_fraction", output_fraction, 0.0, 1.0)
        m2 = mass * output_fraction
        kj = m2 * (2.0 * math.pi * joint_frequency) ** 2
        return cls(mass - m2, m2, damping, stiffness, kj,
                   2.0 * joint_damping_ratio * math.sqrt(kj * m2))

    def matrices(self):
        """Continuous (A, B, C), x = [y_1, v_1, y_2, v_2], input F, output y_2."""
        m1, m2, c, k = self.rod_mass, self.output_mass, self.damping, self.stiffness
        kj, cj = self.joint_stiffness, self.joint_damping
        a = np.array([[0.0, 1.0, 0.0, 0.0],
                      [-(k + kj) / m1, -(c + cj) / m1, kj / m1, cj / m1],
                      [0.0, 0.0, 0.0, 1.0],
                      [kj / m2, cj / m2, -kj / m2, -cj / m2]])
        return a, np.array([0.0, 1.0 / m1, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, 0.0])

    def zoh_matrices(self, step):
        """Exact ZOH discretisation (A_d, B_d) for one step h, F held over it.

        From one matrix exponential of the augmented system (Van Loan 1978;
        Franklin, Powell & Workman, *Digital Control of Dynamic Systems*,
        sec. 4.3): exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, 1]].
        """
        from scipy.linalg import expm

        a, b, _ = self.matrices()
        aug = np.zeros((5, 5))
        aug[:4, :4] = a
        aug[:4, 4] = b
        e = expm(aug * step)
        return e[:4, :4], e[:4, 4]

    def response(self, angular_frequency, step=None):
        """Y_2/F at w, [m/N]: continuous, or the ZOH-sampled model at ``step`` [s].

        The sampled form is C (z I - A_d)^-1 B_d at z = e^{j w h}, with y_2 the
        state at the start of the step, as :func:`zoh_frequency_response`
        gives for eq 27.
        """
        w = np.atleast_1d(np.asarray(angular_frequency, dtype=float))
        if step is None:
            zj = self.joint_stiffness + 1j * w * self.joint_damping
            d1 = self.stiffness - self.rod_mass * w * w + 1j * w * self.damping
            d2 = -self.output_mass * w * w
            return zj / ((d1 + zj) * (d2 + zj) - zj * zj)
        z = np.exp(1j * w * step)
        modes = _two_mass_modes(self)
        if modes is not None:
            # A = V diag(l) V^-1: A_d = V e^{L h} V^-1, B_d = V diag((e^{l h} - 1)/l) V^-1 B,
            # C (z I - A_d)^-1 B_d = sum_i r_i (e^{l_i h} - 1) / (l_i (z - e^{l_i h})),
            # r_i = (C V)_i (V^-1 B)_i
            lam, res = modes
            gain = res * np.expm1(lam * step) / lam
            return (gain[None, :] / (z[:, None] - np.exp(lam * step)[None, :])).sum(axis=1)
        ad, bd = self.zoh_matrices(step)  # (nearly) repeated eigenvalues
        _, _, c = self.matrices()
        lhs = z[:, None, None] * np.eye(4) - ad
        x = np.linalg.solve(lhs, np.broadcast_to(bd.astype(complex), (w.size, 4))[..., None])
        return x[:, :, 0] @ c


@lru_cache(maxsize=64)
def _two_mass_modes(system: TwoMassMechanics):
    """Eigenvalues l_i of A and residues (C V)_i (V^-1 B)_i; None when A is (nearly) defective."""
    a, b, c = system.matrices()
    lam, vec = np.linalg.eig(a)
    if not np.linalg.cond(vec) < 1e8:
        return None
    return lam, (c @ vec) * np.linalg.solve(vec, b.astype(complex))


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
