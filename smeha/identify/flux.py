"""Step 1 of identification: B_m of a run, from the sense voltage or the displacement.

The harmonic least-squares fits here also give the current's fundamental, to which
the loop fit (:mod:`smeha.identify.loop`) refers the model.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

import gmt
from gmt.constants import MU_0
from gmt.extensions.steady import mechanics_response
from gmt.forward import strain_harmonics
from gmt.sensing import flux_density_amplitude_from_voltage

from ..measured import Run, harmonic_basis

__all__ = ["HARMONICS", "SOURCES", "flux_density_from_sense_voltage", "current_phasor",
           "flux_density_from_displacement"]

#: Harmonics (besides the offset) in the least-squares fits of a fundamental.
HARMONICS = 3
#: Where B_m came from (:attr:`RunIdentification.flux_density_source`), as the reports name it.
SOURCES = {"sense_voltage": "sense voltage (eq 22)",
           "displacement": "displacement fundamental (eqs 19, 25, 29)"}


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


def current_phasor(time, current, frequency):
    """The current's fundamental a cos(w t) + b sin(w t) as a - j b, [A] (least squares)."""
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
    i1 = current_phasor(t, run.current[mask], run.frequency)
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
