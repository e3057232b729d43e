"""The hidden effects and their truth parameters: names, nominal sizes, strength, jitter.

Each effect's parameters at strength 1 (:data:`NOMINAL`) make it clearly visible;
:func:`truth_parameters` scales them with the strength and jitters some of them per
seed, from a stream independent of the noise. Sources of the nominal values: the
package docstring (:mod:`smeha.synthetic`).
"""
from __future__ import annotations

import math

import numpy as np

import gmt
from gmt.constants import MU_0
__all__ = ["EFFECTS", "MAGNETIC_EFFECTS", "NOMINAL", "truth_parameters"]

#: The hidden effects the generator can add (``None`` adds none).
EFFECTS = ("rate_independent_hysteresis", "magnetization_saturation",
           "eddy_current_diffusion", "transport_delay", "mechanical_resonance",
           "thermal_drift")

#: Effects that change B (and so the sensing-coil voltage); the others act on
#: the mechanics, the strain coefficient or the displacement sensor only.
MAGNETIC_EFFECTS = ("rate_independent_hysteresis", "magnetization_saturation",
                    "eddy_current_diffusion")


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
        raise gmt.ParameterError(f"effect = {effect!r} is not one of {EFFECTS} or None")
    s = float(strength)
    if not (s >= 0.0 and math.isfinite(s)):
        raise gmt.ParameterError(f"strength = {strength!r} is outside the allowed range [0, inf)")
    if not 0.0 <= jitter < 0.5:
        raise gmt.ParameterError(f"jitter = {jitter!r} is outside the allowed range [0, 0.5)")
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
            raise gmt.ParameterError(f"output_mass = {m2:g} kg must lie in (0, {p.mass:g}) kg")
        k1 = m2 * (2.0 * math.pi * nominal["joint_frequency"]) ** 2
        t["joint_stiffness"] = math.inf if s == 0.0 else k1 / s
        t["joint_damping"] = (math.inf if s == 0.0 else
                              2.0 * nominal["joint_damping_ratio"] * math.sqrt(k1 / s * m2))
        t["joint_frequency"] = (math.inf if s == 0.0 else nominal["joint_frequency"] / math.sqrt(s))
    elif effect == "thermal_drift":
        t["thermal_resistance"] = s * nominal["thermal_resistance"]
    return t
