"""Step 2 of identification: mu'' of each run from its loop, eq 30 (:mod:`smeha.identify`)."""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

import gmt
from gmt.extensions.steady import mechanics_response
from gmt.forward import strain_harmonics
from gmt.permeability import amplitude_permeability, lag_angle

from ..measured import DataError, Run
from .flux import (SOURCES, current_phasor, flux_density_from_displacement,
                   flux_density_from_sense_voltage)
from .results import RunIdentification

__all__ = ["SCAN_RANGE", "SCAN_POINTS", "identify_run"]

#: The paper's scan range of mu'' ("varying its value from 0 to 10").
SCAN_RANGE = (0.0, 10.0)
#: Points of the scan over SCAN_RANGE (the paper does not say; 0.2 apart).
SCAN_POINTS = 51
#: The loop is fitted in micrometres: sums of squares of order 1.
_SCALE = 1e6


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
    continuous mechanics (:mod:`smeha.identify`, step 2): y = y_0 + Re(Y_1 e^{j theta})
    + Re(Y_2 e^{2 j theta}), theta = w t + phi, at the run's own sample times.
    """

    def __init__(self, run: Run, params, transient_cycles: float):
        self.run, self.params = run, params
        t = run.time
        span = t[-1] - t[0]
        i1 = current_phasor(t, run.current, run.frequency)
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



def _flux_density(run: Run, params, mask):
    """B_m [T], its standard error [T] and its source (:mod:`smeha.identify`, step 1)."""
    if run.sense_voltage is not None:
        bm, se_b = flux_density_from_sense_voltage(run, params)
        source = "sense_voltage"
    else:
        bm, se_b, _, _ = flux_density_from_displacement(run, params, mask)
        source = "displacement"
    if not (bm > 0 and math.isfinite(bm)):
        raise DataError(f"{run.where()}: B_m = {bm:g} T from the {SOURCES[source]} is not "
                        "positive", run.source, run.name)
    return bm, se_b, source


def _difference(fn, x, h, lo=-math.inf, hi=math.inf):
    """Central difference quotient of ``fn`` at ``x``, one-sided where a bound cuts it."""
    a, b = max(x - h, lo), min(x + h, hi)
    return (fn(b) - fn(a)) / (b - a)


def _best_mu(model: _LoopModel, bm, lower, upper, scan_points):
    """mu'' minimising the sum of squares of the loop (:mod:`smeha.identify`, step 2).

    The scan over [lower, upper] brackets the minimum, a bounded Brent search refines
    it and one Gauss-Newton step polishes it. Returns mu'', the sum of squares
    [um^2], the residual [um] and d(model)/d mu'' [um] there, and the latter's
    squared norm.
    """
    def sse(mu):
        r, _ = model.residual(bm, mu)
        return float(((r * _SCALE) @ (r * _SCALE)))

    grid = np.linspace(lower, upper, scan_points)
    values = np.array([sse(mu) for mu in grid])
    k = int(np.argmin(values))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(sse, bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-12 * max(upper, 1.0), "maxiter": 200})
    mu, s_min = float(res.x), float(res.fun)
    h_mu = 1e-6 * max(mu, 1e-3)
    j_mu = _difference(lambda m: -model.residual(bm, m)[0] * _SCALE, mu, h_mu, lower, upper)
    jj = float(j_mu @ j_mu)
    r0 = model.residual(bm, mu)[0] * _SCALE
    if jj > 0:  # one Gauss-Newton step from the Brent minimum
        cand = min(max(mu + float(j_mu @ r0) / jj, lower), upper)
        r1 = model.residual(bm, cand)[0] * _SCALE
        if float(r1 @ r1) < s_min:
            mu, s_min, r0 = cand, float(r1 @ r1), r1
    return mu, s_min, r0, j_mu, jj


def identify_run(run: Run, params: gmt.TransducerParameters | None = None, *,
                 scan=SCAN_RANGE, scan_points: int = SCAN_POINTS,
                 transient_cycles: float = 1.0) -> RunIdentification:
    """B_m and mu'' of one run (:mod:`smeha.identify`, steps 1-2).

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
    bm, se_b, source = _flux_density(run, params, model.mask)
    mod = amplitude_permeability(bm, hm)
    upper = min(scan[1], mod * (1.0 - 1e-9))
    lower = max(scan[0], 0.0)
    if not upper > lower:
        raise DataError(f"{run.where()}: |mu| = B_m/(mu_0 H_m) = {mod:.4g} leaves no room for "
                        f"mu'' in [{lower:g}, {scan[1]:g}] (eq 20)", run.source, run.name)
    mu, s_min, r0, j_mu, jj = _best_mu(model, bm, lower, upper, scan_points)
    n = r0.size
    sigma2 = s_min / max(n - 2, 1)  # mu'' and the offset
    se_fit = math.sqrt(sigma2 / jj) if jj > 0 else math.inf
    # B_m's uncertainty through the fit's sensitivity d mu''/d B_m = -(J_mu . J_B)/(J_mu . J_mu)
    h_b = 1e-6 * bm
    j_b = _difference(lambda b: -model.residual(b, mu)[0] * _SCALE, bm, h_b)
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
