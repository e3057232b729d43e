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

4. **The extended loss law** (:mod:`gmt.timedomain.dynamic`, docs/LOSSES.md) from the
   runs' loss densities, when they are enough for it
   (:func:`~smeha.identify.losses.fit_extended_losses`).

Modules: :mod:`~smeha.identify.flux` (step 1), :mod:`~smeha.identify.loop` (step 2),
:mod:`~smeha.identify.losses` (step 3), :mod:`~smeha.identify.results` (what they give),
:mod:`~smeha.identify.report` (the text); :func:`identify` runs the three steps.

SI inside; the physics is :mod:`gmt`'s.
"""
from __future__ import annotations

import gmt

from .flux import (HARMONICS, SOURCES, flux_density_from_displacement,
                   flux_density_from_sense_voltage)
from .loop import SCAN_POINTS, SCAN_RANGE, identify_run
from .losses import (MIN_RUNS_FOR_UNCERTAINTY, RESIDUAL_VARIANCE_TAIL, fit_extended_losses,
                     fit_losses, physical_flags)
from .report import format_identification
from .results import LOSS_COEFFICIENTS, Identification, LossFit, RunIdentification

__all__ = [
    "HARMONICS", "SOURCES", "SCAN_POINTS", "SCAN_RANGE", "LOSS_COEFFICIENTS",
    "MIN_RUNS_FOR_UNCERTAINTY", "RESIDUAL_VARIANCE_TAIL", "RunIdentification", "LossFit",
    "Identification", "flux_density_from_sense_voltage", "flux_density_from_displacement",
    "identify_run", "fit_losses", "fit_extended_losses", "physical_flags", "identify",
    "format_identification",
]


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
    from ..plausibility import check_plausible

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
    law, why = fit_extended_losses(results)
    return Identification(runs=results, loss_fit=fit, note=note,
                          extended_law=None if law is None else law.as_dict(), extended_note=why)
