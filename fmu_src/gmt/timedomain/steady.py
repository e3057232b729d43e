"""The time-domain magnetics under a sinusoidal current: what the paper's model describes.

Under i = I_m cos(w t) the time-domain model settles to a periodic B(t) that
is not a sinusoid (the core is nonlinear and lossy). :func:`sinusoidal_response`
steps it to that periodic state and reports it in the paper's terms: B_m
(half the peak-to-peak B, what eq 22 measures from the sensing coil's peak),
the complex permeability of B's fundamental, mu' - j mu'' = B_1 / (mu_0 H_m)
(eq 3), the lag of eq 18, and the loss per cycle as the loop integral of
H dB (eq 13), against which eqs 7, 9, 11 are the loss separation.

:func:`fit_reversible_permeability` fits the reversible curve to the paper's
Table 1 at its lowest frequency (5 Hz), where the dynamic terms are small.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..constants import MU_0
from ..errors import ParameterError
from ..parameters import TransducerParameters
from .magnetics import TimeDomainStepper
from .parameters import TimeDomainParameters

__all__ = ["SinusoidalResponse", "sinusoidal_response", "fit_reversible_permeability",
           "Comparison", "compare_with_paper"]


@dataclass(frozen=True)
class SinusoidalResponse:
    """The periodic state of the time-domain model under i = I_m cos(w t) (SI)."""

    frequency: float  #: f, [Hz]
    current_amplitude: float  #: I_m, [A]
    field_amplitude: float  #: H_m, [A/m] (eq 1)
    flux_density_amplitude: float  #: B_m, half the peak-to-peak B, [T]
    mu_real: float  #: mu' of B's fundamental, [-] (eq 3)
    mu_imag: float  #: mu'' of B's fundamental, [-] (eq 3)
    loss_per_cycle: float  #: loop integral of H dB, [J/m^3] (eq 13 per cycle and volume)
    hysteresis_loss: float  #: its rate-independent part, [J/m^3] (eq 7 per cycle)
    eddy_loss: float  #: its eddy part, [J/m^3] (eq 9 per cycle)
    excess_loss: float  #: its excess part, [J/m^3] (eq 11 per cycle)
    peak_to_peak: float  #: peak-to-peak displacement, [m]
    dy: float  #: y(i = I_m) - y(i = -I_m), [m] (eq 40's stroke)

    @property
    def lag(self) -> float:
        """Lag of B's fundamental behind H, arctan(mu''/mu'), [rad] (eq 18)."""
        return math.atan2(self.mu_imag, self.mu_real)

    def as_dict(self) -> dict:
        """The fields and the lag, for tables and JSON."""
        return dict(asdict(self), lag=self.lag)


def sinusoidal_response(params: TransducerParameters | None = None,
                        td: TimeDomainParameters | None = None, frequency: float = 50.0,
                        current_amplitude: float = 1.0, samples: int = 2000,
                        periods: int = 4) -> SinusoidalResponse:
    """Step the time-domain model through ``periods`` periods of i = I_m cos(w t).

    Parameters
    ----------
    params, td : the transducer (Table 2) and the time-domain parameters.
    frequency : float
        f, [Hz], > 0.
    current_amplitude : float
        I_m, [A], > 0.
    samples : int
        Steps per period (even, >= 20); the last period is analysed.
    periods : int
        Periods stepped from the demagnetised state at rest (>= 2).

    Notes
    -----
    Over step k the current is held at its value at the step's middle. The
    energy the source delivers over the step is exactly H_k (B_{k+1} - B_k), so
    the discrete loop integral is the model's loss.
    """
    if not (frequency > 0.0 and current_amplitude > 0.0):
        raise ParameterError(f"frequency = {frequency!r} Hz and current_amplitude = "
                             f"{current_amplitude!r} A must be > 0")
    if samples < 20 or samples % 2 or periods < 2:
        raise ParameterError(f"samples = {samples} (even, >= 20) and periods = {periods} (>= 2)")
    params = params or TransducerParameters()
    stepper = TimeDomainStepper(params, td)
    mag = stepper.magnetics
    h = 1.0 / (frequency * samples)
    w = 2.0 * math.pi * frequency
    n = samples * periods
    # the current held over step k is the sinusoid at the step's middle (the symmetric
    # sample: a held i(t_k) would lag the drive by half a step); B, y at the steps' ends
    current = current_amplitude * np.cos(w * h * (np.arange(n + 1) + 0.5))
    b = np.empty(n + 1)
    hyst = np.empty(n + 1)
    y = np.empty(n + 1)
    b[0], hyst[0], y[0] = 0.0, 0.0, stepper.displacement
    for k in range(n):
        stepper.step(float(current[k]), h)
        b[k + 1], hyst[k + 1], y[k + 1] = mag.flux_density, mag.static_field(), stepper.displacement
    last = slice(n - samples, n + 1)
    bl, hl, il, yl = b[last], hyst[last], current[last], y[last]
    field = params.field_per_ampere * il
    db = np.diff(bl)
    # the dynamic parts by their continuous formulas on the run's B (the step's own eddy
    # term is exponentially fitted: magnetics.TimeDomainMagnetics.eddy_stiffness)
    rate = db / h
    eddy = mag.k_e * rate
    excess = mag.k_ex * np.sign(rate) * np.sqrt(np.abs(rate))
    # the hysteresis part: H_hys at the step's end (the point backward Euler evaluates)
    w_h = float(np.sum(hl[1:] * db))
    phase = np.exp(-1j * w * h * np.arange(samples))
    b1 = 2.0 * np.mean(bl[:-1] * phase)
    hm = params.field_per_ampere * current_amplitude
    mu = b1 / (MU_0 * hm)
    ys = yl[:-1]
    return SinusoidalResponse(
        frequency=float(frequency), current_amplitude=float(current_amplitude),
        field_amplitude=hm, flux_density_amplitude=float(0.5 * (bl.max() - bl.min())),
        mu_real=float(mu.real), mu_imag=float(-mu.imag),
        loss_per_cycle=float(np.sum(field[:-1] * db)), hysteresis_loss=w_h,
        eddy_loss=float(np.sum(eddy * db)), excess_loss=float(np.sum(excess * db)),
        peak_to_peak=float(ys.max() - ys.min()), dy=float(ys[0] - ys[samples // 2]))


def fit_reversible_permeability(params: TransducerParameters | None = None,
                                td: TimeDomainParameters | None = None,
                                points=((5.0, 0.5, 0.0300), (5.0, 0.7, 0.0530)),
                                samples: int = 1000) -> tuple[float, list[float]]:
    """mu_rev that brings the model's B_m closest to measured points, in log terms.

    Parameters
    ----------
    points : sequence of (f [Hz], I_m [A], B_m [T])
        Default: the paper's Table 1 at 5 Hz.

    Returns
    -------
    (float, list of float)
        The fitted mu_rev and the model's B_m at each point, [T].
    """
    from scipy.optimize import minimize_scalar

    td = td or TimeDomainParameters()

    def model(mu):
        trial = td.replace(reversible_permeability=mu)
        return [sinusoidal_response(params, trial, f, i, samples).flux_density_amplitude
                for f, i, _ in points]

    def cost(log_mu):
        return sum(math.log(m / p[2]) ** 2 for m, p in zip(model(math.exp(log_mu)), points))

    best = minimize_scalar(cost, bounds=(math.log(1.5), math.log(1e3)), method="bounded",
                           options={"xatol": 1e-5})
    mu = float(math.exp(best.x))
    return mu, model(mu)


@dataclass(frozen=True)
class Comparison:
    """The two models at one sinusoidal operating point, side by side (SI)."""

    frequency: float  #: f, [Hz]
    current_amplitude: float  #: I_m, [A]
    measured_flux_density: float | None  #: Table 1's B_m there, [T] (None: not measured)
    paper: dict  #: the paper's model: B_m (its input), mu', mu'', lag, loss per cycle, y
    time_domain: dict  #: the time-domain model's, the same keys

    def differences(self) -> dict:
        """time_domain / paper - 1 of each quantity (the lag's in degrees: the difference)."""
        out = {}
        for key, value in self.paper.items():
            other = self.time_domain[key]
            out[key] = (math.degrees(other - value) if key == "lag"
                        else (other / value - 1.0 if value else math.nan))
        return out


def compare_with_paper(params: TransducerParameters | None = None,
                       td: TimeDomainParameters | None = None, frequency: float = 50.0,
                       current_amplitude: float = 1.0, samples: int = 2000,
                       calibration=None) -> Comparison:
    """Both models under i = I_m cos(w t): B_m, mu', mu'', lag, loss per cycle, strokes.

    The paper's model takes B_m from the calibration (Table 1 at its own points,
    :mod:`gmt.calibration`) and mu'' from eq 16, mu' from eq 20, the loss per
    cycle from eq 12 (P_loss / (f V)); the time-domain model predicts all of
    them from the current (:func:`sinusoidal_response`). ``dy`` and
    ``peak_to_peak`` are the free rod's strokes (eq 40; the paper's from eq 30's
    closed form).
    """
    from ..calibration import DEFAULT_CALIBRATION, TABLE_1
    from ..forward import loop_metrics, operating_point
    from ..parameters import Excitation

    params = params or TransducerParameters()
    point = operating_point(params, Excitation(frequency, current_amplitude),
                            calibration or DEFAULT_CALIBRATION)
    metrics = loop_metrics(params, point)
    paper = {"flux_density_amplitude": point.flux_density_amplitude,
             "mu_real": point.mu_real, "mu_imag": point.mu_imag, "lag": point.lag,
             "loss_per_cycle": point.losses.total / (frequency * params.rod_volume),
             "peak_to_peak": metrics["peak_to_peak"], "dy": metrics["dy"]}
    r = sinusoidal_response(params, td, frequency, current_amplitude, samples)
    time_domain = {"flux_density_amplitude": r.flux_density_amplitude, "mu_real": r.mu_real,
                   "mu_imag": r.mu_imag, "lag": r.lag, "loss_per_cycle": r.loss_per_cycle,
                   "peak_to_peak": r.peak_to_peak, "dy": r.dy}
    measured = next((b for f, i, _, b in TABLE_1
                     if f == frequency and i == current_amplitude), None)
    return Comparison(float(frequency), float(current_amplitude), measured, paper,
                      time_domain)
