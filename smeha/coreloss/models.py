"""Loss laws fitted to measured core losses and evaluated on any flux waveform.

Three laws, each a frozen dataclass with ``predict(data)`` -> loss per volume [W/m^3]:

* :class:`SeparationLaw`: the paper's loss separation (eqs 7, 9, 11: K_h, n,
  K_e, K_ex) run through the time-domain magnetics (:mod:`gmt.timedomain`):
  the hysteresis operator's loss per cycle K_h B_pk^n and Bertotti's eddy and
  excess fields integrated over the row's flux waveform.
* :class:`ExtendedLaw`: the same field separation with the rate field and the
  relaxation of :mod:`gmt.timedomain.dynamic`, a second hysteresis density and a
  break of the hysteresis exponent (:mod:`gmt.timedomain.hysteresis`; parameters of
  :class:`gmt.TimeDomainParameters`).
* :class:`SteinmetzLaw`: P = k f^alpha B^beta on sinusoids and, on any other
  waveform, the improved generalised Steinmetz equation (iGSE, Venkatachalam
  et al. 2002, eq 9 there): P = (1/T) integral k_i |dB/dt|^alpha dB_pp^(beta -
  alpha) dt with k_i = k / ((2 pi)^(alpha - 1) integral_0^(2 pi) |cos|^alpha
  2^(beta - alpha) d theta).

The fits (:func:`fit_separation`, :func:`fit_steinmetz`, :func:`fit_extended`)
minimise relative errors: the laws are linear in their coefficients, so each
fit is a nonnegative least-squares solve (Lawson & Hanson, *Solving Least
Squares Problems*, 1974, ch. 23) inside a bounded search over the exponents
(variable projection, Golub & Pereyra 1973). Nonnegative coefficients keep
every loss term, and so the loss per cycle, nonnegative.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import least_squares, nnls

from gmt.timedomain.dynamic import segment_losses, sine_losses
from gmt.timedomain.hysteresis import cycle_loss_per_coefficient
from gmt.timedomain.separation import cos_power_mean

from .measurements import CoreLossData

__all__ = ["SeparationLaw", "ExtendedLaw", "SteinmetzLaw", "fit_separation", "fit_steinmetz",
           "fit_extended", "EXPONENT_BOUNDS"]

#: Search ranges of the exponents n, q, beta, n2, m (-), log10 of tau (s) and of r_b (T).
EXPONENT_BOUNDS = {"steinmetz_exponent": (1.05, 3.0), "rate_exponent": (1.0, 4.0),
                   "swing_exponent": (1.0, 4.0), "log10_relaxation_time": (-8.0, -4.0),
                   "second_steinmetz_exponent": (1.05, 4.0),
                   "log10_steinmetz_break": (-1.7, 0.3),
                   "steinmetz_exponent_high": (1.05, 4.0)}


def _terms(data: CoreLossData, n, q=2.0, beta=2.0, tau=1e-6, extended=False, n2=3.5,
           knee=math.inf, m=2.0):
    """Loss per cycle per unit coefficient of each term, columns (rows, terms), [J/m^3].

    Hysteresis B_pk^n (the operator's loss, eq 7, for r_0 <= B_pk <= r_max; above
    the break ``knee`` its exponent turns to ``m``,
    :func:`gmt.timedomain.hysteresis.cycle_loss_per_coefficient`), eddy, excess, and
    with ``extended`` the rate field, the relaxation (:mod:`gmt.timedomain.dynamic`)
    and the second hysteresis density's B_pk^n2 (same break;
    :class:`gmt.timedomain.hysteresis.BranchSum`), each with unit coefficient. The eddy and
    excess columns are per unit K_e and K_ex of eqs 9 and 11 (k_e = K_e/(2 pi^2),
    k_ex = K_ex/C, :mod:`gmt.timedomain.separation`).
    """
    from gmt.timedomain.separation import EXCESS_CONSTANT

    sine = data.family("sine")
    bm = data.flux_density
    k_e, k_ex = 1.0 / (2.0 * math.pi ** 2), 1.0 / EXCESS_CONSTANT
    cols = [cycle_loss_per_coefficient(bm, n, knee, m)]
    out = np.zeros((len(data), 4 if extended else 2))
    if sine.any():
        terms = sine_losses(data.frequency[sine], bm[sine], k_e, k_ex, 1.0 if extended else 0.0,
                            q, beta, 1.0 if extended else 0.0, tau)
        out[sine] = np.column_stack(terms[:out.shape[1]])
    other = ~sine
    if other.any():
        terms = segment_losses(data.durations[other], data.swings[other], 2.0 * bm[other], k_e,
                               k_ex, 1.0 if extended else 0.0, q, beta,
                               1.0 if extended else 0.0, tau)
        out[other] = np.column_stack(terms[:out.shape[1]])
    if extended:
        out = np.column_stack([out, cycle_loss_per_coefficient(bm, n2, knee, m)])
    return np.column_stack(cols + [out])


def _relative_nnls(columns, frequency, loss, weight):
    """Nonnegative coefficients minimising sum (w (P_model/P - 1))^2; (coefs, residuals)."""
    a = columns * (frequency / loss * weight)[:, None]
    scale = np.max(np.abs(a), axis=0)
    scale[scale == 0.0] = 1.0
    coef, _ = nnls(a / scale, weight, maxiter=50 * a.shape[1])
    coef = coef / scale
    return coef, a @ coef - weight


@dataclass(frozen=True)
class SeparationLaw:
    """The paper's loss separation: per cycle K_h B^n + K_e B^2 f + K_ex B^1.5 f^0.5 (sine)."""

    hysteresis_coefficient: float  #: K_h, [J/(m^3 T^n)]
    steinmetz_exponent: float  #: n, [-]
    eddy_coefficient: float  #: K_e, [J s/(m^3 T^2)]
    excess_coefficient: float  #: K_ex, [J s^0.5/(m^3 T^1.5)]

    def coefficients(self):
        return np.array([self.hysteresis_coefficient, self.eddy_coefficient,
                         self.excess_coefficient])

    def predict(self, data: CoreLossData) -> np.ndarray:
        """Loss per volume of every row, [W/m^3]."""
        return data.frequency * (_terms(data, self.steinmetz_exponent) @ self.coefficients())

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class ExtendedLaw:
    """The separation with the rate field and the relaxation (:mod:`gmt.timedomain.dynamic`).

    Field names are those of :class:`gmt.TransducerParameters` and
    :class:`gmt.TimeDomainParameters`, so a fit can feed the time-domain magnetics.
    """

    hysteresis_coefficient: float
    steinmetz_exponent: float
    eddy_coefficient: float
    excess_coefficient: float
    rate_coefficient: float
    rate_exponent: float
    swing_exponent: float
    relaxation_coefficient: float
    relaxation_time: float
    second_hysteresis_coefficient: float = 0.0
    second_steinmetz_exponent: float = 3.5
    steinmetz_break: float = 2.0
    steinmetz_exponent_high: float = 2.0

    def coefficients(self):
        return np.array([self.hysteresis_coefficient, self.eddy_coefficient,
                         self.excess_coefficient, self.rate_coefficient,
                         self.relaxation_coefficient, self.second_hysteresis_coefficient])

    def predict(self, data: CoreLossData) -> np.ndarray:
        """Loss per volume of every row, [W/m^3]."""
        cols = _terms(data, self.steinmetz_exponent, self.rate_exponent, self.swing_exponent,
                      self.relaxation_time, True, self.second_steinmetz_exponent,
                      self.steinmetz_break, self.steinmetz_exponent_high)
        return data.frequency * (cols @ self.coefficients())

    def time_domain_parameters(self):
        """(TransducerParameters changes, TimeDomainParameters changes) as dicts."""
        d = asdict(self)
        paper = {k: d[k] for k in ("hysteresis_coefficient", "steinmetz_exponent",
                                   "eddy_coefficient", "excess_coefficient")}
        return paper, {k: v for k, v in d.items() if k not in paper}

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class SteinmetzLaw:
    """P = k f^alpha B^beta (sinusoids), iGSE on other waveforms."""

    k: float  #: [W/m^3 Hz^-alpha T^-beta]
    alpha: float
    beta: float

    @property
    def k_i(self) -> float:
        """iGSE's k_i (Venkatachalam et al. 2002, eq 10)."""
        a, b = self.alpha, self.beta
        return self.k / ((2.0 * math.pi) ** (a - 1.0) * 2.0 * math.pi * cos_power_mean(a)
                         * 2.0 ** (b - a))

    def predict(self, data: CoreLossData) -> np.ndarray:
        """Loss per volume of every row, [W/m^3]: Steinmetz on sinusoids, iGSE elsewhere."""
        out = np.empty(len(data))
        sine = data.family("sine")
        f, bm = data.frequency[sine], data.flux_density[sine]
        out[sine] = self.k * f ** self.alpha * bm ** self.beta
        other = ~sine
        dur, sw = data.durations[other], data.swings[other]
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = np.where(dur > 0.0, np.abs(sw) / dur, 0.0)
        integral = np.sum(rate ** self.alpha * dur, axis=1)
        pp = 2.0 * data.flux_density[other]
        out[other] = data.frequency[other] * self.k_i * pp ** (self.beta - self.alpha) * integral
        return out

    def as_dict(self) -> dict:
        return asdict(self)


def fit_steinmetz(data: CoreLossData) -> SteinmetzLaw:
    """k, alpha, beta by linear least squares of ln P on ln f, ln B over sinusoidal rows."""
    sine = data.family("sine")
    a = np.column_stack([np.ones(int(sine.sum())), np.log(data.frequency[sine]),
                         np.log(data.flux_density[sine])])
    c, *_ = np.linalg.lstsq(a, np.log(data.loss[sine]), rcond=None)
    return SteinmetzLaw(float(np.exp(c[0])), float(c[1]), float(c[2]))


def _group_weights(data: CoreLossData) -> np.ndarray:
    """Each waveform family present weighs as much in total as the sinusoids."""
    w = np.zeros(len(data))
    for k in np.unique(data.waveform):
        m = data.waveform == k
        w[m] = 1.0 / math.sqrt(m.sum())
    return w


def fit_separation(data: CoreLossData) -> SeparationLaw:
    """K_h, n, K_e, K_ex of the paper's separation on ``data`` (its sinusoids, in practice)."""
    w = _group_weights(data)
    lo, hi = EXPONENT_BOUNDS["steinmetz_exponent"]

    def cost(n):
        return _relative_nnls(_terms(data, n), data.frequency, data.loss, w)

    grid = np.linspace(lo, hi, 40)
    n0 = min(grid, key=lambda n: float(np.sum(cost(n)[1] ** 2)))
    sol = least_squares(lambda x: cost(x[0])[1], [n0], bounds=([lo], [hi]))
    coef = cost(sol.x[0])[0]
    return SeparationLaw(float(coef[0]), float(sol.x[0]), float(coef[1]), float(coef[2]))


def fit_extended(data: CoreLossData, start: SeparationLaw | None = None) -> ExtendedLaw:
    """The thirteen parameters of :class:`ExtendedLaw` on ``data`` (the calibration rows).

    The exponents n, q, beta, log10 tau, n2, log10 r_b and m are searched within
    :data:`EXPONENT_BOUNDS` from two starts (n from ``start``; q 2 and 3; tau
    1 us; n2 3.5; r_b 50 mT; m 1.5), the six coefficients solved nonnegative for each.
    Each waveform family weighs as much as the sinusoids (:func:`_group_weights`).
    """
    w = _group_weights(data)
    names = ("steinmetz_exponent", "rate_exponent", "swing_exponent", "log10_relaxation_time",
             "second_steinmetz_exponent", "log10_steinmetz_break", "steinmetz_exponent_high")
    lo = [EXPONENT_BOUNDS[k][0] for k in names]
    hi = [EXPONENT_BOUNDS[k][1] for k in names]

    def solve(x):
        cols = _terms(data, x[0], x[1], x[2], 10.0 ** x[3], True, x[4], 10.0 ** x[5], x[6])
        return _relative_nnls(cols, data.frequency, data.loss, w)

    n0 = start.steinmetz_exponent if start else 2.5
    best = None
    for q0 in (2.0, 3.0):
        x0 = np.clip([n0, q0, 2.5, -6.0, 3.5, -1.3, 1.5], np.add(lo, 1e-6), np.subtract(hi, 1e-6))
        sol = least_squares(lambda x: solve(x)[1], x0, bounds=(lo, hi), diff_step=1e-4,
                            max_nfev=200)
        if best is None or sol.cost < best.cost:
            best = sol
    coef = solve(best.x)[0]
    n, q, beta, log_tau, n2, log_knee, m = (float(v) for v in best.x)
    return ExtendedLaw(float(coef[0]), n, float(coef[1]), float(coef[2]), float(coef[3]), q,
                       beta, float(coef[4]), 10.0 ** log_tau, float(coef[5]), n2,
                       10.0 ** log_knee, m)
