"""Does the drift of y go with time (heating) or with the drive's cycles?

A thermal drift follows the heat the coil has put in: over a record much shorter than the
thermal time constant (seconds to minutes for a coil on a rod) the rod's temperature, and
with it the offset and gain of y, change at a rate set by the Joule loss, ~ I_m^2 per
second, whatever the drive's frequency (:mod:`gmt.extensions.drift`). A change that goes
with the drive's cycles (a hysteresis population settling from its first cycles, or any
accommodation of the magnetic state) changes y by an amount per period: per second it
grows with the frequency. The two are told apart on the drift features alone (each run's
slope of y's mean and of its fundamental, with their standard deviations,
:class:`smeha.diagnose.candidates.Batch`), by weighted least squares of each law:

* per second: d<y>/dt = a I^2 + c and dY_1/dt = (g I^2 + h) Y_1;
* per cycle: the same, times the drive frequency f.

The constants c, h stand for a start away from the equilibrium (a rod that starts warm).
Each law has four unknowns, so their chi^2 compare directly (Schwarz's criterion with
equal parameter counts). Measured on the outside lab files with Preisach hysteresis (A and
C): the gain of y fell by 2e-4 per period at 1 A from 5 to 50 Hz (-0.001 per second at
5 Hz, -0.010 at 50 Hz), a per-cycle law; on labsim's coil heating (tau_th 30 s) the rates
do not grow with f.
"""
from __future__ import annotations

import numpy as np

__all__ = ["law_chi2", "goes_with_time"]


def _wls(design, target, sd):
    """chi^2 of the weighted least-squares fit of ``target`` by the columns of ``design``."""
    a = design / sd[:, None]
    b = target / sd
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)
    r = b - a @ coef
    return float(r @ r)


def law_chi2(batch, per_cycle: bool) -> float:
    """chi^2 of the drift features of ``batch`` under the per-second law or, with
    ``per_cycle``, the per-cycle law (module docstring); SI units inside."""
    i2 = batch.current_amplitude ** 2
    scale = batch.frequency if per_cycle else np.ones_like(batch.frequency)
    offset = _wls(np.column_stack((i2 * scale, scale)), batch.drift, batch.drift_sd)
    y1 = batch.y[:, 0]
    # dY_1/dt = (g I^2 + h) s Y_1 with real g, h: real and imaginary parts stacked
    cols = (i2 * scale * y1, scale * y1)
    design = np.column_stack([np.concatenate((c.real, c.imag)) for c in cols])
    target = np.concatenate((batch.y1_slope.real, batch.y1_slope.imag))
    sd = np.concatenate((batch.y1_slope_sd, batch.y1_slope_sd))
    return offset + _wls(design, target, sd)


def goes_with_time(batch, margin: float) -> bool:
    """True when the per-second law describes the drift features of ``batch`` better than
    the per-cycle law by more than ``margin`` in chi^2 (both have four unknowns), in units
    of the per-second law's dispersion (chi^2 per degree of freedom, at least 1), as
    :func:`smeha.diagnose.rules.no_channel_worse` scales its margin.

    Where neither law describes the drift terms (a Preisach population's scatter) the
    difference between them is not a law, and the margin is read in units of that
    scatter; a coil heating is described per second many times better (pinned by
    tests/test_driftlaw.py::test_labsim_coil_heating_goes_with_time and
    ::test_labsim_preisach_leaves_no_drift)."""
    per_second = law_chi2(batch, per_cycle=False)
    dof = max(3 * len(batch.frequency) - 4, 1)
    scale = max(1.0, per_second / dof)
    return law_chi2(batch, per_cycle=True) - per_second > margin * scale
