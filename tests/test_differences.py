"""The diagnosis' finite differences with the base columns evaluated together.

:mod:`smeha.diagnose.differences` claims the Jacobian scipy's least squares would take by
its own forward differences ('2-point'), evaluated in fewer calls. The reference is scipy
itself, :func:`scipy.optimize.least_squares` with ``jac="2-point"``: the Jacobian it
returns when stopped at its first evaluation, and its iterates, on functions written here.
The model's side of the claim, that the runs stacked once per base vector give each
vector's residuals as one evaluation of it would, is checked on labsim data (an
implementation apart from the candidates), bit for bit: a difference of one rounding in
a residual is 1e-8 of a derivative over a step of 1.5e-8.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

import gmt
from labsim_runs import runs as labsim_runs
from smeha.diagnose import differences
from smeha.diagnose.candidates import Batch, Candidate, Evaluator, candidates

def _model(z):
    """A smooth vector function of 5 unknowns, 12 residuals (an exponential fit's)."""
    t = np.linspace(0.0, 2.0, 12)
    return z[0] * np.exp(-z[1] * t) + z[2] * np.sin(z[3] * t) + z[4] ** 2 * t - np.cos(t)


def _stacked(points):
    return np.array([_model(p) for p in points])


BOUNDS = (np.array([0.0, -1.0, -np.inf, 0.5, 1.0]), np.array([5.0, 1.0, np.inf, 0.5 + 1e-9, 9.0]))


@pytest.mark.parametrize("z", [
    [1.0, 0.2, -3.0, 0.5 + 5e-10, 2.0],    # one unknown in a range narrower than its step
    [5.0 - 1e-12, 1.0 - 1e-9, 0.0, 0.5, 9.0 - 1e-10],  # on and by upper bounds
    [0.0, -1.0, 1e6, 0.5 + 1e-9, 1.0],     # on lower bounds, a large value
])
def test_the_steps_and_columns_are_scipys(z):
    # scipy's Jacobian at its start (moved strictly inside the bounds by least_squares)
    ref = least_squares(_model, np.array(z), bounds=BOUNDS, max_nfev=1)
    steps = differences.scipy_steps(ref.x, *BOUNDS)
    jac, r0 = differences.jacobian(_stacked, ref.x, steps)
    np.testing.assert_array_equal(jac, ref.jac)
    np.testing.assert_array_equal(r0, _model(ref.x))


def test_least_squares_takes_the_same_path_as_with_its_own_differences():
    # the Jacobian is handed over in scipy's memory order (its columns contiguous): the
    # trust-region solver's products round as with its own, and the iterates agree to
    # the bit (with the columns in C order they parted at the second step on the
    # diagnosis' fits)
    t = np.linspace(0.0, 3.0, 40)
    data = 2.0 * np.exp(-0.7 * t) + 0.3 * np.sin(2.1 * t) + 0.01 * np.cos(17.0 * t)

    def fun(z):
        return z[0] * np.exp(-z[1] * t) + z[2] * np.sin(z[3] * t) - data

    lo, hi = np.array([0.0, 0.0, -1.0, 1.0]), np.array([5.0, 3.0, 1.0, 4.0])

    def jac(z):
        return differences.jacobian(lambda ps: np.array([fun(p) for p in ps]), z,
                                    differences.scipy_steps(z, lo, hi))[0]

    z0 = np.array([1.0, 1e-12, 0.5, 3.0])
    for max_nfev in (2, 5, 50):
        ours = least_squares(fun, z0, jac=jac, bounds=(lo, hi), x_scale="jac",
                             max_nfev=max_nfev, xtol=1e-12, ftol=1e-12)
        theirs = least_squares(fun, z0, bounds=(lo, hi), x_scale="jac", max_nfev=max_nfev,
                               xtol=1e-12, ftol=1e-12)
        np.testing.assert_array_equal(ours.x, theirs.x)


def test_relative_steps_and_chosen_columns():
    # the rule of the linearisations in smeha.diagnose.linearfit and fit.predictive_chi2,
    # written out here: 1e-6 max(|z|, 1e-3), backwards where it would pass the upper bound
    z = np.array([2.0, 0.0, -3.0, 0.5, 1.0])
    upper = np.array([np.inf, np.inf, np.inf, 0.5, np.inf])
    steps = differences.relative_steps(z, upper)
    np.testing.assert_array_equal(steps, [2e-6, 1e-9, 3e-6, -5e-7, 1e-6])
    r0 = _model(z)
    jac, _ = differences.jacobian(_stacked, z, steps, columns=[0, 3],
                                  r0=r0)
    for j in range(z.size):
        if j in (0, 3):
            zj = z.copy()
            zj[j] += steps[j]
            np.testing.assert_array_equal(jac[:, j], (_model(zj) - r0) / steps[j])
        else:
            assert not jac[:, j].any()


@pytest.fixture(scope="module")
def labsim_batch():
    """Ten runs of labsim's Preisach hysteresis with coil heating, 100 samples a period,
    three of them without a sense voltage, as the diagnosis' features."""
    from smeha.diagnose.workflow import _usable_features

    params = gmt.TransducerParameters()
    data = labsim_runs({"rate_independent_hysteresis": 1.0, "thermal_drift": 1.0}, seed=4,
                       noise_um=0.05, samples_per_cycle=100,
                       formulations={"rate_independent_hysteresis": "preisach_random"})
    for r in data[:3]:
        r.sense_voltage = None
    feats, _ = _usable_features(data, params)
    rfs = list(feats.values())[:10]
    hmax = max(params.field_per_ampere * rf.current_amplitude for rf in rfs)
    return Evaluator(params, hmax), Batch(rfs)


@pytest.mark.parametrize("label", ["paper", "rate_independent_hysteresis (preisach)",
                                   "rate_independent_hysteresis (play_operators)",
                                   "eddy_current_diffusion (cylinder_magnetization)",
                                   "thermal_drift", "mechanical_resonance (two_dof)",
                                   "magnetization_saturation"])
def test_each_stacked_copy_is_its_own_evaluation(labsim_batch, label):
    # the points of a Jacobian: the base stepped in each unknown, the candidate's unknowns
    # stepped each (per run where the form takes them so: the hysteresis operators), and a
    # point far off
    ev, batch = labsim_batch
    assert not batch.has_b.all() and batch.has_b.any()
    cand = {c.label: c for c in candidates()}[label]
    x = cand.starts()[1 if len(cand.starts()) > 1 else 0]
    if label.endswith("(preisach)"):  # a density with weights (its starts have none)
        x = tuple(x[:2]) + tuple(4e3 if k % 3 == 0 else v for k, v in enumerate(x[2:]))
    base = (9.6e4, 1.84, 2.0e4, 2.0, 1.05)  # losses where the root is scanned for
    points = [(base, x)]
    points += [(tuple(v * (1.0 + 1.5e-8 * (i == j)) for i, v in enumerate(base)), x)
               for j in range(5)]
    points += [(base, tuple(v + 1e-7 * (i == j) for i, v in enumerate(x)))
               for j in range(min(len(x), 5))]
    points += [((1.2e5, 2.1, 1.0e3, 0.0, 0.9), x)]
    rows = ev.residuals_stacked(batch, points, cand)
    assert rows.shape[0] == len(points)
    for (b, xx), row in zip(points, rows):
        np.testing.assert_array_equal(row, ev.residuals(batch, b, cand, xx))


def test_a_combination_stacked(labsim_batch):
    # the density's rate factor stepped (per run) beside a drift stepped (evaluated apart)
    ev, batch = labsim_batch
    forms = {c.label: c.members[0] for c in candidates()[1:]}
    cand = Candidate((forms["rate_independent_hysteresis (preisach)"],
                      forms["thermal_drift"]))
    x = np.array(cand.starts()[0], float)
    x[2::4] = 3e3
    base = (9.6e4, 1.84, 3.6e3, 2.0, 1.05)
    points = [(base, tuple(x))]
    for j in (0, 1, x.size - 3):
        xj = x.copy()
        xj[j] += 1e-7
        points.append((base, tuple(xj)))
    for (b, xx), row in zip(points, ev.residuals_stacked(batch, points, cand)):
        np.testing.assert_array_equal(row, ev.residuals(batch, b, cand, xx))


def test_stacked_batches_are_kept_within_their_bound(labsim_batch):
    # Batch.stacked: one copy is the batch itself; the last STACKS_KEPT sizes made are kept
    batch = Batch(labsim_batch[1].runs)  # its own, nothing stacked yet
    assert batch.stacked(1) is batch
    first = batch.stacked(2)
    assert batch.stacked(2) is first
    np.testing.assert_array_equal(first.y, np.vstack((batch.y, batch.y)))
    for copies in range(3, 3 + Batch.STACKS_KEPT):
        batch.stacked(copies)
    assert len(batch._stacks) == Batch.STACKS_KEPT and 2 not in batch._stacks


def test_a_density_combination_on_its_upper_bounds_has_a_covariance(labsim_batch):
    # every step of a Jacobian stays within the unknowns' bounds (the rule of
    # relative_steps), the covariance's too: the saturation law's exponents on their upper
    # bound 4 beside the Preisach density, where a fit of labsim's hysteresis with
    # mean-field saturation ended, made a law outside its range one step up, the fit
    # failed and the combination was lost
    from smeha.diagnose import linearfit

    ev, batch = labsim_batch
    forms = {c.label: c.members[0] for c in candidates()[1:]}
    cand = Candidate((forms["rate_independent_hysteresis (preisach)"],
                      forms["magnetization_saturation"]))
    lin = linearfit.linear_member(cand)
    prob = linearfit._Problem(ev, batch, cand, lin)
    x = np.array(cand.starts()[0], float)
    x[prob.other_idx] = np.minimum(np.asarray(cand.upper, float)[prob.other_idx], 1e4)
    # M_b/M_s, slope, knee, tail, bias shift: the exponents on their upper bounds
    x[prob.other_idx[-5:]] = (0.5, 2.0, 4.0, 4.0, 0.0)
    w = np.where(np.arange(prob.lin_idx.size) % 3 == 0, 4e3, 0.0)
    other = x[prob.other_idx]
    base = (9.6e4, 1.84, 2.0e4, 2.0, 1.05)
    r0 = prob.residuals(base, w, other)
    cov = linearfit._covariance(ev, batch, cand, prob, base, w, other,
                                prob.jacobian(base, w, other, r0), 1.0)
    assert np.all(np.isfinite(cov))


def test_a_fit_that_fails_is_kept_with_its_label(monkeypatch):
    # a diagnosis goes on without a candidate or combination it cannot fit and reports
    # each one (smeha.diagnose.workflow: "not fitted, left out"), its label first
    from smeha.diagnose import fit

    cand = candidates()[1]

    def failing(*args, **kwargs):
        raise ValueError("tail_exponent = 4.000001 - is outside the allowed range [0.5, 4]")

    monkeypatch.setattr(fit, "fit_and_score", failing)
    with fit.unfitted_kept() as kept:
        out = fit.fit_all(None, None, None, [(cand, (1.0,), None)] * 2, workers=1)
    assert out == [f"{cand.label}: tail_exponent = 4.000001 - is outside the allowed range "
                   "[0.5, 4]"] * 2
    assert kept == out[:1]  # each reason once
    assert fit.fit_all(None, None, None, [(cand, (1.0,), None)], workers=1) == out[:1]
