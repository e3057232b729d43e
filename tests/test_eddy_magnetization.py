"""Eddy diffusion acting on the magnetisation, the coil seeing unshielded vacuum flux
(gmt.extensions.diffusion.MagnetizationDiffusionForm).

References: Stoll, *The Analysis of Eddy Currents*, 1974 (the slab's tanh(q)/q and the
rod's 2 I_1(q)/(q I_0(q))); Table 2 of the paper (A_c = 380 mm^2 of the sensing coil
against the rod's 79 mm^2: the coil links air flux no eddy current in the rod shields).
"""
from __future__ import annotations

import numpy as np
import pytest

import gmt
from gmt import extensions as ext
from gmt.extensions.steady import steady_state

P = gmt.TransducerParameters()
LOSS = (P.hysteresis_coefficient, P.steinmetz_exponent, P.eddy_coefficient,
        P.excess_coefficient)
F = np.array([20.0, 100.0, 200.0])
IM = np.array([1.0, 1.0, 0.6])
BM = np.array([0.08, 0.055, 0.02])


def run(cls, values):
    return steady_state(P, F, IM, BM, LOSS, [(cls, values)])


@pytest.mark.parametrize("geometry", ["slab", "cylinder"])
def test_no_unshielded_share_is_the_field_diffusion_form(geometry):
    field = ext.lookup("eddy_current_diffusion", geometry)
    magn = ext.lookup("eddy_current_diffusion", f"{geometry}_magnetization")
    a = run(field, {"time_constant_s": 1e-3})
    b = run(magn, {"time_constant_s": 1e-3, "unshielded_share": 0.0})
    assert np.allclose(a.displacement, b.displacement, rtol=1e-10, atol=0)
    assert np.allclose(a.flux_density, b.flux_density, rtol=1e-10, atol=0)


@pytest.mark.parametrize("geometry", ["slab", "cylinder"])
def test_the_unshielded_share_keeps_b_m_and_is_seen_in_b(geometry):
    # the coil's |B_1| is the measured B_m whatever kappa (eq 22); kappa moves B's phase
    # (the unshielded vacuum flux does not lag), so the sense voltage identifies it
    magn = ext.lookup("eddy_current_diffusion", f"{geometry}_magnetization")
    phases = []
    for kappa in (0.0, 1.0):
        r = run(magn, {"time_constant_s": 2e-3, "unshielded_share": kappa})
        assert np.allclose(np.abs(r.flux_density[:, 0]), BM, rtol=1e-9)
        phases.append(np.angle(r.flux_density[:, 0]))
    assert np.all(np.abs(phases[1] - phases[0]) > 1e-3)  # rad: beyond a sense coil's noise


def test_vanishing_time_constant_is_the_paper_model():
    magn = ext.lookup("eddy_current_diffusion", "slab_magnetization")
    a = steady_state(P, F, IM, BM, LOSS)
    b = run(magn, {"time_constant_s": 0.0, "unshielded_share": 0.7})
    assert np.allclose(a.displacement, b.displacement, rtol=1e-12, atol=0)
    assert np.allclose(a.flux_density, b.flux_density, rtol=1e-12, atol=0)
