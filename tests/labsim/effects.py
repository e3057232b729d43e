"""The six physical effects, each scaled by a ``strength`` (0 = absent, 1 = the reference
magnitude below), and their physical parameters.

The values at strength 1 are physically plausible and chosen so that each effect changes the
displacement by roughly 0.5-3 um RMS at 100 Hz, 1 A (measured figures in README.md). The
formulations are this generator's own; see README.md for their literature sources.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from .constants import LabsimError

EFFECTS = (
    "rate_independent_hysteresis",
    "magnetization_saturation",
    "eddy_current_diffusion",
    "transport_delay",
    "mechanical_resonance",
    "thermal_drift",
)


@dataclass(frozen=True)
class Hysteresis:
    """Play-operator Preisach magnetisation added to the paper's (module ``hysteresis``)."""

    susceptibility: float  # chi_P = 0.25 at strength 1, [-]
    threshold_scale: float = 2000.0  # r_0, mean coercive field of the plays, [A/m]

    @staticmethod
    def at(strength: float) -> "Hysteresis":
        # r_0 = 2 kA/m: of the order of the coercive field of prestressed Terfenol-D
        # (about 1-3 kA/m in published major loops; an assumption here).
        return Hysteresis(0.25 * strength)


@dataclass(frozen=True)
class Saturation:
    """Langevin anhysteretic law for the total magnetisation (Jiles and Atherton, J. Magn.
    Magn. Mater. 61, 1986, 48-60): M_tot = M_s L(3 (M_b + M) / M_s), L(x) = coth x - 1/x.
    Its slope at 0 is 1, so for M_s -> infinity the law is the identity (the paper's model)."""

    saturation_magnetization: float  # M_s = 0.8 MA/m / strength, [A/m]

    @staticmethod
    def at(strength: float) -> "Saturation":
        # Terfenol-D: mu_0 M_s ~ 1.0 T, M_s ~ 0.8 MA/m (Engdahl 2000, ch. 1; Clark 1980).
        return Saturation(0.8e6 / strength)


@dataclass(frozen=True)
class EddyDiffusion:
    """Radial diffusion of the field into the solid rod, F(s) = 2 I_1(q) / (q I_0(q)),
    q = sqrt(s tau), tau = mu sigma a^2 (module ``lti``)."""

    diffusion_time: float  # tau = 1 ms at strength 1, [s]

    @staticmethod
    def at(strength: float) -> "EddyDiffusion":
        # a = 5 mm (Table 2) and sigma ~ 1.7 MS/m (Terfenol-D, ~0.6 uOhm m) give 1 ms with an
        # effective mu_r ~ 19; the rod alone (mu_r ~ 4) would be ~0.2 ms (strength ~0.2).
        return EddyDiffusion(1.0e-3 * strength)


@dataclass(frozen=True)
class Delay:
    """A pure delay of the displacement sensor chain (sensor electronics, demodulator)."""

    delay: float  # tau = 100 us at strength 1, [s]

    @staticmethod
    def at(strength: float) -> "Delay":
        return Delay(100e-6 * strength)


@dataclass(frozen=True)
class Resonance:
    """An output mass m2 (output rod, pump piston, entrained oil) on a compliant coupling
    k2, c2 to the rod tip; the displacement sensor sits on m2 (``lti.two_mass``)."""

    out_mass: float  # m2 = 50 g at strength 1, [kg]
    out_stiffness: float = 3.16e5  # k2, [N/m] (uncoupled mode sqrt(k2/m2)/2pi = 400 Hz at s=1)
    out_damping: float = 25.0  # c2, [N s/m] (Q ~ 5 at strength 1)

    @staticmethod
    def at(strength: float) -> "Resonance":
        return Resonance(0.05 * strength)

    @property
    def uncoupled_frequency(self) -> float:
        """sqrt(k2 / m2) / (2 pi), [Hz]."""
        return math.sqrt(self.out_stiffness / self.out_mass) / (2 * math.pi)


@dataclass(frozen=True)
class Thermal:
    """Coil heating: Delta T(t) = dT_inf + (dT_0 - dT_inf) exp(-t / tau_th) from the drive's
    switch-on, dT_inf ~ I_m^2 (Joule loss R I_m^2 / 2 through a thermal resistance). The
    temperature lowers K_lambda and expands the rod (an offset)."""

    initial_rise: float  # dT_0 = 10 K at strength 1, [K]
    final_rise_1A: float  # dT_inf at I_m = 1 A: 40 K at strength 1, [K]
    time_constant: float = 30.0  # tau_th, [s]
    strain_coefficient: float = -0.005  # d ln K_lambda / dT, [1/K]
    expansion_coefficient: float = 12e-6  # thermal expansion of Terfenol-D, [1/K]

    @staticmethod
    def at(strength: float) -> "Thermal":
        # Terfenol-D: thermal expansion ~ 12 ppm/K (ETREMA data sheet); strain coefficient
        # falling by ~0.5 %/K above room temperature (order of magnitude of Clark's data in
        # Engdahl 2000, ch. 1; an assumption here).
        return Thermal(10.0 * strength, 40.0 * strength)

    def final_rise(self, current_amplitude: float) -> float:
        """dT_inf at this current amplitude (Joule heating ~ I_m^2), [K]."""
        return self.final_rise_1A * current_amplitude**2


_FACTORIES = {
    "rate_independent_hysteresis": Hysteresis.at,
    "magnetization_saturation": Saturation.at,
    "eddy_current_diffusion": EddyDiffusion.at,
    "transport_delay": Delay.at,
    "mechanical_resonance": Resonance.at,
    "thermal_drift": Thermal.at,
}


@dataclass(frozen=True)
class EffectSet:
    """The effects of one dataset with their physical parameters (None = absent)."""

    strengths: tuple[tuple[str, float], ...] = ()
    hysteresis: Hysteresis | None = None
    saturation: Saturation | None = None
    eddy: EddyDiffusion | None = None
    delay: Delay | None = None
    resonance: Resonance | None = None
    thermal: Thermal | None = None

    @staticmethod
    def from_strengths(effects) -> "EffectSet":
        """Validate {name: strength} (or an iterable of names, strength 1) and build."""
        if effects is None:
            effects = {}
        if isinstance(effects, str):
            effects = {effects: 1.0}
        if not isinstance(effects, dict):
            effects = {name: 1.0 for name in effects}
        built, strengths = {}, []
        for name, strength in effects.items():
            if name not in _FACTORIES:
                raise LabsimError(f"effect {name!r}: unknown; known effects: {', '.join(EFFECTS)}")
            strength = float(strength)
            if not (math.isfinite(strength) and 0.0 <= strength <= 10.0):
                raise LabsimError(f"effect {name!r}: strength = {strength}; allowed 0 to 10")
            strengths.append((name, strength))
            if strength > 0.0:
                built[name] = _FACTORIES[name](strength)
        return EffectSet(
            tuple(strengths),
            built.get("rate_independent_hysteresis"),
            built.get("magnetization_saturation"),
            built.get("eddy_current_diffusion"),
            built.get("transport_delay"),
            built.get("mechanical_resonance"),
            built.get("thermal_drift"),
        )

    def truth(self) -> dict:
        """{name: {"strength": s, "parameters": {SI values}}} for the effects present."""
        objects = {
            "rate_independent_hysteresis": self.hysteresis,
            "magnetization_saturation": self.saturation,
            "eddy_current_diffusion": self.eddy,
            "transport_delay": self.delay,
            "mechanical_resonance": self.resonance,
            "thermal_drift": self.thermal,
        }
        return {
            name: {"strength": s, "parameters": asdict(objects[name]) if objects[name] else {}}
            for name, s in self.strengths
        }
