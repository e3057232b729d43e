"""Seeded synthetic measured runs: the paper's model plus one hidden effect.

The diagnosis workflow (issue #5) must name the cause of a misfit from data
alone. This module makes its test data: measured-like :class:`~smeha.measured.Run`
objects at several frequencies and current amplitudes, from the paper's model
(eq 30: the magnetics of :mod:`gmt` at the samples, the mechanics of eq 27
integrated as the continuous system, :func:`_continuous_mechanics`) with at
most one physical effect added
that the paper's model lacks. The caller (a test) chooses the effect; the runs
carry it in ``Run.meta`` (the diagnosis must not read ``meta``; tests do).

What is recorded, as a bench would
----------------------------------
* ``current`` -- the coil current i = I_m cos(w t) measured with Gaussian noise
  (``current_noise``, [A]); the model is driven by the true sinusoid.
* ``control`` -- the command u = I_m cos(w t) / K_a (K_a = 1 A/V, the paper's
  amplifier); the command is digital and carries no noise.
* ``displacement`` -- y(t) in metres minus the bias displacement of the magnet
  alone, plus a random constant offset per run (measured displacements are
  relative, as the paper's Table 3 zeroes them at the loop minimum), plus
  Gaussian noise ``noise_um``.
* ``sense_voltage`` -- E = -N_c A_c dB/dt (eq 21) of the model's B(t), plus
  Gaussian noise ``voltage_noise``, [V]. dB/dt of the paper's B is exact
  (B is a sinusoid, eq 4); an effect's change of B is differentiated by
  second-order central differences.

Times are t_k = k h, h = 1 / (f * samples_per_cycle), k = 0 ... cycles *
samples_per_cycle - 1. The mechanics start at rest at the bias displacement at
t = 0, as :func:`gmt.simulate` does (its transient dies within ~1 ms).

The noise of run (f, I_m) for a given ``seed`` is the same whatever the effect
and its strength: ``generate_runs(effect, seed=s)`` minus
``generate_runs(None, seed=s)`` is the effect alone. The effect's own
parameters are drawn (``jitter``) from a second, independent stream.

The hidden effects
------------------
Each effect is a *truth* formulation chosen to differ from the candidate
extensions the diagnosis fits (so the diagnosis cannot win by sharing the
generator's formula); each reduces to the paper's model as its strength goes
to 0, and ``strength = 0`` returns the paper's model exactly.

===============================  ==============================================
effect                           truth formulation (see the ``_..._`` functions)
===============================  ==============================================
``rate_independent_hysteresis``  classical Preisach model (Mayergoyz 1991;
                                 Tan & Baras 2004) of the applied field,
                                 lognormal-coercivity x Gaussian-interaction
                                 density, Everett-function evaluation,
                                 added to the paper's M (eq 5)
``magnetization_saturation``     Langevin anhysteretic M_s L(x),
                                 L = coth x - 1/x (Jiles & Atherton 1986), of
                                 the total effective field with the bias M_b
                                 inside, linearised at the bias to match eq 5
``eddy_current_diffusion``       1-D magnetic diffusion across a slab of the
                                 rod's thickness, finite differences in space,
                                 exact first-order-hold time integration, flux
                                 and strain averaged over the thickness
                                 (Bertotti 1998, ch. 8 and 12; Stoll 1974)
``transport_delay``              a delay line on the displacement sensor:
                                 y_meas(t) = y(t - tau), y rebuilt between
                                 samples by a cubic spline of the fine record
``mechanical_resonance``         two masses: the rod (m_1, K, c) and an output
                                 mass m_2 on a compliant joint (k_j, c_j); the
                                 sensor reads m_2 (Engdahl 2000, ch. 4)
``thermal_drift``                first-order thermal model of coil heating
                                 i^2 R(T), with K_lambda(T) and a sensor
                                 offset proportional to the temperature rise
                                 (Engdahl 2000; Clark 1980 for K_lambda(T))
===============================  ==============================================

Strength ``1.0`` makes each effect clearly visible (RMS change of y of a few
um on the runs where the effect matters, against 0.05 um of noise); the
effect's size scales monotonically with ``strength`` (see
:func:`truth_parameters` for how each parameter scales).

References
----------
* I. D. Mayergoyz, *Mathematical Models of Hysteresis*, Springer 1991, ch. 1.
* X. Tan, J. S. Baras, "Modeling and control of hysteresis in magnetostrictive
  actuators", Automatica 40 (2004) 1469-1480.
* D. C. Jiles, D. L. Atherton, "Theory of ferromagnetic hysteresis",
  J. Magn. Magn. Mater. 61 (1986) 48-60.
* G. Bertotti, *Hysteresis in Magnetism*, Academic Press 1998, ch. 8 (eddy
  currents in laminations, magnetic diffusion).
* R. L. Stoll, *The Analysis of Eddy Currents*, Clarendon 1974 (slab solution
  tanh(q)/q used in the tests).
* G. Engdahl (ed.), *Handbook of Giant Magnetostrictive Materials*, Academic
  Press 2000 (Terfenol-D properties: M_s ~ 765 kA/m, rho ~ 0.6 uOhm m,
  thermal behaviour, transducer dynamics).
* A. E. Clark, "Magnetostrictive rare earth-Fe2 compounds", in Ferromagnetic
  Materials vol. 1, North-Holland 1980 (temperature dependence of
  magnetostriction; delta-E).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter
from scipy.special import ndtr

import gmt
from gmt.constants import MU_0
from gmt.forward import bias_displacement, magnetics
from gmt.magnetostriction import magnetostriction, magnetostrictive_force
from gmt.sensing import induced_voltage

from .measured import Run

#: The hidden effects the generator can add (``None`` adds none).
EFFECTS = ("rate_independent_hysteresis", "magnetization_saturation",
           "eddy_current_diffusion", "transport_delay", "mechanical_resonance",
           "thermal_drift")

#: Effects that change B (and so the sensing-coil voltage); the others act on
#: the mechanics, the strain coefficient or the displacement sensor only.
MAGNETIC_EFFECTS = ("rate_independent_hysteresis", "magnetization_saturation",
                    "eddy_current_diffusion")

#: Half-width of the random constant displacement offset per run, [m].
OFFSET_RANGE = 30e-6

#: Nominal truth parameters at strength 1 (SI). See :func:`truth_parameters`.
NOMINAL = {
    "rate_independent_hysteresis": {
        # Preisach part of the magnetisation at positive saturation of all its
        # hysterons, [A/m]; scales with strength.
        "preisach_magnetization": 12e3,
        # median coercive (half-width) field of the lognormal density, [A/m]
        "coercive_field": 5e3,
        "coercive_log_spread": 0.5,  # sigma of ln(r), [-]
        "interaction_spread": 4e3,  # sigma of the Gaussian interaction field, [A/m]
    },
    "magnetization_saturation": {
        # Saturation magnetisation of the Langevin law at strength 1, [A/m];
        # M_s = M_b + (value - M_b) / sqrt(strength), so M_s -> inf as strength -> 0.
        "saturation_magnetization": 400e3,
    },
    "eddy_current_diffusion": {
        "thickness": 10e-3,  # slab thickness: the rod diameter, [m]
        "conductivity": 1.7e6,  # Terfenol-D, rho = 0.59 uOhm m (Engdahl 2000), [S/m]
        # Frequency at which the skin depth sqrt(2/(w mu sigma)) equals the half
        # thickness at strength 1, [Hz]; the diffusion time mu sigma d^2 scales
        # with strength.
        "half_thickness_skin_frequency": 100.0,
        "nodes": 12,  # finite-difference nodes over the half thickness
    },
    "transport_delay": {
        "delay": 0.5e-3,  # sensor delay tau at strength 1, [s]; scales with strength
    },
    "mechanical_resonance": {
        "output_mass": 0.015,  # m_2, [kg]; the rod keeps m_1 = m - m_2
        # resonance of m_2 on the joint alone, sqrt(k_j/m_2)/(2 pi), at strength 1
        # [Hz]; the joint compliance 1/k_j scales with strength
        "joint_frequency": 450.0,
        "joint_damping_ratio": 0.1,  # c_j / (2 sqrt(k_j m_2)), [-]
    },
    "thermal_drift": {
        "coil_resistance": 4.0,  # R_0 at the start temperature, [Ohm]
        "resistance_coefficient": 3.93e-3,  # copper, [1/K]
        # thermal resistance coil -> ambient at strength 1, [K/W]; scales with strength
        "thermal_resistance": 5.0,
        "thermal_time_constant": 1.0,  # R_th C_th, [s]
        "strain_coefficient_tc": -4e-3,  # (dK_lambda/dT)/K_lambda, [1/K]
        # sensor offset per kelvin: rod and sensor-mount expansion, [m/K]
        "offset_tc": 1.0e-6,
    },
}

#: Parameters jittered per seed (log-uniform factor within 1 -+ jitter).
_JITTERED = {
    "rate_independent_hysteresis": ("preisach_magnetization", "coercive_field"),
    "magnetization_saturation": ("saturation_magnetization",),
    "eddy_current_diffusion": ("half_thickness_skin_frequency",),
    "transport_delay": ("delay",),
    "mechanical_resonance": ("joint_frequency", "joint_damping_ratio"),
    "thermal_drift": ("thermal_resistance", "thermal_time_constant"),
}


# ----------------------------------------------------------------- truth parameters


def truth_parameters(effect, strength=1.0, *, seed=0, jitter=0.2, params=None) -> dict:
    """The hidden effect's parameters, scaled by ``strength`` and jittered by ``seed``.

    Parameters
    ----------
    effect : str or None
        One of :data:`EFFECTS`, or ``None`` (empty dict).
    strength : float
        >= 0; 0 switches the effect off, 1 is the nominal (clearly visible) size.
    seed : int
        Seed of the jitter stream (independent of the noise stream).
    jitter : float
        Relative spread, in [0, 0.5), of the jittered nominal parameters
        (:data:`_JITTERED`): each is multiplied by a log-uniform factor in
        [1/(1 + jitter), 1 + jitter]. 0 gives :data:`NOMINAL` exactly.
    params : gmt.TransducerParameters, optional
        The transducer (for M_b and m); default Table 2.

    Returns
    -------
    dict
        Every parameter the truth formulation uses, SI, after scaling:

        * hysteresis: ``preisach_magnetization`` x strength;
        * saturation: M_s = M_b + (M_s1 - M_b) / sqrt(strength) (inf at 0;
          the distortion grows as 1/M_s^2, so about linearly in strength);
        * eddy: ``diffusion_time`` mu sigma d^2 = 8 strength / (2 pi f_1),
          and the implied relative permeability;
        * delay: ``delay`` x strength;
        * resonance: ``joint_stiffness`` = m_2 (2 pi f_j)^2 / strength (inf
          at 0), ``joint_damping`` keeping the damping ratio;
        * thermal: ``thermal_resistance`` x strength.
    """
    if effect is None:
        return {}
    if effect not in EFFECTS:
        raise ValueError(f"effect = {effect!r} is not one of {EFFECTS} or None")
    s = float(strength)
    if not (s >= 0.0 and math.isfinite(s)):
        raise ValueError(f"strength = {strength!r} is outside the allowed range [0, inf)")
    if not 0.0 <= jitter < 0.5:
        raise ValueError(f"jitter = {jitter!r} is outside the allowed range [0, 0.5)")
    p = params or gmt.TransducerParameters()
    rng = np.random.default_rng([int(seed), 20250605])
    nominal = dict(NOMINAL[effect])
    for name in _JITTERED[effect]:
        factor = math.exp(rng.uniform(-1.0, 1.0) * math.log1p(jitter))
        nominal[name] *= factor
    t = dict(nominal)
    if effect == "rate_independent_hysteresis":
        t["preisach_magnetization"] = s * nominal["preisach_magnetization"]
    elif effect == "magnetization_saturation":
        mb = p.bias_magnetization
        t["saturation_magnetization"] = (
            math.inf if s == 0.0
            else mb + (nominal["saturation_magnetization"] - mb) / math.sqrt(s))
    elif effect == "eddy_current_diffusion":
        w1 = 2.0 * math.pi * nominal["half_thickness_skin_frequency"]
        # delta = d/2 at f_1 <=> mu sigma = 2 / (w_1 (d/2)^2) <=> mu sigma d^2 = 8 / w_1
        t["diffusion_time"] = s * 8.0 / w1
        d, sigma = nominal["thickness"], nominal["conductivity"]
        t["relative_permeability"] = t["diffusion_time"] / (MU_0 * sigma * d * d)
    elif effect == "transport_delay":
        t["delay"] = s * nominal["delay"]
    elif effect == "mechanical_resonance":
        m2 = nominal["output_mass"]
        if not 0.0 < m2 < p.mass:
            raise ValueError(f"output_mass = {m2:g} kg must lie in (0, {p.mass:g}) kg")
        k1 = m2 * (2.0 * math.pi * nominal["joint_frequency"]) ** 2
        t["joint_stiffness"] = math.inf if s == 0.0 else k1 / s
        t["joint_damping"] = (math.inf if s == 0.0 else
                              2.0 * nominal["joint_damping_ratio"] * math.sqrt(k1 / s * m2))
        t["joint_frequency"] = (math.inf if s == 0.0 else nominal["joint_frequency"] / math.sqrt(s))
    elif effect == "thermal_drift":
        t["thermal_resistance"] = s * nominal["thermal_resistance"]
    return t


# ----------------------------------------------------------------- Preisach (hysteresis)


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(48)


def _everett(alpha, beta, coercive_field, log_spread, interaction_spread):
    """Everett function F(alpha, beta) of the Preisach density, [-].

    The density over the Preisach half-plane alpha >= beta is factorised in the
    coercive field r = (alpha - beta)/2 (lognormal, median ``coercive_field``,
    log-spread ``log_spread``) and the interaction field u = (alpha + beta)/2
    (Gaussian, zero mean, ``interaction_spread``), normalised to 1 over the half
    plane (Mayergoyz 1991, sec. 1.2; the factorised form is Della Torre's).
    F(alpha, beta) is its integral over the triangle beta <= beta' <= alpha' <=
    alpha, i.e. over 0 <= r' <= R, |u' - c| <= R - r' with R = (alpha - beta)/2,
    c = (alpha + beta)/2:

        F = int_0^R w(r') [Phi((c + R - r')/s_u) - Phi((c - R + r')/s_u)] dr',

    evaluated by 48-point Gauss-Legendre quadrature in r' (in log r', where the
    lognormal is smooth). Vectorised over ``alpha``, ``beta``.
    """
    a = np.asarray(alpha, dtype=float)
    b = np.asarray(beta, dtype=float)
    big_r = np.maximum(0.5 * (a - b), 0.0)
    c = 0.5 * (a + b)
    # quadrature in z = ln r' over [ln r_lo, ln R]; below r_lo = r0 e^{-8 s} the
    # lognormal has no mass
    z_lo = math.log(coercive_field) - 8.0 * log_spread
    z_hi = np.log(np.maximum(big_r, 1e-300))
    valid = z_hi > z_lo
    z_hi = np.where(valid, z_hi, z_lo)
    half = 0.5 * (z_hi - z_lo)
    mid = 0.5 * (z_hi + z_lo)
    z = mid[..., None] + half[..., None] * _GL_NODES
    r = np.exp(z)
    # w(r) dr = lognormal pdf in z: N(z; ln r0, s) dz
    wz = np.exp(-0.5 * ((z - math.log(coercive_field)) / log_spread) ** 2) / (
        log_spread * math.sqrt(2.0 * math.pi))
    reach = big_r[..., None] - r
    inner = (ndtr((c[..., None] + reach) / interaction_spread)
             - ndtr((c[..., None] - reach) / interaction_spread))
    out = half * np.sum(_GL_WEIGHTS * wz * inner, axis=-1)
    return np.where(valid, out, 0.0)


def preisach(field, *, coercive_field, coercive_log_spread, interaction_spread,
             limit=None, demagnetisation_steps=64, history=()):
    """Output of a classical Preisach operator with relays +-1, in [-1, 1].

    Parameters
    ----------
    field : array
        Input H_k, [A/m], sample by sample (rate independent: only the order
        of values matters).
    coercive_field, coercive_log_spread, interaction_spread
        The density, see :func:`_everett`.
    limit : float, optional
        The Preisach triangle is alpha, beta in [-limit, limit], [A/m]
        (default: far beyond the density, r0 e^{4 s} + 6 s_u).
    demagnetisation_steps : int
        The operator starts from the AC-demagnetised state, made by the
        alternating extrema +-limit (1 - j/J), j = 0 ... J - 1.
    history : sequence of float
        Extra turning points fed after demagnetisation, before ``field``
        (e.g. one period of the excitation, so the run starts on its loop).

    Notes
    -----
    The relays' state is the staircase of the memory of dominant extrema
    (Mayergoyz 1991, sec. 1.3): a rise above a stored maximum wipes it out
    with the minimum that follows it, a fall below a stored minimum likewise.
    With S+ the region of relays at +1, the output is 2 mu(S+) - mu(T), and
    mu(S+) is a sum of Everett functions over the memory: at a maximum M
    reached from the minimum m, mu(S+) grows by F(M, m); at a minimum m'
    reached from M it falls by F(M, m'). The loop here only keeps the memory;
    the Everett functions are then evaluated vectorised.
    """
    h = np.asarray(field, dtype=float)
    dens = (coercive_field, coercive_log_spread, interaction_spread)
    if limit is None:
        limit = coercive_field * math.exp(4.0 * coercive_log_spread) + 6.0 * interaction_spread
    h = np.clip(h, -limit, limit)
    # memory: turning values, alternating min, max, min, ... starting with -limit
    # (negative saturation), and mu(S+) at each of them
    ext = [-limit]
    mus = [0.0]
    rising = True
    last = -limit

    def move(u):
        nonlocal rising, last
        if u > last and not rising:  # a fall ended at `last`: a new minimum
            mus.append(mus[-1] - float(_everett(ext[-1], last, *dens)))
            ext.append(last)
            rising = True
        elif u < last and rising:  # a rise ended at `last`: a new maximum
            if len(ext) > 0 and last > ext[-1]:
                mus.append(mus[-1] + float(_everett(last, ext[-1], *dens)))
                ext.append(last)
            rising = False
        # wiping out (the sentinel -limit is never removed)
        if rising:
            while len(ext) >= 3 and u >= ext[-2]:
                del ext[-2:], mus[-2:]
        else:
            while len(ext) >= 3 and u <= ext[-2]:
                del ext[-2:], mus[-2:]
        last = u

    turning = [limit * (1.0 - j / demagnetisation_steps) * (-1.0) ** j
               for j in range(demagnetisation_steps)]
    for u in list(turning) + [float(x) for x in history]:
        move(u)
    base = np.empty(h.size)
    arg_a = np.empty(h.size)
    arg_b = np.empty(h.size)
    sign = np.empty(h.size)
    for k, u in enumerate(h.tolist()):
        move(u)
        base[k] = mus[-1]
        if rising:  # mu(S+) = mu(at last minimum) + F(u, m)
            arg_a[k], arg_b[k], sign[k] = u, ext[-1], 1.0
        else:  # mu(S+) = mu(at last maximum) - F(M, u)
            arg_a[k], arg_b[k], sign[k] = ext[-1], u, -1.0
    mu_plus = base + sign * _everett(arg_a, arg_b, *dens)
    total = float(_everett(limit, -limit, *dens))
    return 2.0 * mu_plus - total


# ----------------------------------------------------------------- Langevin (saturation)


def langevin(x):
    """Langevin function L(x) = coth(x) - 1/x, [-] (Taylor series for |x| < 0.05)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 0.05
    xs = np.where(small, 1.0, x)
    big = 1.0 / np.tanh(xs) - 1.0 / xs
    x2 = x * x
    series = x * (1.0 / 3.0 + x2 * (-1.0 / 45.0 + x2 * (2.0 / 945.0 - x2 / 4725.0)))
    return np.where(small, series, big)[()]


def langevin_slope(x):
    """L'(x) = 1/x^2 - 1/sinh^2(x), [-] (Taylor series for |x| < 0.05)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 0.05
    xs = np.where(small, 1.0, x)
    big = 1.0 / xs ** 2 - 1.0 / np.sinh(xs) ** 2
    x2 = x * x
    series = 1.0 / 3.0 + x2 * (-1.0 / 15.0 + x2 * (2.0 / 189.0 - x2 / 675.0))
    return np.where(small, series, big)[()]


def inverse_langevin(y: float) -> float:
    """x with L(x) = y, |y| < 1, by Newton's method from Cohen's Pade start."""
    if not abs(y) < 1.0:
        raise ValueError(f"inverse_langevin: y = {y!r} is outside (-1, 1)")
    x = y * (3.0 - y * y) / (1.0 - y * y)
    for _ in range(50):
        step = (float(langevin(x)) - y) / float(langevin_slope(x))
        x -= step
        if abs(step) <= 1e-15 * max(1.0, abs(x)):
            break
    return x


def saturated_magnetization(magnetization, bias_magnetization, saturation_magnetization):
    """Coil magnetisation through a Langevin anhysteretic of the total field, [A/m].

    The paper's linear magnetisation M (eq 5, with its lag) stands for an
    effective field H_e = (M_b + M) / chi about the bias. The truth is the
    anhysteretic law of Jiles & Atherton (1986), M_tot = M_s L(H_e / a), with
    the bias inside: x_b = L^{-1}(M_b / M_s) places the bias, and the scale of
    H_e / a is fixed so the law's slope at the bias equals the paper's:

        M_tot = M_s L(x_b + M / (M_s L'(x_b))),  returned: M_tot - M_b.

    As M_s -> inf this tends to M (eq 5) exactly; for finite M_s the top of
    the loop (towards saturation) flattens and the bottom steepens, more so at
    larger amplitude.
    """
    m = np.asarray(magnetization, dtype=float)
    if math.isinf(saturation_magnetization):
        return m
    ms = saturation_magnetization
    xb = inverse_langevin(bias_magnetization / ms)
    return ms * langevin(xb + m / (ms * float(langevin_slope(xb)))) - bias_magnetization


# ----------------------------------------------------------------- linear systems, FOH


def _foh_response(a, b, c, u, step, x0=None):
    """Output c x_k of dx/dt = a x + b u(t) for u linear between samples, x(0) = x0.

    Exact first-order-hold integration, mode by mode (a = V diag(lam) V^-1,
    possibly complex): z' = lam z + g u gives z_{k+1} = e^{lam h} z_k
    + g (P0 - P1) u_k + g P1 u_{k+1}, with P0 = (e^{lam h} - 1)/lam and
    P1 = (e^{lam h} - 1 - lam h)/(lam^2 h); each mode is one
    :func:`scipy.signal.lfilter`. ``c`` may be a matrix (several outputs).
    """
    u = np.asarray(u, dtype=float)
    lam, vec = np.linalg.eig(np.asarray(a, dtype=float))
    g = np.linalg.solve(vec, np.asarray(b, dtype=complex))
    z0 = (np.zeros(lam.size, complex) if x0 is None
          else np.linalg.solve(vec, np.asarray(x0, dtype=complex)))
    x = lam * step
    em1 = np.expm1(x)
    p0 = em1 / lam
    small = np.abs(x) < 1e-3
    p1 = np.where(small, step * (0.5 + x / 6.0 + x * x / 24.0),
                  (em1 - x) / np.where(small, 1.0, lam * lam * step))
    cv = np.atleast_2d(np.asarray(c, dtype=float)) @ vec
    out = np.zeros((cv.shape[0], u.size))
    for i in range(lam.size):
        b1, b0 = g[i] * p1[i], g[i] * (p0[i] - p1[i])
        # z_k = e^{lam h} z_{k-1} + b1 u_k + b0 u_{k-1}; DF-II transposed: z_0 = b1 u_0 + zi
        zi = lfilter([b1, b0], [1.0, -np.exp(x[i])], u, zi=[z0[i] - b1 * u[0]])[0]
        out += (cv[:, i:i + 1] * zi).real
    return out if np.ndim(c) == 2 else out[0]


# ----------------------------------------------------------------- slab diffusion (eddy)


def _slab_matrices(diffusion_time, nodes):
    """Method-of-lines matrices (A, b) of 1-D diffusion in a half slab.

    dH/dt = (1/(mu sigma)) d^2H/dx^2 on 0 <= x <= d/2, dH/dx = 0 at the centre
    (symmetry), H = u(t) at the surface x = d/2 (the applied field). With n
    nodes x_j = j dx (dx = d/(2n)), j = 0 ... n-1, and the surface at j = n:
    dH/dt = A H + b u, A = D/dx^2 tridiag(1, -2, 1) with the mirror row 0
    (-2, 2), and D/dx^2 = 4 n^2 / (mu sigma d^2).
    """
    n = nodes
    g = 4.0 * n * n / diffusion_time
    a = np.zeros((n, n))
    for j in range(n):
        a[j, j] = -2.0 * g
        if j > 0:
            a[j, j - 1] = g
        if j < n - 1:
            a[j, j + 1] = g
    a[0, 1] = 2.0 * g
    b = np.zeros(n)
    b[-1] = g
    return a, b


def slab_diffusion(surface, step, diffusion_time, nodes=12):
    """Field across a half slab driven by its surface value, sampled, [same unit as input].

    Parameters
    ----------
    surface : array
        u_k, the surface (applied) value at t_k = k h.
    step : float
        h, [s].
    diffusion_time : float
        mu sigma d^2, [s] (the slab's thickness d, permeability mu,
        conductivity sigma); the skin depth sqrt(2/(w mu sigma)) equals d/2 at
        w = 8 / (mu sigma d^2).
    nodes : int
        Finite-difference nodes over the half thickness.

    Returns
    -------
    (array, array)
        Interior nodal values, shape (n + 1, len(surface)) including the
        surface node last, and the trapezoid weights over the half thickness
        (summing to 1), so the thickness average is ``weights @ values``.

    Notes
    -----
    Time integration is exact for a surface value linear between samples
    (first-order hold, :func:`_foh_response`). The slab starts in equilibrium
    with u_0. The classical slab solution (Stoll 1974; Bertotti 1998, eq 12.8) gives
    the average <H>/H_s = tanh(q)/q, q = (1 + j) d/(2 delta), which the
    finite-difference model approaches as the nodes are refined.
    """
    u = np.asarray(surface, dtype=float)
    a, b = _slab_matrices(diffusion_time, nodes)
    # the slab starts in equilibrium with u_0
    modes = _foh_response(a, b, np.eye(nodes), u, step, x0=np.full(nodes, u[0]))
    values = np.vstack((modes, u))
    weights = np.ones(nodes + 1) / nodes
    weights[0] = weights[-1] = 0.5 / nodes
    return values, weights


# ----------------------------------------------------------------- two-mass mechanics


def two_mass_matrices(rod_mass, damping, stiffness, output_mass, joint_stiffness,
                      joint_damping):
    """Continuous state-space (A, B) of the rod + output-mass model.

    State x = [y_1, v_1, y_2, v_2] (rod end, output mass), input the
    magnetostrictive force F on the rod (eq 28)::

        m_1 y_1'' = F - K y_1 - c y_1' - k_j (y_1 - y_2) - c_j (y_1' - y_2')
        m_2 y_2'' = k_j (y_1 - y_2) + c_j (y_1' - y_2')

    With k_j, c_j -> inf the joint is rigid and this is eq 27 with
    m = m_1 + m_2.
    """
    m1, m2, k, c, kj, cj = rod_mass, output_mass, stiffness, damping, joint_stiffness, joint_damping
    a = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-(k + kj) / m1, -(c + cj) / m1, kj / m1, cj / m1],
        [0.0, 0.0, 0.0, 1.0],
        [kj / m2, cj / m2, -kj / m2, -cj / m2],
    ])
    b = np.array([0.0, 1.0 / m1, 0.0, 0.0])
    return a, b


def two_mass_response(force, step, params, truth, paper_displacement):
    """Output-mass displacement y_2 at t_k, [m].

    The force of a sinusoidal current is smooth, so it is taken linear between
    samples (first-order hold, :func:`_foh_response`): a held force would ring
    the lightly damped joint at every sample. The truth is

        y_2 = y_paper + [y_2 of the two-mass model - y of eq 27 with m = m_1 + m_2],

    both bracketed responses to the same interpolated force F - F_bias,
    starting in static equilibrium with the first force: the continuous paper model
    (``paper_displacement``) plus what the compliant joint changes. As k_j -> inf
    the bracket vanishes.
    """
    m2 = truth["output_mass"]
    a2, b2 = two_mass_matrices(params.mass - m2, params.damping, params.stiffness, m2,
                               truth["joint_stiffness"], truth["joint_damping"])
    a1 = np.array([[0.0, 1.0], [-params.stiffness / params.mass, -params.damping / params.mass]])
    b1 = np.array([0.0, 1.0 / params.mass])
    u = np.asarray(force, dtype=float) - bias_displacement(params) * params.stiffness
    # both start in static equilibrium with the first force (the joint is
    # unloaded at rest), so the bracket starts at 0 and holds no start step
    y_start = u[0] / params.stiffness
    y2 = _foh_response(a2, b2, [0.0, 0.0, 1.0, 0.0], u, step,
                       x0=[y_start, 0.0, y_start, 0.0])
    y1 = _foh_response(a1, b1, [1.0, 0.0], u, step, x0=[y_start, 0.0])
    return paper_displacement + (y2 - y1)


# ----------------------------------------------------------------- thermal


def temperature_rise(time, current_amplitude, frequency, truth):
    """Coil temperature rise Delta T(t), [K], from a first-order thermal model.

        tau dDT/dt = R_th i(t)^2 R_0 (1 + alpha_R DT) - DT,  DT(0) = 0,

    (tau = R_th C_th) with i = I_m cos(w t), the true current: the coil's Joule
    heat with a copper resistance rising with temperature, lost to the ambient
    through R_th. The equation is linear in DT, dDT/dt = a(t) DT + b(t), so

        DT(t) = int_0^t exp(Phi(t) - Phi(s)) b(s) ds,  Phi(t) = int_0^t a,

    with Phi in closed form (cos^2 = (1 + cos 2wt)/2) and the outer integral by
    the trapezoid rule on a grid four times finer than the samples (relative
    error ~ (w h / 4)^2 / 12, 4e-6 at 256 samples a period). Each run starts
    at the ambient temperature.
    """
    t = np.asarray(time, dtype=float)
    r_th = truth["thermal_resistance"]
    if r_th == 0.0:
        return np.zeros_like(t)
    tau = truth["thermal_time_constant"]
    r0, alpha = truth["coil_resistance"], truth["resistance_coefficient"]
    w = 2.0 * math.pi * frequency
    c = r_th * r0 * current_amplitude ** 2 / tau  # heating rate per cos^2, [K/s]
    fine = 4
    tf = np.linspace(t[0], t[-1], fine * (t.size - 1) + 1)
    cos2 = np.cos(w * tf) ** 2
    phi = alpha * c * (0.5 * (tf - t[0]) + (np.sin(2 * w * tf) - np.sin(2 * w * t[0])) / (4 * w)) \
        - (tf - t[0]) / tau
    g = np.exp(-phi) * c * cos2
    integral = np.concatenate(([0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(tf))))
    return (np.exp(phi) * integral)[::fine]


# ----------------------------------------------------------------- one run, noise-free


def _paper_force(params, magnetization):
    """Magnetostrictive force A_r E^H K_lambda (M_b + M)^2, eqs 25 and 28, [N]."""
    return magnetostrictive_force(
        magnetostriction(magnetization, params.bias_magnetization,
                                     params.magnetostriction_coefficient),
        params.rod_area, params.youngs_modulus)


def _with_force(params, point, current, step, paper, force):
    """Eq 27 driven by ``force`` (F at the samples, linear between them), [m].

    The continuous transducer: the mechanics integrated exactly for a force
    linear between the samples (first-order hold, :func:`_foh_response`), from
    rest at the bias displacement at t = 0, as :func:`gmt.simulate` starts. Not
    the paper's zero-order-hold stepper, which would delay the response by
    half a step (and more where the mechanics are fast against the step).
    """
    return _continuous_mechanics(params, force, step)


def _continuous_mechanics(params, force, step):
    """y of eq 27 for the force samples ``force`` [N], linear between samples, [m]."""
    a = np.array([[0.0, 1.0], [-params.stiffness / params.mass,
                               -params.damping / params.mass]])
    b = np.array([0.0, 1.0 / params.mass])
    y_b = bias_displacement(params)
    u = np.asarray(force, dtype=float) - params.stiffness * y_b
    return y_b + _foh_response(a, b, [1.0, 0.0], u, step, x0=[0.0, 0.0])


#: Internal steps per sample of the generator's models: the force is taken linear between
#: the internal samples (relative error about (w h / FINE)^2 / 12, 3e-6 at 256 samples a
#: period) and the effects' own integrations run on the same grid.
FINE = 4


def true_response(effect, truth, params, frequency, current_amplitude, cycles=8,
                  samples_per_cycle=256) -> dict:
    """Noise-free record of one run with the hidden effect, SI.

    The models run on a grid :data:`FINE` times finer than the samples
    (the mechanics of eq 27 integrated exactly for a force linear between the
    internal samples, :func:`_continuous_mechanics`) and are read at the samples.

    Returns
    -------
    dict
        ``time``, ``current`` (true), ``displacement`` (absolute, including the
        bias displacement), ``flux_density`` and ``flux_density_rate`` (dB/dt),
        and for some effects internals (``temperature_rise``, ...).
    """
    out = _fine_response(effect, truth, params, frequency, current_amplitude, cycles,
                         samples_per_cycle * FINE)
    n = int(cycles * samples_per_cycle)
    return {k: np.asarray(v)[::FINE][:n] for k, v in out.items()}


def _fine_response(effect, truth, params, frequency, current_amplitude, cycles,
                   samples_per_cycle) -> dict:
    """:func:`true_response` on the fine grid."""
    f, im = float(frequency), float(current_amplitude)
    n = int(cycles * samples_per_cycle)
    h = 1.0 / (f * samples_per_cycle)
    w = 2.0 * math.pi * f
    t = h * np.arange(n)
    i = im * np.cos(w * t)
    point = gmt.operating_point(params, gmt.Excitation(f, im))
    paper = gmt.simulate(params, point, i, h)  # the magnetics of eq 30 at the samples
    paper_y = _continuous_mechanics(params, paper["force"], h)
    # dB/dt of eq 4 exactly: dH/dt = -w H_q, dH_q/dt = w H
    dbdt = MU_0 * w * (point.mu_real * -paper["quadrature_field"]
                       + point.mu_imag * paper["field"])
    out = {"time": t, "current": i, "displacement": paper_y,
           "flux_density": paper["flux_density"], "flux_density_rate": dbdt}
    if effect is None:
        return out
    m_paper = paper["magnetization"]
    m_eff = None
    force = None
    if effect == "rate_independent_hysteresis":
        if truth["preisach_magnetization"] != 0.0:
            hm = params.field_per_ampere * im
            m_pre = preisach(paper["field"], coercive_field=truth["coercive_field"],
                             coercive_log_spread=truth["coercive_log_spread"],
                             interaction_spread=truth["interaction_spread"],
                             history=(hm, -hm))
            m_eff = m_paper + truth["preisach_magnetization"] * m_pre
    elif effect == "magnetization_saturation":
        if not math.isinf(truth["saturation_magnetization"]):
            m_eff = saturated_magnetization(m_paper, params.bias_magnetization,
                                            truth["saturation_magnetization"])
    elif effect == "eddy_current_diffusion":
        if truth["diffusion_time"] > 0.0:
            # warm-up: the slowest slab mode decays as exp(-pi^2 t / (mu sigma d^2))
            warm = max(1, math.ceil(20.0 * truth["diffusion_time"] / math.pi ** 2 * f))
            tw = h * np.arange(-warm * samples_per_cycle, 0)
            mag_w = magnetics(params, point, im * np.cos(w * tw),
                                          im * np.sin(w * tw))
            nw = tw.size
            m_all = np.concatenate((mag_w.magnetization, m_paper))
            b_all = np.concatenate((mag_w.flux_density, paper["flux_density"]))
            m_x, wts = slab_diffusion(m_all, h, truth["diffusion_time"], truth["nodes"])
            b_x, _ = slab_diffusion(b_all, h, truth["diffusion_time"], truth["nodes"])
            m_x = m_x[:, nw:]
            m_eff = wts @ m_x
            b_eff = wts @ b_x[:, nw:]
            # strain is local: average (M_b + M(x))^2 over the thickness (parallel fibres)
            force = _paper_force(params, 0.0) * (
                wts @ (params.bias_magnetization + m_x) ** 2) / params.bias_magnetization ** 2
            out["flux_density"] = b_eff
            out["flux_density_rate"] = dbdt + np.gradient(b_eff - paper["flux_density"], h,
                                                          edge_order=2)
            out["magnetization"] = m_eff
            out["displacement"] = _with_force(params, point, i, h, paper, force)
            return out
    elif effect == "transport_delay":
        tau = truth["delay"]
        if tau > 0.0:
            out["displacement"] = _delayed(params, t, paper_y, tau)
        return out
    elif effect == "mechanical_resonance":
        if not math.isinf(truth["joint_stiffness"]):
            out["displacement"] = two_mass_response(paper["force"], h, params, truth,
                                                    paper_y)
        return out
    elif effect == "thermal_drift":
        dtemp = temperature_rise(t, im, f, truth)
        out["temperature_rise"] = dtemp
        if truth["thermal_resistance"] > 0.0:
            force = paper["force"] * (1.0 + truth["strain_coefficient_tc"] * dtemp)
            out["displacement"] = (_with_force(params, point, i, h, paper, force)
                                   + truth["offset_tc"] * dtemp)
        return out
    if m_eff is not None:
        b_eff = MU_0 * (paper["field"] + m_eff)
        out["flux_density"] = b_eff
        out["flux_density_rate"] = dbdt + np.gradient(b_eff - paper["flux_density"], h,
                                                      edge_order=2)
        out["magnetization"] = m_eff
        out["displacement"] = _with_force(params, point, i, h, paper,
                                          _paper_force(params, m_eff))
    return out


def _delayed(params, time, displacement, delay):
    """The displacement record read through a delay line, y(t_k - tau), [m].

    The sensor's analog output is the smooth displacement y(t) delayed by tau;
    it is rebuilt from the finely sampled record (256 samples a period by
    default) by a cubic spline (:class:`scipy.interpolate.CubicSpline`, not-a-knot;
    interpolation error ~ (w h)^4 / 384, 1e-9 of the amplitude) and read at
    t_k - tau. Before t = 0 the rod rests at the bias displacement.
    """
    t = np.asarray(time, dtype=float)
    y = np.asarray(displacement, dtype=float)
    # the record's first sample is the rest state before the step: spline from
    # the second sample on, so the start jump does not ring into the record
    spline = CubicSpline(t[1:], y[1:])
    ts = t - delay
    out = np.full(t.size, bias_displacement(params))
    inside = ts >= t[1]
    out[inside] = spline(ts[inside])
    # between the rest state and the first settled sample: linear
    ramp = (ts >= t[0]) & ~inside
    out[ramp] = np.interp(ts[ramp], t[:2], y[:2])
    return out


# ----------------------------------------------------------------- the runs


def run_name(frequency, current_amplitude) -> str:
    """Run label, e.g. ``f050_I1.0``."""
    return f"f{int(round(frequency)):03d}_I{current_amplitude:.1f}"


def generate_runs(effect=None, *, seed=0, strength=1.0, noise_um=0.05, voltage_noise=0.01,
                  frequencies=(5, 20, 50, 100, 150, 200), amplitudes=(0.5, 1.0), cycles=8,
                  samples_per_cycle=256, params=None, current_noise=1e-3, jitter=0.2,
                  amplifier_gain=1.0) -> list[Run]:
    """Synthetic measured runs of the paper's model plus one hidden effect.

    Parameters
    ----------
    effect : str or None
        One of :data:`EFFECTS`, or ``None`` for the paper's model alone.
    seed : int
        Seeds the noise and offsets (``numpy.random.default_rng(seed)``) and,
        through a separate stream, the effect's jittered parameters.
    strength : float
        Size of the effect, >= 0: 0 is none (the paper's model exactly), 1
        clearly visible (see :func:`truth_parameters`).
    noise_um : float
        Standard deviation of the displacement noise, [um].
    voltage_noise : float
        Standard deviation of the sensing-coil voltage noise, [V].
    frequencies : sequence of float
        Excitation frequencies, [Hz] (each within the calibration's reach).
    amplitudes : sequence of float
        Current amplitudes I_m, [A].
    cycles : float
        Periods per run (cycles * samples_per_cycle samples).
    samples_per_cycle : int
        Samples per period.
    params : gmt.TransducerParameters, optional
        The transducer; default Table 2.
    current_noise : float
        Standard deviation of the current-measurement noise, [A].
    jitter : float
        Relative spread of the effect's parameters between seeds.
    amplifier_gain : float
        K_a, [A/V]: the control signal is u = i / K_a.

    Returns
    -------
    list of Run
        One per (f, I_m), frequency-major, named by :func:`run_name`;
        ``meta`` holds the truth: effect, strength, seed, the effect's
        parameters (``truth``), the offset, the noise levels, I_m.
    """
    p = params or gmt.TransducerParameters()
    truth = truth_parameters(effect, strength, seed=seed, jitter=jitter, params=p)
    if int(cycles * samples_per_cycle) < samples_per_cycle + 1 or samples_per_cycle < 8:
        raise ValueError(f"cycles = {cycles!r}, samples_per_cycle = {samples_per_cycle!r}: "
                         "a run needs at least one period of at least 8 samples")
    rng = np.random.default_rng(seed)
    y_bias = bias_displacement(p)
    runs = []
    for f in frequencies:
        for im in amplitudes:
            r = true_response(effect, truth, p, f, im, cycles, samples_per_cycle)
            n = r["time"].size
            # draw in a fixed order, whatever the effect or noise levels
            offset = rng.uniform(-OFFSET_RANGE, OFFSET_RANGE)
            e_i = rng.standard_normal(n)
            e_y = rng.standard_normal(n)
            e_v = rng.standard_normal(n)
            voltage = induced_voltage(r["flux_density_rate"], p.sense_turns,
                                                  p.sense_area)
            meta = {"effect": effect, "strength": float(strength), "seed": seed,
                    "truth": dict(truth), "offset": offset,
                    "current_amplitude": float(im),
                    "noise": {"displacement": noise_um * 1e-6, "sense_voltage": voltage_noise,
                              "current": current_noise},
                    "amplifier_gain": amplifier_gain}
            if "temperature_rise" in r:
                meta["final_temperature_rise"] = float(r["temperature_rise"][-1])
            runs.append(Run(
                name=run_name(f, im), frequency=float(f), time=r["time"],
                current=r["current"] + current_noise * e_i,
                displacement=r["displacement"] - y_bias + offset + noise_um * 1e-6 * e_y,
                sense_voltage=voltage + voltage_noise * e_v,
                control=r["current"] / amplifier_gain,
                source=f"synthetic(effect={effect!r}, seed={seed}, strength={strength:g})",
                meta=meta))
    return runs
