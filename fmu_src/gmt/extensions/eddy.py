"""Eddy currents as a lag of the field inside the rod: g(jw) = (1 + j w tau)^-alpha.

Eddy currents shield the rod's interior: the field inside lags the applied
field, H_in = g H. alpha = 1 is the first-order (lumped) lag; alpha = 1/2 is
the fractional lag whose high-frequency limit (j w tau)^(-1/2) is that of 1-D
diffusion into a slab or cylinder (Stoll, *The Analysis of Eddy Currents*,
Clarendon 1974; Bertotti, *Hysteresis in Magnetism*, Academic Press 1998,
ch. 12), with phase tending to alpha 90 deg and an amplitude falling as
f^-alpha, where the classical eddy loss of eq 9 would keep growing as f.
Inside the rod M = (mu - 1) H_in and B = mu_0 mu H_in (eqs 4-5 on the field
inside); the coil sees the mean B, so mu' is re-solved so that the model
keeps the measured B_m (:func:`eddy_calibrated_permeability`). The diffusion
itself, with its profile across the section, is :mod:`gmt.extensions.diffusion`.

Time-stepped form
-----------------
For alpha = 1 one first-order section, stepped exactly for the held input.
For 0 < alpha < 1, (1 + s tau)^-alpha is a Stieltjes function, a positive
mixture of first-order lags with time constants in (0, tau] (the "diffusive
representation" of fractional operators, Montseny, ESAIM Proc. 5 (1998)
159-175):

    (1 + s tau)^-alpha = (sin(pi alpha) / pi) int_0^inf t^-alpha / (1 + t + s tau) dt.

It is realised by a bank of first-order sections r_j / (1 + s tau_j) with
tau_j log-spaced from tau down to one tenth of the smallest time scale of the
band, :data:`SECTIONS_PER_DECADE` a decade, plus a direct term r_0, the
weights fitted by non-negative least squares (Lawson & Hanson 1974,
:func:`gmt.extensions._numerics.nnls`) to g over 0 to :data:`LAG_BAND` Hz
(relative error weighted) and scaled to the exact DC gain 1. The fit's
largest relative error over the band is :attr:`SectionBank.max_relative_error`:
below 2.5e-4 for every alpha in [0.3, 1) and tau in [1 us, 0.1 s]. Each
section is stepped exactly for the held input, and the field held over a step
is the *mean* of the section's response over the step,
u + (x - u) (tau_j / h)(1 - e^{-h/tau_j}): the zero-order hold delays by h/2
and the mean over the step advances by h/2, so the held field equals the
continuous g H at t_k to second order in w h (relative error about
(w h)^2 / 12). The quadrature field H_q passes through the same bank.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import MU_0
from ..errors import ParameterError, check_range
from ..forward import Magnetics
from ..magnetostriction import magnetostriction, magnetostrictive_force
from ..permeability import flux_density, magnetization
from ._base import Extension, FieldState, FitSpec, Parameter
from ._numerics import nnls

#: Upper end of the band over which the step forms' sections are fitted, [Hz].
LAG_BAND = 1e5
#: First-order sections a decade of time constants in the fractional lag.
SECTIONS_PER_DECADE = 6


@dataclass(frozen=True)
class EddyCurrentLag:
    """Lag of the field inside the rod behind the applied field (module docstring).

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
                                 "only (a fractional lag needs a bank of sections, "
                                 "SectionBank)")
        if self.time_constant == 0.0:
            return field
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
    mod = flux_density_amplitude / (MU_0 * field_amplitude * abs(lag))
    if not mod > mu_imag:
        return math.nan
    return math.sqrt(mod * mod - mu_imag * mu_imag)


class SectionBank:
    """A bank of first-order lags approximating g(s) = (1 + s tau)^-alpha (module docstring).

    g(s) ~ r_0 + sum_j r_j / (1 + s tau_j), r >= 0, sum r = 1 (exact DC gain).

    Parameters
    ----------
    lag : EddyCurrentLag
        tau [s] and alpha.
    band : float
        Upper end of the fitted band, [Hz].

    Attributes
    ----------
    time_constants : array
        tau_j, [s].
    weights : array
        r_j, [-].
    direct : float
        r_0, [-].
    max_relative_error : float
        max |g_bank - g| / |g| over 0 to ``band`` Hz (4000 log-spaced points and DC).
    """

    def __init__(self, lag, band=LAG_BAND):
        tau, alpha = lag.time_constant, lag.order
        self.lag = lag
        if tau == 0.0 or alpha == 1.0:
            self.time_constants = np.array([tau]) if tau > 0.0 else np.zeros(0)
            self.weights = np.ones(self.time_constants.size)
            self.direct = 0.0 if tau > 0.0 else 1.0
            self.max_relative_error = 0.0
            return
        x_max = 2.0 * math.pi * band * tau  # w tau at the top of the band
        lowest = math.log10(0.1 / x_max) if x_max > 0.1 else 0.0
        n = int(math.ceil(-lowest * SECTIONS_PER_DECADE)) + 1
        rho = np.logspace(0.0, lowest, n)  # tau_j / tau
        x = np.concatenate(([0.0], np.logspace(-4.0, math.log10(x_max), 600)))

        def design(xs):
            return np.concatenate((1.0 / (1.0 + 1j * np.outer(xs, rho)),
                                   np.ones((xs.size, 1))), axis=1)

        target = (1.0 + 1j * x) ** (-alpha)
        a = design(x) / np.abs(target)[:, None]
        b = target / np.abs(target)
        r, _ = nnls(np.vstack((a.real, a.imag)), np.concatenate((b.real, b.imag)),
                    max_iterations=50 * (n + 1))
        r = r / r.sum()
        keep = r[:-1] > 0.0
        self.time_constants = tau * rho[keep]
        self.weights = r[:-1][keep]
        self.direct = float(r[-1])
        xt = np.concatenate(([0.0], np.logspace(-5.0, math.log10(x_max), 4000)))
        gt = (1.0 + 1j * xt) ** (-alpha)
        approx = design(xt)[:, np.concatenate((keep, [True]))] @ np.concatenate(
            (self.weights, [self.direct]))
        self.max_relative_error = float(np.max(np.abs(approx - gt) / np.abs(gt)))

    @property
    def size(self) -> int:
        """Number of sections (states per filtered signal)."""
        return int(self.time_constants.size)

    def transfer(self, angular_frequency):
        """The bank's g(j w), [-]."""
        w = np.asarray(angular_frequency, dtype=float)
        return self.direct + np.sum(self.weights / (1.0 + 1j * np.multiply.outer(
            w, self.time_constants)), axis=-1)

    def step(self, signal, state, step):
        """(held output over the step, new state) for inputs ``signal`` held over ``step`` [s].

        ``signal`` has shape (k,), ``state`` (k, size): k signals through the
        same bank. The held output is the mean of each section's exact
        response over the step (module docstring).
        """
        u = np.asarray(signal, dtype=float)[:, None]
        if self.size == 1 and self.direct == 0.0:
            new = self.lag.step(u, state, step)  # first order: EddyCurrentLag.step, exact
        else:
            a = np.exp(-step / self.time_constants)
            new = a * state + (1.0 - a) * u
        mean = u + (state - u) * (-(self.time_constants / step)
                                  * np.expm1(-step / self.time_constants))
        out = self.direct * u[:, 0] + mean @ self.weights
        return out, new


class FilterBankState:
    """Memory of a field-stage form whose state is a bank of sections for H and H_q.

    ``self.bank`` (with ``size``) is set by the form; the state is its filters' outputs.
    """

    def reset(self, rest_displacement):
        self.filters = np.zeros((2, self.bank.size))

    def get_state(self):
        return tuple(float(v) for v in self.filters.ravel())

    def set_state(self, state):
        if len(state) != self.filters.size:
            raise ParameterError(f"{self.cause} ({self.form}) state has {len(state)} values; "
                                 f"its sections need {self.filters.size}")
        self.filters = np.array(state, dtype=float).reshape(self.filters.shape)

    def waveform(self, theta, upstream):
        return np.real(self.magnetization_phasor * np.exp(1j * np.asarray(theta)))


class EddyLagForm(FilterBankState, Extension):
    """Field inside the rod lagging the applied field (module docstring).

    Memory of the time-stepped form: the sections' states for H and H_q, [A/m].
    """

    cause = "eddy_current_diffusion"
    form = "lag"
    stage = "field"
    signals = "B and y"
    parameters = (Parameter("time_constant_s", "s", 0.0, math.inf, low_open=False),
                  Parameter("order", "-", 0.0, 1.0, high_open=False))
    fit = FitSpec(("log10_tau", "order"), ((-4.0, 0.5), (-3.0, 1.0), (-2.5, 0.5)),
                  (-6.0, 0.3), (-1.0, 1.0), neutral=(-6.0, 1.0))

    @classmethod
    def validate(cls, values):
        cls.lag_of(values)

    @staticmethod
    def lag_of(values) -> EddyCurrentLag:
        return EddyCurrentLag(values["time_constant_s"], values["order"])

    @classmethod
    def from_fit(cls, x, context):
        return {"time_constant_s": 10.0 ** x[0], "order": x[1]}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        hit = super().at_bounds(x, tolerance)
        # order 1 (a first-order lag) is a form the lag may take, not a bound pressed on
        return tuple(n for n in hit if not (n == "order" and x[1] >= 1.0 - tolerance))

    # periodic form
    @classmethod
    def field_gain(cls, values, angular_frequency):
        return cls.lag_of(values).transfer(angular_frequency)

    # the hysteresis switches on the lagging field inside (Extension.switching_gain)
    shields_field = True

    @classmethod
    def loss_flux_factor(cls, values, angular_frequency):
        # the lag form evaluates eq 16 at the section-mean flux density, the measured B_m
        return np.abs(cls.field_gain(values, angular_frequency))

    @classmethod
    def steady_field(cls, values, steady, adder=None):
        from .paperpart import paper_permeability
        from .steady import force_gain

        hm, w = steady.field_amplitude, steady.angular_frequency
        g1 = cls.field_gain(values, w)
        mu = paper_permeability(steady.loss, steady.frequency, hm,
                                steady.flux_density_amplitude / (MU_0 * hm), g1, adder,
                                cls.loss_flux_factor(values, w))
        m1 = (mu - 1.0) * g1 * hm
        c = force_gain(steady.params)
        return FieldState(m1, MU_0 * mu * g1 * hm, 2.0 * c * steady.params.bias_magnetization
                          * m1, 0.5 * c * m1 * m1)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        """``point`` carries the paper part's mu (:meth:`gmt.variants.Chain.paper_point`)."""
        super().__init__(values, params, point, upstream)
        self.lag = self.lag_of(values)
        g1 = complex(self.lag.transfer(point.angular_frequency))
        self.magnetization_phasor = complex(point.mu_real - 1.0, -point.mu_imag) * g1 \
            * point.field_amplitude
        self.bank = SectionBank(self.lag)
        self.filters = np.zeros((2, self.bank.size))

    def magnetics(self, current, quadrature, step, time):
        p, pt = self.params, self.point
        h = p.field_per_ampere * current
        hq = p.field_per_ampere * quadrature
        (h_in, hq_in), self.filters = self.bank.step((h, hq), self.filters, step)
        h_in, hq_in = float(h_in), float(hq_in)
        m = magnetization(h_in, hq_in, pt.mu_real, pt.mu_imag)
        lam = magnetostriction(m, p.bias_magnetization, p.magnetostriction_coefficient)
        self.held_switching_field = h_in
        return Magnetics(h, hq, flux_density(h_in, hq_in, pt.mu_real, pt.mu_imag), m, lam,
                         magnetostrictive_force(lam, p.rod_area, p.youngs_modulus))
