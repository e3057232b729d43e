"""The paper's model plus extensions in periodic steady state, by harmonic balance.

For i = I_m cos(theta), theta = w t, the model of eq 30 is periodic once its
transient has died, and each harmonic of the displacement follows from the
force's harmonic through eq 27 exactly:

    Y_k = F_k G(j k w),   G(s) = 1 / (m s^2 + c s + K)   (eqs 27, 29),

the **continuous** system the paper describes, whatever the sampling of the
data it is compared with. (:func:`steady_state` with ``step`` gives instead
the steady state of the ZOH-sampled model at that step, G_d(e^{j k w h}),
which is what :class:`gmt.variants.ExtendedStepper` reaches; the tests use it
to compare the time-stepped forms with the periodic ones at the same step.)

The stages (:data:`gmt.extensions.STAGES`):

1. **field**: the paper's part of the magnetisation: its complex
   permeability (mu'' of eq 16 from the loss coefficients, mu' of eq 20) at
   the flux density that makes the total's |B_1| the run's measured B_m
   (:func:`gmt.extensions.paperpart.paper_permeability`; the measured B_m itself when nothing else
   changes the fundamental), M_1 = (mu - 1) H_m (eq 5), B_1 = mu_0 mu H_m
   (eq 4). While M is that sinusoid the force of eqs 25 and 28,
   A_r E^H K_lambda (M_b + M)^2, has F_1 = 2 c M_b M_1 and F_2 = c M_1^2 / 2
   (c = A_r E^H K_lambda). An eddy-current extension replaces this stage (the
   field inside the rod lags the applied field).
2. **magnetisation**: hysteresis adds its output to M (switching on the field
   the field stage passes on, :func:`switching_gain`), saturation maps M
   through its law; the whole change r(theta) of M over one period (its
   fundamental too) is added to M and mu_0 r to B, and the force gains
   c (2 (M_b + M) r + r^2), all sampled over one period on :data:`GRID` points
   (exact for the quadratic force up to harmonic GRID/2 of r). The sensing
   coil measures the total, which is why the paper's part is solved for in
   step 1 (the paper's model then describes the magnetisation it was built
   for, and the extension what it adds).
3. **strain**: the thermal drift is not periodic; the diagnosis applies it to
   the samples (:class:`gmt.extensions.drift.DriftForm`).
4. **mechanics**: eq 27's G, or an extension's.
5. **sensor**: a factor on each harmonic of y (the delay).

B = mu_0 (H + M) (eq 4).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..constants import MU_0
from ..mechanics import zoh_closed_form
from ._base import FieldState, Steady
from .paperpart import paper_permeability

#: Points per period on which the magnetisation stage samples M.
GRID = 128
#: Harmonics of y and B the evaluation returns by default.
HARMONICS = 8


class SteadyResult(NamedTuple):
    """Harmonics k = 1..K of y [m] and B [T], phasors referred to the current's phase."""

    displacement: np.ndarray
    flux_density: np.ndarray


def force_gain(params):
    """c = A_r E^H K_lambda, force per unit magnetisation squared, [N m^2/A^2] (eqs 25, 28)."""
    return params.rod_area * params.youngs_modulus * params.magnetostriction_coefficient


def complex_permeability(steady: Steady, adder=None):
    """mu' - j mu'' of the paper's part at the run's B_m (eqs 16, 20), [-]."""
    hm = steady.field_amplitude
    return paper_permeability(steady.loss, steady.frequency, hm,
                              steady.flux_density_amplitude / (MU_0 * hm), adder=adder)


def paper_field(steady: Steady, adder=None) -> FieldState:
    """The paper's field stage (module docstring, step 1): its part of M, B and the force."""
    mu = complex_permeability(steady, adder)
    hm = steady.field_amplitude
    m1 = (mu - 1.0) * hm
    c = force_gain(steady.params)
    return FieldState(m1, MU_0 * mu * hm, 2.0 * c * steady.params.bias_magnetization * m1,
                      0.5 * c * m1 * m1)


def magnetization_stage(magnetic, steady: Steady, paper_magnetization, theta, memo=None):
    """(M of the paper's part, M after the magnetisation stage) over one period, [A/m].

    ``paper_magnetization`` is the paper part's fundamental M_1 per run; the
    extensions of ``magnetic`` act on it in order (hysteresis, then saturation),
    each through its periodic form (:meth:`gmt.extensions.Extension.steady_output`).
    ``memo`` (a dict) keeps what an extension computes independently of M
    between calls on the same runs.
    """
    m = np.real(np.asarray(paper_magnetization)[..., None] * np.exp(1j * theta))
    out = m
    for k, (cls, values) in enumerate(magnetic):
        out = cls.steady_output(values, steady, out, theta,
                                None if memo is None else memo.setdefault(k, {}))
    return m, out


def switching_gain(components, angular_frequency):
    """The field the magnetisation stage's hysteresis switches on, per applied field at
    the fundamental: the field stage's :meth:`gmt.extensions.Extension.switching_gain`,
    1 without one, [-] (arrays of runs)."""
    w = np.asarray(angular_frequency, dtype=float)
    for cls, values in components:
        if cls.stage == "field":
            return np.asarray(cls.switching_gain(values, w), dtype=complex) * np.ones_like(w)
    return np.ones_like(w, dtype=complex)


def stage_adder(magnetic, steady: Steady):
    """p(M_1): the fundamental the magnetisation stage adds per unit H_m, for
    :func:`paper_permeability` (None without a magnetisation-stage extension)."""
    if not magnetic:
        return None
    theta = 2.0 * np.pi * np.arange(GRID) / GRID
    memo = {}
    if all(getattr(cls, "additive", False) for cls, _ in magnetic):
        # outputs that do not depend on M (an operator of H): p is one constant per run
        m0 = np.zeros(np.shape(steady.field_amplitude), complex)
        m, out = magnetization_stage(magnetic, steady, m0, theta, memo)
        p = 2.0 * np.fft.rfft(out - m, axis=-1)[..., 1] / GRID / steady.field_amplitude

        def constant(m1):
            return p
        constant.memo = memo
        # p itself, for paper_permeability's Newton iteration
        constant.constant = p
        return constant

    def adder(m1):
        m, out = magnetization_stage(magnetic, steady, m1, theta, memo)
        c1 = 2.0 * np.fft.rfft(out - m, axis=-1)[..., 1] / GRID
        return c1 / steady.field_amplitude
    adder.memo = memo
    return adder


def mechanics_response(mass, damping, stiffness, angular_frequencies, step=None):
    """Displacement per newton of eq 27, G(j w), or the ZOH-sampled G_d(e^{j w h}), [m/N].

    Continuous: G = 1 / (K - m w^2 + j c w) (eq 29). Sampled (``step`` = h, the
    force held over each step): [1 0] (z I - A_d)^-1 B_d at z = e^{j w h} with
    the exact ZOH matrices (:func:`gmt.mechanics.zoh_closed_form`), y the state
    at the start of the step.

    Examples
    --------
    >>> g = mechanics_response(0.02, 2945.0, 1.963e7, [0.0])
    >>> bool(np.isclose(g[0].real, 1 / 1.963e7))
    True
    """
    w = np.atleast_1d(np.asarray(angular_frequencies, dtype=float))
    if step is None:
        return 1.0 / (stiffness - mass * w * w + 1j * damping * w)
    a11, a12, a21, a22, b1, b2 = zoh_closed_form(mass, damping, stiffness, step)
    z = np.exp(1j * w * step)
    det = (z - a11) * (z - a22) - a12 * a21
    return ((z - a22) * b1 + a12 * b2) / det


def _ordered(components):
    from . import STAGES

    return sorted(components, key=lambda cv: STAGES.index(cv[0].stage))


def _magnetization_change(params, st, magnetic, magnetization, memo, k):
    """Harmonics ``k`` of the magnetisation stage's change r of M, [A/m], and of the
    force's change A_r E^H K_lambda (2 (M_b + M) r + r^2) (eqs 25, 28), [N]."""
    theta = 2.0 * np.pi * np.arange(GRID) / GRID
    m_paper, m_total = magnetization_stage(magnetic, st, magnetization, theta, memo)
    r = m_total - m_paper
    c = force_gain(params)
    extra = c * (2.0 * (params.bias_magnetization + m_paper) * r + r * r)
    scale = 2.0 / GRID
    rk = np.fft.rfft(r, axis=-1)[:, k] * scale
    return rk, np.fft.rfft(extra, axis=-1)[:, k] * scale


def _force_to_displacement(params, components, angular_frequencies, step):
    """The path from the force to the measured y at ``angular_frequencies``: the
    mechanics' response [m/N] (a mechanics extension's, else eq 29's) and the sensor
    stage's factor [-] (1 without one)."""
    g = None
    sensor = np.ones_like(angular_frequencies, dtype=complex)
    for cls, values in components:
        if cls.stage == "mechanics":
            g = cls.steady_mechanics(values, params, angular_frequencies, step)
        elif cls.stage == "sensor":
            sensor = sensor * cls.steady_sensor(values, angular_frequencies)
    if g is None:
        g = mechanics_response(params.mass, params.damping, params.stiffness,
                               angular_frequencies, step)
    return g, sensor


def steady_state(params, frequency, current_amplitude, flux_density_amplitude, loss,
                 components=(), harmonics=HARMONICS, step=None) -> SteadyResult:
    """Harmonics of y and B of the paper's model plus ``components`` (module docstring).

    Parameters
    ----------
    params : TransducerParameters
    frequency : float or array
        f, [Hz]; an array evaluates several runs at once (one row each).
    current_amplitude : float or array
        I_m of i = I_m cos(w t), [A].
    flux_density_amplitude : float or array
        B_m the sensing coil measures, [T] (eq 22).
    loss : tuple
        (K_h, n, K_e, K_ex) of eq 16.
    components : sequence of (Extension subclass, dict)
        The extensions and their SI parameters (at most one per stage, except
        the magnetisation stage).
    harmonics : int
        K.
    step : float, optional
        None: the continuous model. h [s]: the steady state of the ZOH-sampled
        model at that step.

    Returns
    -------
    SteadyResult
        Arrays of shape (K,) for scalar inputs, (runs, K) for arrays.
    """
    scalar = np.ndim(frequency) == 0
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    im = np.broadcast_to(np.asarray(current_amplitude, dtype=float), f.shape)
    bm = np.broadcast_to(np.asarray(flux_density_amplitude, dtype=float), f.shape)
    w = 2.0 * math.pi * f
    hm = params.field_per_ampere * im
    comps = _ordered(components)
    st = Steady(params, f, w, im, hm, bm, tuple(loss), step, switching_gain(comps, w))
    magnetic = [(cls, v) for cls, v in comps if cls.stage == "magnetization"]
    adder = stage_adder(magnetic, st)
    k = np.arange(1, harmonics + 1)
    wk = np.outer(w, k)
    field = None
    for cls, values in comps:
        if cls.stage == "field":
            field = cls.steady_field(values, st, adder)
    if field is None:
        field = paper_field(st, adder)
    fk = np.zeros((f.size, harmonics), complex)
    mk = np.zeros((f.size, harmonics), complex)
    bk = np.zeros((f.size, harmonics), complex)
    fk[:, 0] = field.force_first
    if harmonics > 1:
        fk[:, 1] = field.force_second
    mk[:, 0] = field.magnetization
    bk[:, 0] = field.flux_density
    if magnetic:  # the stage adds its whole change r of M: to M, B and the force
        rk, extra_k = _magnetization_change(params, st, magnetic, field.magnetization,
                                            adder.memo, k)
        mk = mk + rk
        bk = bk + MU_0 * rk
        fk = fk + extra_k
    g, sensor = _force_to_displacement(params, comps, wk, step)
    y = fk * g * sensor
    b = bk
    if scalar:
        return SteadyResult(y[0], b[0])
    return SteadyResult(y, b)


def flux_density_from_ratio(params, frequency, current_amplitude, magnetization_ratio,
                            components=()):
    """B_m of runs without a sense voltage, through the components' own path, [T].

    ``magnetization_ratio`` is M_1/H_m as y's fundamental gives it through the
    paper's continuous mechanics (``smeha.identify.flux_density_from_displacement``,
    eq 19). An extension that changes the path from M to y (mechanics, sensor)
    divides by its ratio to the paper's path, and an eddy-current extension,
    with which M_1 = (mu - 1) <g> H_m and B_1 = mu_0 mu <g> H_m, gives
    B_m = mu_0 H_m |M_1/H_m + <g>|; for the paper's model this is eq 19's
    mu_0 H_m |mu|. Otherwise B_m would already carry the effect under test.
    Arrays of runs allowed.
    """
    w = 2.0 * math.pi * np.asarray(frequency, dtype=float)
    hm = params.field_per_ampere * np.asarray(current_amplitude, dtype=float)
    g0 = mechanics_response(params.mass, params.damping, params.stiffness, w)
    path = np.ones_like(g0)
    gin = np.ones_like(g0)
    for cls, values in components:
        if cls.stage == "mechanics":
            path = path * cls.steady_mechanics(values, params, w) / g0
        elif cls.stage == "sensor":
            path = path * cls.steady_sensor(values, w)
        elif cls.stage == "field":
            gin = (cls.field_gain(values, w) + cls.vacuum_share(values, w)) * np.ones_like(g0)
    out = MU_0 * hm * np.abs(np.asarray(magnetization_ratio) / path + gin)
    return out if np.ndim(frequency) else float(np.ravel(out)[0])
