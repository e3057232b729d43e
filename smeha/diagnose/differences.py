"""Forward-difference Jacobians whose columns are evaluated together.

Every fit of the diagnosis linearises its residuals in the base unknowns (eq 16's loss
coefficients and the strain scale s: :mod:`smeha.diagnose.fit`) and in the candidate's
own by forward differences, one evaluation of the model per column. An evaluation's
cost is set by its number of numpy operations, not by its number of runs (the runs are
the rows of every array: :class:`smeha.diagnose.candidates.Batch`), and the base
unknowns enter the model as numbers per run (eq 16's coefficients, the strain scale):
so the point and its steps in the base unknowns are evaluated as one batch of the runs
stacked once per step (:meth:`smeha.diagnose.candidates.Evaluator.residuals_stacked`).
On labsim's Preisach density with eddy diffusion (10 training runs), one evaluation of
the paper's model took 0.091 ms and the same for 8 copies of the runs 0.107 ms; the
density's 1.24 ms and 1.57 ms. The candidate's own unknowns change its extensions'
parameters: stacked too where the form takes them per run (the hysteresis operators'
``stack_values``), one evaluation each otherwise.

The columns are those of the steps given (each column's difference over its step), so
the Jacobian is the one the fit's own rule of steps gives, evaluated in fewer calls:
:func:`scipy_steps` is the rule of :func:`scipy.optimize.least_squares`'s default
('2-point', its steps taken into the bounds), :func:`relative_steps` the rule of the
linearisations of :mod:`smeha.diagnose.linearfit` and of the predictive chi^2.
"""
from __future__ import annotations

import numpy as np

__all__ = ["scipy_steps", "relative_steps", "jacobian"]


def scipy_steps(z, lower, upper) -> np.ndarray:
    """Steps of :func:`scipy.optimize.approx_derivative`'s '2-point' scheme (scipy 1.11 to
    1.17, undocumented but stable): sqrt(machine epsilon) times max(1, |z|), signed as z
    (+ at 0), reversed where the step would leave the bounds and the reverse fits, else
    the larger distance to a bound; each step as represented, (z + h) - z."""
    z = np.asarray(z, float)
    lower = np.asarray(lower, float)
    upper = np.asarray(upper, float)
    sign = np.where(z >= 0.0, 1.0, -1.0)
    h = np.sqrt(np.finfo(float).eps) * sign * np.maximum(1.0, np.abs(z))
    x = z + h
    below, above = z - lower, upper - z
    violated = (x < lower) | (x > upper)
    fitting = np.abs(h) <= np.maximum(below, above)
    h = np.where(violated & fitting, -h, h)
    h = np.where(~fitting & (above >= below), above, h)
    h = np.where(~fitting & (above < below), -below, h)
    return (z + h) - z


def relative_steps(z, upper) -> np.ndarray:
    """Steps 1e-6 max(|z|, 1e-3), reversed where the step would pass ``upper``."""
    z = np.asarray(z, float)
    h = 1e-6 * np.maximum(np.abs(z), 1e-3)
    return np.where(z + h > np.asarray(upper, float), -h, h)


def jacobian(stacked, z, steps, columns=None, r0=None) -> tuple:
    """(J, r(z)): d r / d z by forward differences over ``steps``.

    ``stacked(zs)`` gives the residuals of several vectors, one row each, in as few
    evaluations as their differences allow (:meth:`smeha.diagnose.candidates.Evaluator.
    residuals_stacked`). ``columns``: the indices of the columns wanted (default all; the
    others are zero). ``r0``: r(z) where the caller has it, else evaluated with the steps.
    """
    z = np.asarray(z, float)
    steps = np.asarray(steps, float)
    wanted = np.arange(z.size) if columns is None else np.asarray(columns, int)
    points = [] if r0 is not None else [z]
    for j in wanted:
        zj = z.copy()
        zj[j] += steps[j]
        points.append(zj)
    rows = stacked(points) if points else np.zeros((0, 0))
    if r0 is None:
        r0, rows = rows[0], rows[1:]
    r0 = np.asarray(r0, float)
    # built by columns and returned transposed (Fortran order), as scipy's differences
    # are: the trust-region solver's products then round as they do with scipy's own
    columns_first = np.zeros((z.size, r0.size))
    for k, j in enumerate(wanted):
        columns_first[j] = (rows[k] - r0) / steps[j]
    return columns_first.T, r0
