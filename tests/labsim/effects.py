"""The six physical effects, each scaled by a ``strength`` (0 = absent, 1 = the reference
magnitude below), and their physical parameters.

The values at strength 1 are physically plausible and chosen so that each effect changes the
displacement by roughly 0.5-3 um RMS at 100 Hz, 1 A (measured figures in README.md). The
formulations are this generator's own; see README.md for their literature sources.

Every effect has two formulations (``FORMULATIONS``): the first ones below, and second ones
from other literature in module ``alternatives``; hysteresis and eddy currents have further
textbook ones (general Preisach densities, diffusion acting on the magnetisation), chosen by
name only. Each class answers the simulator's
questions for its effect: hysteresis ``periodic``/``sequence``/``window``, saturation
``saturate``, eddy currents ``transfer``, sensor ``delay``/``sensor``, mechanics
``mechanics``; the thermal drifts act through the force (``Thermal``) or the bias
(``bias_drift``).
"""
from __future__ import annotations

import functools
import inspect
import math
from dataclasses import asdict, dataclass

import numpy as np

from . import alternatives, lti
from .anhysteretic import langevin
from .constants import LabsimError
from .hysteresis import periodic_branches, play_sequence
from .outside import FACTORIES as OUTSIDE_FACTORIES
from .outside import OUTSIDE_EFFECTS

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

    phase_points = 8192

    def periodic(self, amplitude: float, phase: np.ndarray) -> np.ndarray:
        """Added magnetisation on the closed loop at u = A cos(phase), [A/m]."""
        return periodic_branches(amplitude, phase, self.susceptibility, self.threshold_scale)

    def sequence(self, u: np.ndarray) -> np.ndarray:
        """Added magnetisation for the field samples u from the switch-on, [A/m]."""
        return play_sequence(u, self.susceptibility, self.threshold_scale)

    def window(self, omega: float, amplitude: float) -> float:
        """Time after the switch-on when the state is periodic: both extremes swept, [s]."""
        return 1.25 * 2.0 * math.pi / omega


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

    def saturate(self, m, bias: float):
        """M_tot for the paper's M_b + M (the bias does not enter the law), [A/m]."""
        m_s = self.saturation_magnetization
        return m_s * langevin(3.0 * m / m_s)


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

    def transfer(self) -> lti.Modal:
        return lti.cylinder_diffusion(self.diffusion_time)


@dataclass(frozen=True)
class Delay:
    """A pure delay of the displacement sensor chain (sensor electronics, demodulator)."""

    delay: float  # tau = 100 us at strength 1, [s]

    @staticmethod
    def at(strength: float) -> "Delay":
        return Delay(100e-6 * strength)

    def sensor(self) -> None:
        return None  # no filter, only the delay


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

    def mechanics(self, transducer) -> lti.Zpk:
        return lti.two_mass(transducer.mass, transducer.damping, transducer.stiffness,
                            self.out_mass, self.out_damping, self.out_stiffness)


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


#: Formulations of each effect, the first being the default; ``formulation="alt"`` picks the
#: second for every effect (README.md, "Second formulations"); the others are chosen by name
#: (README.md, "Textbook formulations").
FORMULATIONS = {
    "rate_independent_hysteresis": {
        "preisach": Hysteresis.at,
        "jiles_atherton": alternatives.JilesAtherton.at,
        "general_preisach": functools.partial(alternatives.GeneralPreisach.of_shape,
                                              "lognormal_normal"),
        "preisach_bimodal": functools.partial(alternatives.GeneralPreisach.of_shape, "bimodal"),
        "preisach_correlated": functools.partial(alternatives.GeneralPreisach.of_shape,
                                                 "correlated"),
        "preisach_lorentzian": functools.partial(alternatives.GeneralPreisach.of_shape,
                                                 "lorentzian"),
        "preisach_random": alternatives.GeneralPreisach.random,
    },
    "magnetization_saturation": {"langevin": Saturation.at,
                                 "froehlich_kennelly": alternatives.FroehlichKennelly.at,
                                 "brillouin": alternatives.Brillouin.at,
                                 "arctangent": alternatives.Arctangent.at,
                                 "mean_field_langevin": alternatives.MeanFieldLangevin.at},
    "eddy_current_diffusion": {
        "solid_rod": EddyDiffusion.at,
        "conducting_housing": alternatives.ConductingHousing.at,
        "slab_magnetization": alternatives.Diffusion.slab,
        "solid_rod_magnetization": alternatives.Diffusion.cylinder,
        "diffusion_random": alternatives.Diffusion.random,
    },
    "transport_delay": {"pure_delay": Delay.at, "bessel_sensor": alternatives.BesselSensor.at},
    "mechanical_resonance": {"two_mass": Resonance.at,
                             "continuum_rod": alternatives.ContinuumRod.at},
    "thermal_drift": {"strain_and_expansion": Thermal.at,
                      "magnet_bias": alternatives.MagnetWarming.at},
}
_FIELDS = {
    "rate_independent_hysteresis": "hysteresis",
    "magnetization_saturation": "saturation",
    "eddy_current_diffusion": "eddy",
    "transport_delay": "delay",
    "mechanical_resonance": "resonance",
    "thermal_drift": "thermal",
}


def resolve_formulations(formulation: str = "default", formulations=None) -> dict:
    """{effect: formulation name} for every effect from ``formulation`` ("default" or "alt",
    for all effects) and per-effect choices ``formulations`` ({effect: name or "default" or
    "alt"}), which take precedence."""
    if formulation not in ("default", "alt"):
        raise LabsimError(f"formulation = {formulation!r}: must be 'default' or 'alt'")
    index = 0 if formulation == "default" else 1
    chosen = {name: list(forms)[index] for name, forms in FORMULATIONS.items()}
    for name, value in (formulations or {}).items():
        if name not in FORMULATIONS:
            raise LabsimError(f"formulations: effect {name!r} unknown; known effects: "
                              f"{', '.join(EFFECTS)}")
        forms = list(FORMULATIONS[name])
        if value in ("default", "alt"):
            value = forms[0 if value == "default" else 1]
        if value not in forms:
            raise LabsimError(f"formulations[{name!r}] = {value!r}: must be one of "
                              f"{', '.join(forms)}, 'default' or 'alt'")
        chosen[name] = value
    return chosen


@dataclass(frozen=True)
class EffectSet:
    """The effects of one dataset with their physical parameters (None = absent)."""

    strengths: tuple[tuple[str, float], ...] = ()
    hysteresis: object | None = None
    saturation: object | None = None
    eddy: object | None = None
    delay: object | None = None
    resonance: object | None = None
    thermal: object | None = None
    formulations: tuple[tuple[str, str], ...] = ()
    outside: tuple[tuple[str, object], ...] = ()  # effects outside the six (``outside``)

    @staticmethod
    def from_strengths(effects, formulation: str = "default", formulations=None,
                       seed: int | None = None) -> "EffectSet":
        """Validate {name: strength} (or an iterable of names, strength 1) and build with the
        chosen formulations (``resolve_formulations``); formulations drawn per seed (their
        factory takes ``seed``) get ``seed``."""
        chosen = resolve_formulations(formulation, formulations)
        if effects is None:
            effects = {}
        if isinstance(effects, str):
            effects = {effects: 1.0}
        if not isinstance(effects, dict):
            effects = {name: 1.0 for name in effects}
        built, strengths, extra = {}, [], []
        for name, strength in effects.items():
            if name not in FORMULATIONS and name not in OUTSIDE_EFFECTS:
                raise LabsimError(f"effect {name!r}: unknown; known effects: {', '.join(EFFECTS)}"
                                  f" and, outside them, {', '.join(OUTSIDE_EFFECTS)}")
            strength = float(strength)
            if not (math.isfinite(strength) and 0.0 <= strength <= 10.0):
                raise LabsimError(f"effect {name!r}: strength = {strength}; allowed 0 to 10")
            strengths.append((name, strength))
            if name in OUTSIDE_EFFECTS:
                if strength > 0.0:
                    extra.append((name, OUTSIDE_FACTORIES[name](strength)))
                continue
            if strength > 0.0:
                factory = FORMULATIONS[name][chosen[name]]
                seeded = "seed" in inspect.signature(factory).parameters
                built[_FIELDS[name]] = (factory(strength, seed=seed) if seeded
                                        else factory(strength))
        used = tuple((name, chosen[name]) for name, _ in strengths if name in chosen)
        return EffectSet(tuple(strengths), formulations=used, outside=tuple(extra), **built)

    def outside_effect(self, name: str):
        """The effect outside the six of this name, or None."""
        return dict(self.outside).get(name)

    @property
    def thermal_bias(self):
        """The thermal drift if it acts through the bias magnetisation, else None."""
        return self.thermal if hasattr(self.thermal, "bias_drift") else None

    def truth(self) -> dict:
        """{name: {"strength", "formulation", "parameters" (SI values)}} for the effects given."""
        chosen = dict(self.formulations)
        out = {}
        for name, s in self.strengths:
            if name in OUTSIDE_EFFECTS:
                effect = self.outside_effect(name)
                out[name] = {"strength": s, "formulation": "outside",
                             "parameters": asdict(effect) if effect is not None else {}}
                continue
            effect = getattr(self, _FIELDS[name])
            out[name] = {"strength": s, "formulation": chosen[name],
                         "parameters": asdict(effect) if effect is not None else {}}
        return out
