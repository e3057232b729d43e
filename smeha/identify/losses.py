"""Step 3 of identification: the loss coefficients across runs, the set of eqs 16.

Weighted nonlinear least squares started from a variable-projection scan over n,
the weights refined for B_m's error (errors-in-variables); and the flags that say
when the coefficients are not a physical result (:mod:`smeha.identify`, step 3).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

import gmt
from gmt import losses as gmt_losses
from gmt.parameters import STEINMETZ_RANGE

from .flags import loss_law_flags
from .results import LOSS_COEFFICIENTS, LossFit

__all__ = ["MIN_RUNS_FOR_UNCERTAINTY", "RESIDUAL_VARIANCE_TAIL", "MIN_RUNS_FOR_EXTENSION",
           "MIN_FREQUENCY_SPAN", "fit_losses", "physical_flags", "fit_extended_losses"]

#: Fewest runs for the loss-coefficient uncertainties (4 parameters + 1 dof).
MIN_RUNS_FOR_UNCERTAINTY = 5
#: Fewest runs for the extended loss law (its 9 parameters + 1 dof).
MIN_RUNS_FOR_EXTENSION = 10
#: Smallest ratio of the highest to the lowest frequency for the extended law: its rate
#: exponent shows only in how the loss per cycle grows with frequency.
MIN_FREQUENCY_SPAN = 10.0
#: Probability of a residual variance above the flag's limit when the per-run errors are
#: right (the chi^2 distribution's upper tail, :func:`physical_flags`).
RESIDUAL_VARIANCE_TAIL = 1e-3


def _loss_terms(n_exp, f, bm, hm, volume):
    """mu'' per unit K_h, K_e, K_ex (eq 16 through eqs 7, 9, 11 and 14), arrays."""
    mu = gmt_losses.imaginary_permeability
    return (mu(gmt_losses.hysteresis_loss(1.0, n_exp, bm, f, volume), hm, f, volume),
            mu(gmt_losses.eddy_current_loss(1.0, bm, f, volume), hm, f, volume),
            mu(gmt_losses.excess_loss(1.0, bm, f, volume), hm, f, volume))



class _LossProblem:
    """The set of eqs 16 over the runs: weighted residuals in mu'' and their Jacobian.

    The weights start at 1/stderr(mu'') and are refined by :meth:`effective_weights`
    for B_m's error (:mod:`smeha.identify`, step 3).
    """

    def __init__(self, runs, volume):
        self.volume = volume
        self.f = np.array([r.frequency for r in runs])
        self.bm = np.array([r.flux_density_amplitude for r in runs])
        self.hm = np.array([r.field_amplitude for r in runs])
        self.mu = np.array([r.mu_imag for r in runs])
        se = np.array([r.mu_imag_stderr for r in runs])
        self.se_fit = np.array([r.mu_imag_fit_stderr for r in runs])
        self.se_b = np.array([r.flux_density_stderr for r in runs])
        self.dmu_db = np.array([r.mu_imag_flux_sensitivity for r in runs])
        self.floor = 1e-12 * np.maximum(np.abs(self.mu), 1e-12)
        self.weight = 1.0 / np.maximum(se, self.floor)

    def terms(self, n_exp):
        """mu'' per unit K_h, K_e, K_ex of every run for the exponent ``n_exp``."""
        return _loss_terms(n_exp, self.f, self.bm, self.hm, self.volume)

    def start(self):
        """(K_h, n, K_e, K_ex) of the variable-projection scan over n (linear in the rest)."""
        weight, mu = self.weight, self.mu

        def linear(n_exp):
            a = np.column_stack(self.terms(n_exp)) * weight[:, None]
            coef, *_ = np.linalg.lstsq(a, mu * weight, rcond=None)
            r = a @ coef - mu * weight
            return coef, float(r @ r)

        ns = np.linspace(STEINMETZ_RANGE[0], STEINMETZ_RANGE[1], 201)
        best = min(ns, key=lambda n_exp: linear(n_exp)[1])
        k_lin, _ = linear(best)
        return np.array([k_lin[0], best, k_lin[1], k_lin[2]])

    def residuals(self, x):
        """Eq 16's mu'' minus the measured one, weighted, for x = (K_h, n, K_e, K_ex)."""
        th, tn, te, tx = x
        ph, pe, px = self.terms(tn)
        return (th * ph + te * pe + tx * px - self.mu) * self.weight

    def jacobian(self, x):
        """d :meth:`residuals` / d x."""
        th, tn, te, tx = x
        ph, pe, px = self.terms(tn)
        return np.column_stack([ph, th * ph * np.log(self.bm), pe, px]) * self.weight[:, None]

    def effective_weights(self, x):
        """1 / the residuals' standard errors with B_m's error counted at ``x``.

        B_m's error moves both the measured mu'' (by d mu''/d B_m of the loop fit)
        and eq 16's prediction (by d g/d B_m): effective variance of the residual.
        """
        th, tn, te, tx = x
        ph, pe, px = self.terms(tn)
        dg_db = (tn * th * ph + 2.0 * te * pe + 1.5 * tx * px) / self.bm
        eff = np.sqrt(self.se_fit ** 2 + ((self.dmu_db - dg_db) * self.se_b) ** 2)
        return 1.0 / np.maximum(eff, self.floor)


def _weighted_fit(problem: _LossProblem):
    """(K_h, n, K_e, K_ex) by weighted least squares, n within STEINMETZ_RANGE; the
    weights refined for B_m's error until they settle (three fits at most)."""
    lo = [-np.inf, STEINMETZ_RANGE[0], -np.inf, -np.inf]
    hi = [np.inf, STEINMETZ_RANGE[1], np.inf, np.inf]
    x = problem.start()
    x[1] = min(max(x[1], lo[1] + 1e-9), hi[1] - 1e-9)
    for _ in range(3):
        sol = least_squares(problem.residuals, x, jac=problem.jacobian, bounds=(lo, hi),
                            x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        x = sol.x
        new_weight = problem.effective_weights(x)
        if np.allclose(new_weight, problem.weight, rtol=1e-6, atol=0.0):
            break
        problem.weight[:] = new_weight
    return x


def _uncertainties(jacobian, residual_variance):
    """Standard uncertainties and correlation matrix of the four coefficients, and "";
    or None, None and why they are not determined.

    The covariance is (J^T J)^-1 (columns scaled to unit norm for the inversion)
    times the residual variance.
    """
    norms = np.linalg.norm(jacobian, axis=0)
    if np.any(norms == 0):
        return None, None, "uncertainty not determined: a coefficient does not affect the data"
    js = jacobian / norms
    sv = np.linalg.svd(js, compute_uv=False)
    if sv[-1] < 1e-12 * sv[0]:
        return None, None, ("uncertainty not determined: the runs do not separate the four "
                            "coefficients (vary both frequency and amplitude)")
    cov = np.linalg.inv(js.T @ js) / np.outer(norms, norms) * residual_variance
    sd = np.sqrt(np.diag(cov))
    c = cov / np.outer(sd, sd)
    return (tuple(float(s) for s in sd), tuple(tuple(float(v_) for v_ in row) for row in c),
            "")


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
    problem = _LossProblem(runs, params.rod_volume)
    x = _weighted_fit(problem)
    r = problem.residuals(x)
    dof = len(runs) - 4
    note = ""
    stderrs = corr = None
    rv = float(r @ r) / dof if dof > 0 else None
    if x[1] <= STEINMETZ_RANGE[0] + 1e-6 or x[1] >= STEINMETZ_RANGE[1] - 1e-6:
        note = (f"n = {x[1]:g} is on the bound of the accepted range {STEINMETZ_RANGE} "
                "(gmt.parameters.STEINMETZ_RANGE); ")
    if dof <= 0:
        note += (f"uncertainty not determined: {len(runs)} runs for 4 coefficients "
                 f"(needs at least {MIN_RUNS_FOR_UNCERTAINTY})")
    else:
        stderrs, corr, why = _uncertainties(problem.jacobian(x), rv)
        note += why
    values = tuple(float(v_) for v_ in x)
    flags = physical_flags(values, stderrs, rv, dof) + loss_law_flags(
        values, runs, params.rod_volume, _loss_terms)
    if flags:
        note = (note.strip().rstrip(";") + "; " if note.strip() else "") + (
            "not a physical result (" + "; ".join(flags) + "): the paper's loss law does not "
            "describe these runs; run smeha diagnose on the same file to see what the paper's "
            "model misses")
    return LossFit(values=values, stderrs=stderrs, correlation=corr, runs=len(runs),
                   residual_variance=rv, note=note.strip().rstrip(";"), flags=flags)


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


def fit_extended_losses(runs):
    """The extended loss law (:mod:`gmt.timedomain.dynamic`) from sinusoidal runs, if possible.

    Each run's loss density P/V = pi f mu_0 mu'' H_m^2 (eq 13) at its f and B_m is a
    sinusoidal row of :func:`smeha.coreloss.models.fit_extended`. Sinusoids alone
    determine the law's rate exponent only through the growth of the loss per cycle
    with frequency (docs/LOSSES.md), so the fit needs :data:`MIN_RUNS_FOR_EXTENSION`
    runs over a frequency span of :data:`MIN_FREQUENCY_SPAN` at least and two
    amplitudes.

    Returns
    -------
    (ExtendedLaw or None, str)
        The law, or None with the reason.
    """
    from ..coreloss.measurements import WAVEFORMS, CoreLossData
    from ..coreloss.models import fit_extended, fit_separation

    runs = [r for r in runs if r.mu_imag > 0.0 and r.flux_density_amplitude > 0.0]
    f = np.array([r.frequency for r in runs])
    bm = np.array([r.flux_density_amplitude for r in runs])
    if len(runs) < MIN_RUNS_FOR_EXTENSION:
        return None, (f"extended loss law not fitted: {len(runs)} run(s) with a positive mu'', "
                      f"it needs {MIN_RUNS_FOR_EXTENSION}")
    if f.max() < MIN_FREQUENCY_SPAN * f.min() or len(np.unique(np.round(bm, 6))) < 2:
        return None, (f"extended loss law not fitted: the runs span {f.min():g}-{f.max():g} Hz "
                      f"and {len(np.unique(np.round(bm, 6)))} amplitude(s); it needs a "
                      f"frequency ratio of {MIN_FREQUENCY_SPAN:g} and two amplitudes")
    n = len(runs)
    data = CoreLossData("runs", f, bm, np.full(n, WAVEFORMS.index("sine")), -np.ones((n, 4)),
                        np.zeros((n, 4)), np.zeros((n, 4)),
                        np.array([r.loss_density for r in runs]))
    return fit_extended(data, fit_separation(data)), ""
