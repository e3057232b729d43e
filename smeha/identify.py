"""Identification of the transducer's loss model from measured runs.

The paper's procedure ("Simulation and experiments"), with a few additions:

1. **B_m per run.** From the sensing coil, eq 22: the amplitude E_m of the
   voltage's fundamental at the run's frequency, by linear least squares
   (offset and harmonics 1-3 in the basis), gives B_m = E_m / (w N_c A_c)
   (:func:`gmt.sensing.flux_density_amplitude_from_voltage`), with a standard
   error from the fit. A run without a sense voltage gets B_m from its
   displacement instead: the displacement's fundamental, as a complex
   amplitude relative to the current's fundamental, is
   A_r E^H G(jw) 2 K_lambda M_b H_m ((mu' - 1) - j mu'')
   (:func:`gmt.forward.strain_harmonics`; G the continuous mechanics of
   eq 29, Table 2), which gives mu' and mu'' and
   B_m = mu_0 H_m |mu' - j mu''| (eq 19). Each run reports its source.
2. **mu'' per run.** The model's prediction of the loop is eq 30 in
   periodic steady state for the current's fundamental i = I_m cos(w t + phi)
   (f, I_m and phi of the run's current by least squares): the strain
   harmonics of eq 25 (:func:`gmt.forward.strain_harmonics`) through the
   **continuous** mechanics of eq 27, Y_k = A_r E^H Lambda_k G(j k w), at the
   operating point (the run's B_m, mu'' imposed), evaluated at the sample
   times, with the first period discarded as transient and a constant
   displacement offset fitted (measured displacements are relative). The
   transducer is a continuous system, so the model does not depend on how
   the data were sampled (uniform or not, at any rate). The paper's scan of
   mu'' over [0, 10] (bounded above by |mu| = B_m/(mu_0 H_m), where mu' of
   eq 20 stops being real) brackets the minimum of the sum of squares; a
   bounded Brent search refines it, and one Gauss-Newton step polishes it.
   The standard error comes from the curvature of the sum of squares
   (Gauss-Newton, 2 J^T J) and the residual variance, with the
   uncertainty of B_m propagated through the sensitivity d mu''/d B_m of the
   fit.
3. **Loss coefficients across runs.** The set of eqs 16,
   P/V = pi f mu_0 mu'' H_m^2 = K_h B_m^n f + K_e (B_m f)^2 + K_ex (B_m f)^1.5,
   solved for K_h, n, K_e, K_ex by weighted nonlinear least squares
   (:func:`scipy.optimize.least_squares`, residuals in mu'' divided by each
   run's standard error), started from a variable-projection scan over n
   (the problem is linear in K_h, K_e, K_ex for fixed n). B_m is measured
   too, and its error moves the measured mu'' and eq 16's prediction
   together, so the weights are refined to the effective standard error
   sqrt(se_fit^2 + ((d mu''/d B_m - d g/d B_m) se_B)^2), g the right side of
   eq 16 at the current estimate (errors-in-variables, iterated). The covariance is
   (J^T J)^-1 scaled by the residual variance; with fewer than five runs
   (no residual degrees of freedom left) the uncertainty is not determined.

SI inside; the physics is :mod:`gmt`'s.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from types import SimpleNamespace

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

import gmt
from gmt import losses as gmt_losses
from gmt.constants import MU_0
from gmt.extensions.steady import mechanics_response
from gmt.forward import strain_harmonics
from gmt.parameters import STEINMETZ_RANGE
from gmt.permeability import amplitude_permeability, lag_angle
from gmt.sensing import flux_density_amplitude_from_voltage

from .measured import DataError, Run, harmonic_basis

#: The paper's scan range of mu'' ("varying its value from 0 to 10").
SCAN_RANGE = (0.0, 10.0)
#: Points of the scan over SCAN_RANGE (the paper does not say; 0.2 apart).
SCAN_POINTS = 51
#: Harmonics (besides the offset) in the least-squares fits of a fundamental.
HARMONICS = 3
#: Names, symbols and units of the loss coefficients (eqs 7, 9, 11).
LOSS_COEFFICIENTS = (
    ("K_h", "hysteresis_coefficient", "W s/(m^3 T^n)"),
    ("n", "steinmetz_exponent", "-"),
    ("K_e", "eddy_coefficient", "W s^2/(m^3 T^2)"),
    ("K_ex", "excess_coefficient", "W s^1.5/(m^3 T^1.5)"),
)
#: Fewest runs for the loss-coefficient uncertainties (4 parameters + 1 dof).
MIN_RUNS_FOR_UNCERTAINTY = 5

SOURCES = {"sense_voltage": "sense voltage (eq 22)",
           "displacement": "displacement fundamental (eqs 19, 25, 29)"}


@dataclass(frozen=True)
class RunIdentification:
    """What one run gives: B_m, the complex permeability and the fit quality.

    Attributes
    ----------
    run : str
        Run label.
    frequency : float
        f, [Hz].
    current_amplitude : float
        I_m of the current's fundamental, [A].
    field_amplitude : float
        H_m = N I_m / (k_f L), [A/m] (eq 1).
    flux_density_amplitude, flux_density_stderr : float
        B_m and its standard error, [T].
    flux_density_source : {"sense_voltage", "displacement"}
        Where B_m came from (module docstring, step 1).
    mu_imag, mu_imag_stderr : float
        mu'' minimising the eq 30 error, and its standard error including the
        propagated uncertainty of B_m, [-].
    mu_imag_fit_stderr : float
        Standard error of mu'' from the loop fit alone (B_m held), [-].
    mu_imag_flux_sensitivity : float
        d mu''/d B_m of the loop fit (B_m held at a shifted value), [1/T];
        with ``flux_density_stderr`` it carries B_m's error into the loss fit.
    mu_imag_at_bound : bool
        True when mu'' ended on a bound of the scan (the minimum may lie
        outside it).
    scan_upper : float
        Upper bound of the scan, min(10, |mu|) just below |mu|, [-].
    mu_real : float
        mu' from eq 20, [-].
    lag : float
        Lag of B behind H, arctan(mu''/mu'), [rad] (eq 18).
    rms_residual : float
        RMS of measured minus model displacement over the fitted samples, [m].
    offset : float
        Fitted constant added to the model's displacement, [m].
    samples : int
        Samples in the fit (after the discarded transient).
    discarded_time : float
        Time discarded at the start of the run as transient, [s].
    """

    run: str
    frequency: float
    current_amplitude: float
    field_amplitude: float
    flux_density_amplitude: float
    flux_density_stderr: float
    flux_density_source: str
    mu_imag: float
    mu_imag_stderr: float
    mu_imag_fit_stderr: float
    mu_imag_flux_sensitivity: float
    mu_imag_at_bound: bool
    scan_upper: float
    mu_real: float
    lag: float
    rms_residual: float
    offset: float
    samples: int
    discarded_time: float

    @property
    def loss_density(self) -> float:
        """P/V = pi f mu_0 mu'' H_m^2, [W/m^3] (eq 13)."""
        return math.pi * self.frequency * MU_0 * self.mu_imag * self.field_amplitude ** 2

    def as_dict(self) -> dict:
        """JSON-able dict: SI fields plus ``lag_deg``, ``rms_residual_um``,
        ``loss_density_W_m3``."""
        d = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
             for k, v in asdict(self).items()}
        d["lag_deg"] = math.degrees(self.lag)
        d["rms_residual_um"] = self.rms_residual * 1e6
        d["loss_density_W_m3"] = self.loss_density
        return d


@dataclass(frozen=True)
class LossFit:
    """K_h, n, K_e, K_ex from the set of eqs 16 (weighted least squares).

    Attributes
    ----------
    values : tuple of float
        (K_h, n, K_e, K_ex) in the units of :data:`LOSS_COEFFICIENTS`.
    stderrs : tuple of float or None
        Standard uncertainties; None when not determined (``note`` says why).
    correlation : tuple of tuple of float, or None
        Correlation matrix of the four, in the same order.
    runs : int
        Runs in the fit.
    residual_variance : float or None
        Sum of squared weighted residuals over the degrees of freedom
        (about 1 when the per-run standard errors are right); None without
        degrees of freedom.
    note : str
        What limits the result, or "".
    flags : tuple of str
        Why the coefficients are not a physical result, when they are not
        (:func:`physical_flags`): a negative loss coefficient, an uncertainty
        larger than the value, a residual variance the per-run errors cannot
        explain. Empty for a fit that makes physical sense.
    """

    values: tuple
    stderrs: tuple | None
    correlation: tuple | None
    runs: int
    residual_variance: float | None
    note: str = ""
    flags: tuple = ()

    @property
    def physical(self) -> bool:
        """True when no flag was raised (:attr:`flags`)."""
        return not self.flags

    @property
    def names(self) -> tuple[str, ...]:
        """("K_h", "n", "K_e", "K_ex")."""
        return tuple(n for n, _, _ in LOSS_COEFFICIENTS)

    def parameters(self, params: gmt.TransducerParameters | None = None):
        """A :class:`gmt.TransducerParameters` with these coefficients (others from ``params``)."""
        params = params or gmt.TransducerParameters()
        return params.replace(**{attr: v for (_, attr, _), v in
                                 zip(LOSS_COEFFICIENTS, self.values)})

    def as_dict(self) -> dict:
        """``{name: {"value", "stderr", "unit"}}``, JSON-able."""
        out = {}
        for k, (name, _, unit) in enumerate(LOSS_COEFFICIENTS):
            out[name] = {"value": self.values[k],
                         "stderr": None if self.stderrs is None else self.stderrs[k],
                         "unit": unit}
        return out


@dataclass(frozen=True)
class Identification:
    """Result of :func:`identify`: every run and the loss coefficients.

    Attributes
    ----------
    runs : tuple of RunIdentification
    loss_fit : LossFit or None
        None when there are fewer than four runs (``note`` says so).
    note : str
    """

    runs: tuple
    loss_fit: LossFit | None
    note: str = ""

    def as_dict(self) -> dict:
        """``{"runs": [...], "loss_coefficients": {...} | None, "correlation": ...,
        "loss_fit": ...}``."""
        lf = self.loss_fit
        return {
            "runs": [r.as_dict() for r in self.runs],
            "loss_coefficients": None if lf is None else lf.as_dict(),
            "correlation": None if lf is None or lf.correlation is None else
            {"names": list(lf.names), "matrix": [list(row) for row in lf.correlation]},
            "loss_fit": None if lf is None else
            {"runs": lf.runs, "residual_variance": lf.residual_variance, "note": lf.note,
             "physical": lf.physical, "flags": list(lf.flags),
             "method": "weighted least squares on the set of eqs 16 (weights 1/stderr(mu''))"},
            "note": self.note,
        }


# -- harmonic least squares ---------------------------------------------------------------


def _harmonic_fit(time, signal, frequency, harmonics=HARMONICS):
    """Least-squares offset + harmonics; returns (coef, covariance, residual)."""
    basis = harmonic_basis(time, frequency, harmonics)
    gram_inv = np.linalg.pinv(basis.T @ basis)
    coef = gram_inv @ (basis.T @ signal)  # normal equations: near-orthogonal columns
    resid = signal - basis @ coef
    dof = max(time.size - basis.shape[1], 1)
    sigma2 = float(resid @ resid) / dof
    cov = sigma2 * gram_inv
    return coef, cov, resid


def _phasor(coef, cov, k=1):
    """Complex amplitude a - j b of a cos + b sin at harmonic k, and its 2x2 covariance."""
    a, b = coef[2 * k - 1], coef[2 * k]
    return complex(a, -b), cov[2 * k - 1:2 * k + 1, 2 * k - 1:2 * k + 1]


def flux_density_from_sense_voltage(run: Run, params: gmt.TransducerParameters):
    """B_m from the sensing-coil voltage, eq 22, and its standard error, [T].

    E_m is the amplitude of the voltage's fundamental at ``run.frequency``
    by least squares over the whole run.
    """
    coef, cov, _ = _harmonic_fit(run.time, run.sense_voltage, run.frequency)
    e1, c = _phasor(coef, cov)
    em = abs(e1)
    grad = np.array([e1.real, -e1.imag]) / em if em > 0 else np.zeros(2)
    se_em = math.sqrt(max(float(grad @ c @ grad), 0.0))
    to_b = flux_density_amplitude_from_voltage(1.0, run.frequency, params.sense_turns,
                                               params.sense_area)
    return em * to_b, se_em * to_b


def _current_phasor(time, current, frequency):
    coef, _, _ = _harmonic_fit(time, current, frequency)
    return complex(coef[1], -coef[2])


def flux_density_from_displacement(run: Run, params: gmt.TransducerParameters, mask):
    """B_m (eq 19), mu' and mu'' from the displacement's fundamental, [T], [-], [-].

    Y_1 / (I_1/|I_1|) = A_r E^H G(jw) Lambda_1 with
    Lambda_1 = 2 K_lambda M_b H_m ((mu' - 1) - j mu'') (eq 25 about the bias,
    :func:`gmt.forward.strain_harmonics`) and G the continuous mechanics of
    eq 29 (:func:`gmt.extensions.steady.mechanics_response`).

    Returns
    -------
    (float, float, float, float)
        B_m, its standard error, mu', mu''.
    """
    t, y = run.time[mask], run.displacement[mask]
    w = 2.0 * math.pi * run.frequency
    i1 = _current_phasor(t, run.current[mask], run.frequency)
    im = abs(i1)
    coef, cov, _ = _harmonic_fit(t, y, run.frequency)
    y1, c = _phasor(coef, cov)
    hm = params.field_per_ampere * im
    unit_m = SimpleNamespace(mu_real=2.0, mu_imag=0.0, field_amplitude=hm)  # m = 1
    lam1_per_m = strain_harmonics(params, unit_m)[1]
    gy = mechanics_response(params.mass, params.damping, params.stiffness, [w])
    scale = params.rod_area * params.youngs_modulus * gy[0] * lam1_per_m * (i1 / im)
    m = y1 / scale
    mu = 1.0 + m
    bm = MU_0 * hm * abs(mu)
    # d|1 + Y/s|/d(Re Y, Im Y): (mu/|mu|) . (1/s) for the two directions
    g = np.array([(mu.conjugate() / abs(mu) / scale).real,
                  (mu.conjugate() / abs(mu) * (1j / scale)).real])
    # coefficients are (a, b) with Y = a - j b
    g = np.array([g[0], -g[1]])
    se = MU_0 * hm * math.sqrt(max(float(g @ c @ g), 0.0))
    return bm, se, mu.real, -mu.imag


# -- the loop fit -------------------------------------------------------------------------

def _slow_rate(params):
    """Rate of the slower pole of eq 27, [1/s] (about 7.0e3 with Table 2, gmt.mechanics)."""
    m, c, k = params.mass, params.damping, params.stiffness
    disc = c * c - 4.0 * m * k
    if disc <= 0.0:
        return c / (2.0 * m)
    return (c - math.sqrt(disc)) / (2.0 * m)


class _LoopModel:
    """Model displacement of a run for given (B_m, mu''), on the fitted samples.

    Eq 30 in periodic steady state for the current's fundamental, through the
    continuous mechanics (module docstring, step 2): y = y_0 + Re(Y_1 e^{j theta})
    + Re(Y_2 e^{2 j theta}), theta = w t + phi, at the run's own sample times.
    """

    def __init__(self, run: Run, params, transient_cycles: float):
        self.run, self.params = run, params
        t = run.time
        span = t[-1] - t[0]
        i1 = _current_phasor(t, run.current, run.frequency)
        self.current_amplitude = abs(i1)
        self.current_phase = math.atan2(i1.imag, i1.real)
        if run.cycles >= transient_cycles + 1.0:
            discard = transient_cycles / run.frequency
        else:  # short run: discard 20 time constants of the slower mechanical pole
            discard = min(20.0 / _slow_rate(params), 0.5 * span)
        self.discarded = discard
        self.mask = t >= t[0] + discard - 1e-12 * max(span, 1.0)
        self.data = run.displacement[self.mask]
        w = 2.0 * math.pi * run.frequency
        theta = w * t[self.mask] + self.current_phase
        self._waves = (np.exp(1j * theta), np.exp(2j * theta))
        self._gain = params.rod_area * params.youngs_modulus * mechanics_response(
            params.mass, params.damping, params.stiffness, [w, 2.0 * w])

    def point(self, bm, mu_imag):
        exc = gmt.Excitation(self.run.frequency, self.current_amplitude, bm)
        return gmt.operating_point(self.params, exc, mu_imag=mu_imag)

    def predict(self, bm, mu_imag):
        """Model displacement on the fitted samples, about the bias (no offset), [m]."""
        lam = strain_harmonics(self.params, self.point(bm, mu_imag))
        e1, e2 = self._waves
        return np.real(self._gain[0] * lam[1] * e1) + np.real(self._gain[1] * lam[2] * e2)

    def residual(self, bm, mu_imag):
        """Measured minus model with the best constant offset, [m]; and the offset."""
        r = self.data - self.predict(bm, mu_imag)
        c = float(r.mean())
        return r - c, c


def identify_run(run: Run, params: gmt.TransducerParameters | None = None, *,
                 scan=SCAN_RANGE, scan_points: int = SCAN_POINTS,
                 transient_cycles: float = 1.0) -> RunIdentification:
    """B_m and mu'' of one run (module docstring, steps 1-2).

    Parameters
    ----------
    run : Run
        A checked run (:func:`smeha.measured.read_measurements`).
    params : TransducerParameters, optional
        Mechanics, coil and magnetostriction constants (default Table 2); the
        loss coefficients in it are not used.
    scan : (float, float)
        Range of the mu'' scan (the paper's 0 to 10).
    scan_points : int
        Points of the scan.
    transient_cycles : float
        Periods discarded at the start (the transducer's mechanical transient);
        runs too short for that plus one period discard 20 mechanical time
        constants.

    Returns
    -------
    RunIdentification

    Raises
    ------
    DataError
        When the run cannot be fitted (no current, B_m not positive).
    """
    params = params or gmt.TransducerParameters()
    model = _LoopModel(run, params, transient_cycles)
    im = model.current_amplitude
    if not im > 0:
        raise DataError(f"{run.where()}: the current has no fundamental at "
                        f"{run.frequency:g} Hz", run.source, run.name)
    hm = params.field_per_ampere * im
    if run.sense_voltage is not None:
        bm, se_b = flux_density_from_sense_voltage(run, params)
        source = "sense_voltage"
    else:
        bm, se_b, _, _ = flux_density_from_displacement(run, params, model.mask)
        source = "displacement"
    if not (bm > 0 and math.isfinite(bm)):
        raise DataError(f"{run.where()}: B_m = {bm:g} T from the {SOURCES[source]} is not "
                        "positive", run.source, run.name)
    mod = amplitude_permeability(bm, hm)
    upper = min(scan[1], mod * (1.0 - 1e-9))
    lower = max(scan[0], 0.0)
    if not upper > lower:
        raise DataError(f"{run.where()}: |mu| = B_m/(mu_0 H_m) = {mod:.4g} leaves no room for "
                        f"mu'' in [{lower:g}, {scan[1]:g}] (eq 20)", run.source, run.name)
    scale = 1e6  # fit in micrometres: sums of squares of order 1

    def sse(mu):
        r, _ = model.residual(bm, mu)
        return float(((r * scale) @ (r * scale)))

    grid = np.linspace(lower, upper, scan_points)
    values = np.array([sse(mu) for mu in grid])
    k = int(np.argmin(values))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(sse, bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-12 * max(upper, 1.0), "maxiter": 200})
    mu, s_min = float(res.x), float(res.fun)

    def jac(fn, x, h, lo_=-math.inf, hi_=math.inf):
        a, b = max(x - h, lo_), min(x + h, hi_)
        return (fn(b) - fn(a)) / (b - a)

    h_mu = 1e-6 * max(mu, 1e-3)
    j_mu = jac(lambda m: -model.residual(bm, m)[0] * scale, mu, h_mu, lower, upper)
    jj = float(j_mu @ j_mu)
    r0 = model.residual(bm, mu)[0] * scale
    if jj > 0:  # one Gauss-Newton step from the Brent minimum
        cand = min(max(mu + float(j_mu @ r0) / jj, lower), upper)
        r1 = model.residual(bm, cand)[0] * scale
        if float(r1 @ r1) < s_min:
            mu, s_min, r0 = cand, float(r1 @ r1), r1
    n = r0.size
    sigma2 = s_min / max(n - 2, 1)  # mu'' and the offset
    se_fit = math.sqrt(sigma2 / jj) if jj > 0 else math.inf
    # B_m's uncertainty through the fit's sensitivity d mu''/d B_m = -(J_mu . J_B)/(J_mu . J_mu)
    h_b = 1e-6 * bm
    j_b = jac(lambda b: -model.residual(b, mu)[0] * scale, bm, h_b)
    dmu_db = -float(j_mu @ j_b) / jj if jj > 0 else 0.0
    se_mu = math.sqrt(se_fit ** 2 + (dmu_db * se_b) ** 2)
    r, offset = model.residual(bm, mu)
    point = model.point(bm, mu)
    at_bound = bool(mu <= lower + 1e-9 * max(upper, 1.0) or mu >= upper * (1 - 1e-9))
    return RunIdentification(
        run=run.name, frequency=run.frequency, current_amplitude=im, field_amplitude=hm,
        flux_density_amplitude=bm, flux_density_stderr=se_b, flux_density_source=source,
        mu_imag=mu, mu_imag_stderr=se_mu, mu_imag_fit_stderr=se_fit,
        mu_imag_flux_sensitivity=dmu_db,
        mu_imag_at_bound=at_bound, scan_upper=upper, mu_real=point.mu_real,
        lag=lag_angle(point.mu_real, mu), rms_residual=float(np.sqrt(np.mean(r * r))),
        offset=offset, samples=int(n), discarded_time=model.discarded)


# -- the loss coefficients ----------------------------------------------------------------


def _loss_terms(n_exp, f, bm, hm, volume):
    """mu'' per unit K_h, K_e, K_ex (eq 16 through eqs 7, 9, 11 and 14), arrays."""
    mu = gmt_losses.imaginary_permeability
    return (mu(gmt_losses.hysteresis_loss(1.0, n_exp, bm, f, volume), hm, f, volume),
            mu(gmt_losses.eddy_current_loss(1.0, bm, f, volume), hm, f, volume),
            mu(gmt_losses.excess_loss(1.0, bm, f, volume), hm, f, volume))


def fit_losses(runs, params: gmt.TransducerParameters | None = None) -> LossFit | None:
    """K_h, n, K_e, K_ex from per-run (f, B_m, H_m, mu'' +- se), the set of eqs 16.

    Parameters
    ----------
    runs : sequence of RunIdentification
    params : TransducerParameters, optional
        Only the rod volume is used (it cancels in eq 16).

    Returns
    -------
    LossFit or None
        None with fewer than four runs.
    """
    params = params or gmt.TransducerParameters()
    runs = list(runs)
    if len(runs) < 4:
        return None
    v = params.rod_volume
    f = np.array([r.frequency for r in runs])
    bm = np.array([r.flux_density_amplitude for r in runs])
    hm = np.array([r.field_amplitude for r in runs])
    mu = np.array([r.mu_imag for r in runs])
    se = np.array([r.mu_imag_stderr for r in runs])
    se_fit = np.array([r.mu_imag_fit_stderr for r in runs])
    se_b = np.array([r.flux_density_stderr for r in runs])
    dmu_db = np.array([r.mu_imag_flux_sensitivity for r in runs])
    floor = 1e-12 * np.maximum(np.abs(mu), 1e-12)
    weight = 1.0 / np.maximum(se, floor)

    def linear(n_exp):
        a = np.column_stack(_loss_terms(n_exp, f, bm, hm, v)) * weight[:, None]
        coef, *_ = np.linalg.lstsq(a, mu * weight, rcond=None)
        r = a @ coef - mu * weight
        return coef, float(r @ r)

    ns = np.linspace(STEINMETZ_RANGE[0], STEINMETZ_RANGE[1], 201)
    best = min(ns, key=lambda n_exp: linear(n_exp)[1])
    k_lin, _ = linear(best)
    x0 = np.array([k_lin[0], best, k_lin[1], k_lin[2]])

    def resid(x):
        th, tn, te, tx = x
        ph, pe, px = _loss_terms(tn, f, bm, hm, v)
        return (th * ph + te * pe + tx * px - mu) * weight

    def jacobian(x):
        th, tn, te, tx = x
        ph, pe, px = _loss_terms(tn, f, bm, hm, v)
        return np.column_stack([ph, th * ph * np.log(bm), pe, px]) * weight[:, None]

    lo = [-np.inf, STEINMETZ_RANGE[0], -np.inf, -np.inf]
    hi = [np.inf, STEINMETZ_RANGE[1], np.inf, np.inf]
    x0[1] = min(max(x0[1], lo[1] + 1e-9), hi[1] - 1e-9)
    x = x0
    for _ in range(3):
        sol = least_squares(resid, x, jac=jacobian, bounds=(lo, hi), x_scale="jac",
                            xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        x = sol.x
        # B_m's error moves both the measured mu'' (by d mu''/d B_m of the loop fit)
        # and eq 16's prediction (by d g/d B_m): effective variance of the residual
        th, tn, te, tx = x
        ph, pe, px = _loss_terms(tn, f, bm, hm, v)
        dg_db = (tn * th * ph + 2.0 * te * pe + 1.5 * tx * px) / bm
        eff = np.sqrt(se_fit ** 2 + ((dmu_db - dg_db) * se_b) ** 2)
        new_weight = 1.0 / np.maximum(eff, floor)
        if np.allclose(new_weight, weight, rtol=1e-6, atol=0.0):
            break
        weight[:] = new_weight
    r = resid(x)
    dof = len(runs) - 4
    note = ""
    stderrs = corr = None
    rv = float(r @ r) / dof if dof > 0 else None
    if x[1] <= lo[1] + 1e-6 or x[1] >= hi[1] - 1e-6:
        note = (f"n = {x[1]:g} is on the bound of the accepted range {STEINMETZ_RANGE} "
                "(gmt.parameters.STEINMETZ_RANGE); ")
    if dof <= 0:
        note += (f"uncertainty not determined: {len(runs)} runs for 4 coefficients "
                 f"(needs at least {MIN_RUNS_FOR_UNCERTAINTY})")
    else:
        jm = jacobian(x)
        norms = np.linalg.norm(jm, axis=0)
        if np.any(norms == 0):
            note += "uncertainty not determined: a coefficient does not affect the data"
        else:
            js = jm / norms
            sv = np.linalg.svd(js, compute_uv=False)
            if sv[-1] < 1e-12 * sv[0]:
                note += ("uncertainty not determined: the runs do not separate the four "
                         "coefficients (vary both frequency and amplitude)")
            else:
                cov = np.linalg.inv(js.T @ js) / np.outer(norms, norms) * rv
                sd = np.sqrt(np.diag(cov))
                stderrs = tuple(float(s) for s in sd)
                c = cov / np.outer(sd, sd)
                corr = tuple(tuple(float(v_) for v_ in row) for row in c)
    values = tuple(float(v_) for v_ in x)
    flags = physical_flags(values, stderrs, rv, dof)
    if flags:
        note = (note.strip().rstrip(";") + "; " if note.strip() else "") + (
            "not a physical result (" + "; ".join(flags) + "): the paper's loss law does not "
            "describe these runs; run smeha diagnose on the same file to see what the paper's "
            "model misses")
    return LossFit(values=values, stderrs=stderrs, correlation=corr, runs=len(runs),
                   residual_variance=rv, note=note.strip().rstrip(";"), flags=flags)


#: Probability of a residual variance above the flag's limit when the per-run errors are
#: right (the chi^2 distribution's upper tail, :func:`physical_flags`).
RESIDUAL_VARIANCE_TAIL = 1e-3


def physical_flags(values, stderrs, residual_variance, dof) -> tuple:
    """Why loss coefficients make no physical sense, as short texts (empty if they do).

    * a negative K_h, K_e or K_ex: each is a loss per cycle (eqs 7, 9, 11), never
      negative;
    * a standard uncertainty larger than the value: the runs do not determine it;
    * a residual variance (chi^2/dof of the weighted fit) beyond the upper
      :data:`RESIDUAL_VARIANCE_TAIL` quantile of chi^2/dof: the mu'' of the runs
      scatter about eq 16 far beyond their standard errors, so the law (or the
      model that gave each mu'') does not hold.
    """
    from scipy.stats import chi2

    flags = []
    names = [n for n, _, _ in LOSS_COEFFICIENTS]
    for k in (0, 2, 3):
        if values[k] < 0.0:
            flags.append(f"{names[k]} = {values[k]:.4g} < 0, and a loss coefficient cannot "
                         "be negative")
    if stderrs is not None:
        for name, v, e in zip(names, values, stderrs):
            if e > abs(v):
                flags.append(f"{name} = {v:.4g} +- {e:.3g}, not determined (the uncertainty "
                             "exceeds the value)")
    if residual_variance is not None and dof > 0:
        limit = float(chi2.isf(RESIDUAL_VARIANCE_TAIL, dof)) / dof
        if residual_variance > limit:
            flags.append(f"residual variance {residual_variance:.3g} where the per-run errors "
                         f"allow at most {limit:.2g}")
    return tuple(flags)


def identify(runs, params: gmt.TransducerParameters | None = None, **kwargs) -> Identification:
    """Identify every run (:func:`identify_run`) and the loss coefficients (:func:`fit_losses`).

    Parameters
    ----------
    runs : sequence of Run
    params : TransducerParameters, optional
        Default Table 2 (its loss coefficients are not used).
    **kwargs
        Passed to :func:`identify_run`.

    Returns
    -------
    Identification

    Raises
    ------
    DataError
        Implausible magnitudes (:func:`smeha.plausibility.check_plausible`).
    """
    from .plausibility import check_plausible

    params = params or gmt.TransducerParameters()
    runs = list(runs)
    check_plausible(runs, params)  # a column in the wrong unit, before any fit
    results = tuple(identify_run(r, params, **kwargs) for r in runs)
    fit = fit_losses(results, params)
    note = ""
    if fit is None:
        note = (f"loss coefficients not determined: {len(results)} run(s); the four "
                "coefficients of eq 16 need at least 4 runs (and 5 for their uncertainties)")
    bounded = [r.run for r in results if r.mu_imag_at_bound]
    if bounded:
        note = (note + "; " if note else "") + (
            "mu'' on a bound of the scan for run(s) " + ", ".join(map(repr, bounded)))
    return Identification(runs=results, loss_fit=fit, note=note)


# -- report -------------------------------------------------------------------------------


def _pm(value, err, digits=4):
    if err is None or not math.isfinite(err):
        return f"{value:.{digits}g}"
    return f"{value:.{digits}g} +- {err:.2g}"


def format_identification(ident: Identification, path: str = "") -> str:
    """Plain-text report: a table per run and the loss coefficients."""
    lines = []
    if path:
        lines.append(f"identification from {path} ({len(ident.runs)} runs)")
    head = (f"{'run':<14} {'f [Hz]':>8} {'I_m [A]':>8} {'B_m [T]':>9} {'B_m source':<14} "
            f"{'mu_imag':>20} {'mu_real':>8} {'lag [deg]':>9} {'RMS [um]':>9}")
    lines += [head, "-" * len(head)]
    short = {"sense_voltage": "sense voltage", "displacement": "displacement"}
    for r in ident.runs:
        mark = "*" if r.mu_imag_at_bound else ""
        lines.append(
            f"{r.run:<14.14} {r.frequency:>8.4g} {r.current_amplitude:>8.4f} "
            f"{r.flux_density_amplitude:>9.5f} {short[r.flux_density_source]:<14} "
            f"{_pm(r.mu_imag, r.mu_imag_stderr, 6) + mark:>20} {r.mu_real:>8.4f} "
            f"{math.degrees(r.lag):>9.2f} {r.rms_residual * 1e6:>9.4f}")
    lines.append("B_m: sense voltage = eq 22; displacement = fundamental of y (eqs 19, 25, 29)")
    lines.append("")
    fit = ident.loss_fit
    if fit is None:
        lines.append(ident.note)
        return "\n".join(lines)
    rv = "" if fit.residual_variance is None else \
        f", residual variance {fit.residual_variance:.3g}"
    lines.append(f"loss coefficients (set of eqs 16, weighted least squares over "
                 f"{fit.runs} runs{rv}):")
    for k, (name, _, unit) in enumerate(LOSS_COEFFICIENTS):
        err = None if fit.stderrs is None else fit.stderrs[k]
        lines.append(f"  {name:<5} = {_pm(fit.values[k], err, 6):<26} [{unit}]")
    if fit.correlation is not None:
        lines.append("correlation:")
        lines.append("        " + "".join(f"{n:>8}" for n in fit.names))
        for name, row in zip(fit.names, fit.correlation):
            lines.append(f"  {name:<5} " + "".join(f"{v:>8.3f}" for v in row))
    if fit.flags:
        lines.append("these coefficients make no physical sense:")
        lines += [f"  - {flag}" for flag in fit.flags]
        where = f" {path}" if path else ""
        lines.append(f"the paper's model does not describe these runs; run `smeha diagnose"
                     f"{where}` to see what it misses")
    elif fit.note or ident.note:
        lines.append("note: " + "; ".join(x for x in (fit.note, ident.note) if x))
    return "\n".join(lines)
