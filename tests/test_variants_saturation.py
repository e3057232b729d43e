"""The anhysteretic law of ``magnetization_saturation`` (gmt.extensions.saturation).

References: the closed forms of the textbook laws, written here apart from the module's
tabulated inverse (tanh; Froehlich-Kennelly u / (1 + |u|); Langevin coth x - 1/x;
Brillouin B_J, Kittel, *Introduction to Solid State Physics*, ch. 11; arctangent).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

import gmt
from gmt.extensions.saturation import (EXPONENT_RANGE, RicherSaturationForm, SaturationForm,
                                       SoftSaturation, anhysteretic)

U = np.linspace(-6.0, 6.0, 241)


def _coth(x):
    return 1.0 / np.tanh(x)


def _brillouin_unit_slope(j, u):
    """B_J of the field scaled to slope 1 at 0 (its slope there is (J + 1) / 3J)."""
    x = np.where(u == 0, 1e-9, u) * 3.0 * j / (j + 1.0)
    c1, c2 = (2 * j + 1) / (2 * j), 1 / (2 * j)
    return c1 * _coth(c1 * x) - c2 * _coth(c2 * x)


#: name -> the law with slope 1 at 0, as a function of u
TEXTBOOK = {
    "langevin": lambda u: _brillouin_unit_slope(1e6, u),  # J -> inf: L(3u)
    "brillouin_1": lambda u: _brillouin_unit_slope(1.0, u),
    "brillouin_7/2": lambda u: _brillouin_unit_slope(3.5, u),
    "arctangent": lambda u: 2.0 / np.pi * np.arctan(0.5 * np.pi * u),
}


def test_tanh_and_froehlich_kennelly_are_members():
    # eq (1) with p = 2, q = 1 integrates to tanh; p = 1, q = 2 to u / (1 + |u|); the
    # table's Simpson steps hold them to 1e-8 of M_s
    assert np.max(np.abs(anhysteretic(U, 2.0, 1.0) - np.tanh(U))) < 1e-8
    assert np.max(np.abs(anhysteretic(U, 1.0, 2.0) - U / (1.0 + np.abs(U)))) < 1e-8


@pytest.mark.parametrize("name", sorted(TEXTBOOK))
def test_other_textbook_laws_are_near_a_member(name):
    # the nearest member over the whole curve (u in (0, 4], where each law is past 90 % of
    # saturation) stays within 0.4 % of M_s; Brillouin J = 1/2 is tanh, the first test
    u = np.linspace(0.02, 4.0, 120)
    target = TEXTBOOK[name](u)
    fit = least_squares(lambda x: anhysteretic(u, *x) - target, (2.0, 1.5),
                        bounds=EXPONENT_RANGE)
    assert np.max(np.abs(fit.fun)) < 4e-3


LOW, HIGH = EXPONENT_RANGE


@pytest.mark.parametrize("p, q", [(LOW, LOW), (LOW, HIGH), (HIGH, LOW), (HIGH, HIGH),
                                  (2.0, 0.5), (1.0, 1.0)])
def test_every_member_is_odd_monotone_and_bounded(p, q):
    s = anhysteretic(U, p, q)
    assert np.allclose(anhysteretic(-U, p, q), -s, atol=1e-12)
    assert np.all(np.diff(s) >= -1e-12) and np.all(np.abs(s) <= 1.0)
    # and it obeys eq (1), dS/du = (1 - |S|^p)^q (central differences of step 1e-5, whose
    # error is of order 1e-10 times the third derivative, far below the tolerance)
    # short of full saturation (q < 1 reaches it at a finite u, a kink)
    u, h = np.linspace(0.05, 2.0, 9), 1e-5
    u = u[anhysteretic(u + h, p, q) < 1.0 - 1e-3]
    slope = (anhysteretic(u + h, p, q) - anhysteretic(u - h, p, q)) / (2 * h)
    assert np.allclose(slope, (1.0 - anhysteretic(u, p, q) ** p) ** q, rtol=1e-4, atol=1e-9)


def test_a_tail_exponent_below_one_saturates_at_a_finite_field():
    # dS/du = (1 - S^2)^(1/2) is the sine law S = sin u up to u = pi/2, then 1
    u = np.linspace(0.0, 3.0, 31)
    assert np.allclose(anhysteretic(u, 2.0, 0.5), np.where(u < np.pi / 2, np.sin(u), 1.0),
                       atol=1e-6)


def test_the_law_reduces_to_the_paper_and_keeps_the_bias_on_its_curve():
    m = np.linspace(-3e4, 3e4, 7)
    assert np.allclose(SoftSaturation(1e12, 250e3, 1.0, 1.3, 2.5).magnetization(m), m,
                       atol=1e-6 * 3e4)
    # with an initial slope k the total is M_s S(k (M_b + M) / M_s): for tanh the slope
    # at the bias is k sech^2(k M_b / M_s)
    s = SoftSaturation(400e3, 250e3, 1.2)
    slope = (s.magnetization(1.0) - s.magnetization(-1.0)) / 2
    assert slope == pytest.approx(1.2 / math.cosh(1.2 * 250e3 / 400e3) ** 2, rel=1e-6)


@pytest.mark.parametrize("field, value", [("knee_exponent", 0.1), ("tail_exponent", 9.0),
                                          ("initial_slope", 12.0), ("bias_shift", 0.5),
                                          ("shoulder", -1.0)])
def test_a_law_outside_its_ranges_is_refused_naming_the_parameter(field, value):
    kwargs = {"saturation_magnetization": 4e5, "bias_magnetization": 2.5e5, field: value}
    with pytest.raises(gmt.ParameterError, match=f"{field} = {value:g}"):
        SoftSaturation(**kwargs)


def test_a_law_tangent_to_the_paper_at_the_bias_is_a_member():
    # the paper's linear M as the small-signal model about the bias: the tanh law through
    # the bias u_b, tanh(u_b) = M_b / M_s, scaled so that its slope there is the paper's,
    # M_tot = M_s tanh(u_b + M / (M_s sech^2 u_b)) (closed form, written here), is eq (1)'s
    # p = 2, q = 1 with k = cosh^2 u_b and d = u_b - k M_b / M_s
    ms, mb = 450e3, 250e3
    ub = math.atanh(mb / ms)
    k = math.cosh(ub) ** 2
    law = SoftSaturation(ms, mb, k, 2.0, 1.0, 0.0, ub - k * mb / ms)
    m = np.linspace(-1.5e5, 1.5e5, 31)
    closed = ms * np.tanh(ub + m / (ms / math.cosh(ub) ** 2)) - mb
    assert np.max(np.abs(law.magnetization(m) - closed)) < 1e-8 * ms
    # its slope at the bias is the paper's: 1
    assert (law.magnetization(1.0) - law.magnetization(-1.0)) / 2 == pytest.approx(1.0,
                                                                                   rel=1e-6)


def test_the_richer_form_holds_the_law_and_starts_from_it():
    # c = 0 is eq (1): the richer form's start from a fit is the same law
    x = (0.4, 1.05, 1.8, 1.2, -0.1)
    ctx = {"params": gmt.TransducerParameters()}
    assert SaturationForm.finer is RicherSaturationForm
    start = SaturationForm.finer_start(x)
    assert RicherSaturationForm.from_fit(start, ctx) == dict(
        SaturationForm.from_fit(x, ctx), shoulder=0.0)
    params = gmt.TransducerParameters()
    m = np.linspace(-5e4, 5e4, 11)
    assert np.allclose(RicherSaturationForm.law(RicherSaturationForm.from_fit(start, ctx),
                                                params).magnetization(m),
                       SaturationForm.law(SaturationForm.from_fit(x, ctx),
                                          params).magnetization(m))
