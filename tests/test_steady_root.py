"""The paper's part of the permeability beside a magnetisation-stage extension: its root.

:func:`gmt.extensions.paperpart.paper_permeability` solves |mu_p(a) + p| = |B_1| / (mu_0 H_m)
for a = |mu_p|, mu'' from eq 16 and mu' from eq 20. Near the point where eq 16's mu''
reaches |mu_p| (the cap) mu' collapses and a second, spurious root appears. The
reference here is a brute-force scan of the same equation, eq 16 written out in this
file, on a fine grid of a (no iteration), and the case is one where a secant from the
closed form stalls by the cap: labsim's Preisach density with saturation, 200 Hz at 1 A (loss
coefficients of that fit, the adder p the density gave there). Each case is solved twice:
with the adder as a function of M_1 (the secant and regula falsi of a saturation's stage)
and as the constant an operator of H gives (``constant``, Newton's method;
gmt.extensions.steady.stage_adder).
"""
import math

import numpy as np
import pytest

import gmt
from gmt.constants import MU_0
from gmt.extensions.paperpart import LOSS_ANGLE_CAP, paper_permeability, uncapped_limit

LOSS = (135421.88, 1.9105760, 4004.9444, 7.4208)
FREQ = 200.0
HM = gmt.TransducerParameters().field_per_ampere * 1.0
MODULUS = 3.0549556
P = 1.132 - 0.242j


def _mu_imag(a, loss=LOSS, f=FREQ, hm=HM):
    """mu'' of eq 16 written out here (not gmt's): pi f mu_0 mu'' H_m^2 = K_h B_m^n f +
    K_e (B_m f)^2 + K_ex (B_m f)^1.5 at B_m = mu_0 |mu| H_m."""
    kh, n, ke, kex = loss
    bm = MU_0 * a * hm
    return (kh * bm ** n * f + ke * (bm * f) ** 2 + kex * (bm * f) ** 1.5) / (
        math.pi * f * MU_0 * hm * hm)


def _mu(a):
    mu_i = np.minimum(_mu_imag(a), LOSS_ANGLE_CAP * a)
    return np.sqrt(a * a - mu_i * mu_i) - 1j * mu_i


def _roots_by_scan(p):
    """Every sign change of |mu(a) + p| - modulus on 2e5 points of a in (0, 3 modulus)."""
    a = np.linspace(1e-4, 3.0 * MODULUS, 200_001)
    e = np.abs(_mu(a) + p) - MODULUS
    idx = np.flatnonzero(np.sign(e[1:]) != np.sign(e[:-1]))
    return a[idx]


def _adder(p, kind):
    """p as the magnetisation stage gives it: a function of M_1, or a constant."""
    if kind == "function":
        return lambda m1: p + 0.0 * m1

    def constant(m1):
        return p
    constant.constant = p
    return constant


KINDS = ("function", "constant")


def test_the_case_has_a_trap_by_the_cap():
    # the premise: the scan's root lies well below the cap, and just below the cap
    # |mu + p| - modulus comes back to within 0.2 % of zero, where an iteration from the
    # closed form (a = modulus, above the cap) stalled
    cap = float(uncapped_limit(LOSS, FREQ, HM))
    assert _roots_by_scan(P)[0] < 0.9 * cap
    a = np.linspace(0.97 * cap, cap, 2001)
    assert np.min(np.abs(np.abs(_mu(a) + P) - MODULUS)) < 0.002 * MODULUS


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("t", np.linspace(0.9, 1.1, 21))
def test_least_root_is_taken(t, kind):
    # the adder as a function of M_1 (constant here, as the density's is); tolerance: the
    # scan's grid step, 4.6e-5 in a. A secant from the closed form stalls by the cap on half
    # of these p (0.9-1.1 times the case's), |mu_p| 2.55 for 2.12
    p = t * P
    mu = paper_permeability(LOSS, FREQ, HM, MODULUS, adder=_adder(p, kind))
    assert abs(mu) == pytest.approx(_roots_by_scan(p)[0], abs=5e-5)
    assert abs(abs(mu + p) - MODULUS) < 1e-10


@pytest.mark.parametrize("kind", KINDS)
def test_no_root_below_the_cap(kind):
    # p = 0: the closed form |mu_p| = modulus (eqs 16, 20), here above the cap
    mu = paper_permeability(LOSS, FREQ, HM, MODULUS, adder=_adder(0.0, kind))
    assert abs(mu) == pytest.approx(MODULUS, rel=1e-12)
    assert MODULUS > float(uncapped_limit(LOSS, FREQ, HM))


def test_uncapped_limit_is_where_mu_imag_reaches_the_cap():
    cap = float(uncapped_limit(LOSS, FREQ, HM))
    ratio = _mu_imag(cap) / cap
    assert ratio == pytest.approx(LOSS_ANGLE_CAP, rel=1e-9)
    # without losses the cap is never reached
    assert math.isinf(float(uncapped_limit((0.0, 1.5, 0.0, 0.0), FREQ, HM)))


@pytest.mark.parametrize("kind", KINDS)
def test_arrays_of_runs(kind):
    # one run with the adder, one without losses: each its own root
    loss = LOSS
    f = np.array([FREQ, 50.0])
    hm = np.array([HM, 0.6 * HM])
    modulus = np.array([MODULUS, 4.0])
    p = np.array([P, 0.5])
    mu = paper_permeability(loss, f, hm, modulus, adder=_adder(p, kind))
    assert np.allclose(np.abs(mu + p), modulus, rtol=1e-12)
    assert abs(mu[0]) == pytest.approx(_roots_by_scan(P)[0], abs=5e-5)


@pytest.mark.parametrize("inner", [None, "constant"])
def test_the_vacuum_share_adds_to_a_constant_adder(inner):
    # the unshielded vacuum field per H_m adds to p (an eddy form's vacuum_share): the
    # root with p + vacuum given as a function of M_1 is the same (iterations' tolerance)
    vacuum = 0.05 - 0.01j
    adder = None if inner is None else _adder(P, inner)
    mu = paper_permeability(LOSS, FREQ, HM, MODULUS, adder=adder, vacuum=vacuum)
    p = vacuum + (0.0 if inner is None else P)
    ref = paper_permeability(LOSS, FREQ, HM, MODULUS, adder=_adder(p, "function"))
    assert mu == pytest.approx(ref, rel=1e-10)
    assert abs(abs(mu + p) - MODULUS) < 1e-10


@pytest.mark.parametrize("kind", KINDS)
def test_a_runs_root_does_not_depend_on_the_runs_solved_with_it(kind):
    # the diagnosis evaluates a point and its finite-difference steps as one batch
    # (smeha.diagnose.differences): each run's root must be the one it has solved alone,
    # bit for bit (the iterations hold a run once it has converged). The batch mixes the
    # case by the cap (scanned for its least root), runs stepped by 1.5e-8 in the loss
    # coefficients (converging at other iterations) and a run without losses
    steps = [1.0, 1.0 + 1.5e-8, 1.0 - 3e-8, 1.0 + 1e-3]
    loss = tuple(np.array([v * s for s in steps] + [0.0 if k != 1 else 1.5])
                 for k, v in enumerate(LOSS))
    f = np.array([FREQ] * 4 + [50.0])
    hm = np.array([HM] * 4 + [0.6 * HM])
    modulus = np.array([MODULUS] * 4 + [4.0])
    p = np.array([P, 1.05 * P, 0.95 * P, P, 0.5])
    together = paper_permeability(loss, f, hm, modulus, adder=_adder(p, kind))
    for j in range(f.size):
        alone = paper_permeability(tuple(v[j:j + 1] for v in loss), f[j:j + 1], hm[j:j + 1],
                                   modulus[j:j + 1], adder=_adder(p[j:j + 1], kind))
        assert together[j] == alone[0]
