"""Second formulations of the six effects, from literature other than the first ones'.

Each class is a physically different account of the same effect, with the same physical
class (the magnetic ones change B, the mechanical and sensor ones leave the magnetics
alone) and a strength 1 of similar visibility (0.5-3 um RMS change of y at 100 Hz, 1 A).
They answer the same questions the first formulations do (module ``effects``), so the
simulator treats both alike. Sources and reasoning are in README.md.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from . import jiles_atherton as ja
from . import preisach
from . import lti, rod
from .anhysteretic import (arctangent, arctangent_inverse, brillouin, frohlich_kennelly,
                          frohlich_kennelly_inverse, mean_field_langevin)
from .constants import LabsimError


@dataclass(frozen=True)
class JilesAtherton:
    """Pinned-wall hysteresis after Jiles and Atherton (1986), added to the paper's
    magnetisation (module ``jiles_atherton``); input the field H_eff, offset H_0."""

    saturation: float  # M_s of the pinned-wall population: 12 kA/m at strength 1, [A/m]
    shape: float = 12e3  # a of its Langevin anhysteretic, [A/m]
    pinning: float = 3e3  # k, [A/m]
    reversibility: float = 0.2  # c, [-]
    offset: float = 4e3  # H_0, operating point on M_an (asymmetric loops), [A/m]

    @staticmethod
    def at(strength: float) -> "JilesAtherton":
        # k ~ 3 kA/m and c ~ 0.2: the order of published Jiles-Atherton fits to Terfenol-D
        # (e.g. Dapino, Smith, Calkins and Flatau, a magnetoelastic model of Villari-effect
        # Terfenol-D sensors built on Jiles-Atherton, J. Intell. Mater. Syst. Struct., 2002);
        # the model is linear in M_s (no mean field), so the strength scales M_s.
        return JilesAtherton(12e3 * strength)

    @property
    def model(self) -> ja.Model:
        return ja.Model(self.saturation, self.shape, self.pinning, self.reversibility,
                        self.offset)

    phase_points = 8192

    def periodic(self, amplitude: float, phase: np.ndarray) -> np.ndarray:
        """Added magnetisation on the closed loop at u = A cos(phase), [A/m]."""
        return ja.periodic_branches(self.model, _loop(self.model, amplitude), phase)

    def sequence(self, u: np.ndarray) -> np.ndarray:
        """Added magnetisation for the field samples u from the switch-on, [A/m]."""
        return ja.sequence(self.model, u)

    def window(self, omega: float, amplitude: float) -> float:
        """Time after the switch-on when the loop has closed to 1e-15 M_s, [s]."""
        cycles = _loop(self.model, amplitude).cycles_to_settle(self.model)
        return (cycles + 1.25) * 2.0 * math.pi / omega


@functools.lru_cache(maxsize=64)
def _loop(model: ja.Model, amplitude: float) -> ja.Loop:
    return ja.periodic_loop(model, amplitude)


@dataclass(frozen=True)
class FroehlichKennelly:
    """Saturation of the magnetisation curve by the Froehlich-Kennelly law
    M = M_s H / (a + |H|), of which the paper's linear magnetisation is the tangent at the
    bias point (M_b): the small-signal gain is kept; large signals bend with the concave
    curve (rises compressed, falls deepened)."""

    saturation_magnetization: float  # M_s: 0.5 MA/m at strength 1, -> M_b as s -> inf, [A/m]

    @staticmethod
    def at(strength: float) -> "FroehlichKennelly":
        # M_s = M_b_ref + (0.5 MA/m - M_b_ref) / s with M_b_ref = 250 kA/m (Table 2): no
        # saturation as s -> 0. At s = 1 the bias sits at x_b = 1 (M_b = M_s / 2), i.e. the
        # bias field equals the law's a; with the paper's quasi-static susceptibility (~4.3
        # at 5 Hz) that is H_b = M_b / (2 chi) ~ 29 kA/m, a usual magnet bias for Terfenol-D.
        # The law's slow approach leaves the material's 0.8 MA/m to large fields.
        return FroehlichKennelly(250e3 + (0.5e6 - 250e3) / strength)

    def saturate(self, m, bias: float):
        """Total magnetisation for the paper's M_b + M: M_b + g(M), g(0) = 0, g'(0) = 1, [A/m].

        With x_b the bias point on the law (f(x_b) = M_b / M_s) and f'(x_b) its slope,
        g(M) = M_s [f(x_b + M / (M_s f'(x_b))) - f(x_b)].
        """
        m_s = self.saturation_magnetization
        if not bias < m_s:
            raise LabsimError(f"Froehlich-Kennelly saturation: M_s = {m_s:.6g} A/m must exceed "
                              f"the bias magnetisation {bias:.6g} A/m")
        x_b = frohlich_kennelly_inverse(bias / m_s)
        slope = 1.0 / (1.0 + abs(x_b)) ** 2
        return m_s * frohlich_kennelly(x_b + (np.asarray(m) - bias) / (m_s * slope))


@dataclass(frozen=True)
class Brillouin:
    """Saturation by the Brillouin law of moments with angular momentum J (Kittel, ch. 11)
    on the total magnetisation, unit slope at 0 as the first formulation's Langevin law:
    M_tot = M_s B_J(3 J / (J + 1) (M_b + M) / M_s)."""

    saturation_magnetization: float  # M_s = 0.8 MA/m / strength, [A/m]
    angular_momentum: float = 2.0    # J, [-] (1/2: tanh; -> infinity: Langevin)

    @staticmethod
    def at(strength: float) -> "Brillouin":
        return Brillouin(0.8e6 / strength)

    def saturate(self, m, bias: float):
        """M_tot for the paper's M_b + M (the bias does not enter the law), [A/m]."""
        m_s, j = self.saturation_magnetization, self.angular_momentum
        return m_s * brillouin(j, 3.0 * j / (j + 1.0) * np.asarray(m) / m_s)


@dataclass(frozen=True)
class Arctangent:
    """Saturation by the arctangent law f(x) = (2 / pi) atan(pi x / 2), of which the
    paper's linear M is the tangent at the bias, as the Froehlich-Kennelly formulation:
    M_tot = M_b + M_s [f(x_b + M / (M_s f'(x_b))) - f(x_b)], f(x_b) = M_b / M_s."""

    saturation_magnetization: float  # M_s: 0.45 MA/m at strength 1, -> inf as s -> 0, [A/m]

    @staticmethod
    def at(strength: float) -> "Arctangent":
        return Arctangent(250e3 + (0.45e6 - 250e3) / strength)

    def saturate(self, m, bias: float):
        """Total magnetisation for the paper's M_b + M, [A/m]."""
        m_s = self.saturation_magnetization
        if not bias < m_s:
            raise LabsimError(f"arctangent saturation: M_s = {m_s:.6g} A/m must exceed "
                              f"the bias magnetisation {bias:.6g} A/m")
        x_b = arctangent_inverse(bias / m_s)
        slope = 1.0 / (1.0 + (0.5 * np.pi * x_b) ** 2)
        return m_s * arctangent(x_b + (np.asarray(m) - bias) / (m_s * slope))


@dataclass(frozen=True)
class MeanFieldLangevin:
    """Saturation by the Langevin law with the domains' mean field (Jiles and Atherton
    1986): a knee sharper than any law of independent moments, unit slope at 0:
    M_tot = M_s m, m = L(3 ((1 - alpha) (M_b + M) / M_s + alpha m))."""

    saturation_magnetization: float  # M_s = 1.2 MA/m / strength, [A/m]
    coupling: float = 0.6            # alpha, [-], in [0, 1)

    @staticmethod
    def at(strength: float) -> "MeanFieldLangevin":
        return MeanFieldLangevin(1.2e6 / strength)

    def saturate(self, m, bias: float):
        """M_tot for the paper's M_b + M (the bias does not enter the law), [A/m]."""
        m_s = self.saturation_magnetization
        return m_s * mean_field_langevin(np.asarray(m) / m_s, self.coupling)


@dataclass(frozen=True)
class ConductingHousing:
    """Eddy currents in a conducting housing (coil former, tube) around the coil: a shorted
    turn. The field in the rod follows H_eff = F(s) H, F(s) = 1 - kappa s tau / (1 + s tau)
    (``lti.shorted_turn``); the rod itself is taken as laminated (no diffusion in it)."""

    time_constant: float  # tau = L_h / R_h of the housing loop: 0.3 ms at strength 1, [s]
    coupling: float = 0.5  # kappa, fraction of the rod's flux path linked by the loop, [-]

    @staticmethod
    def at(strength: float) -> "ConductingHousing":
        # an aluminium former around the rod (wall 1 mm, d ~ 30 mm, l = 80 mm: R_h ~ 35 uOhm)
        # linking the rod's flux (mu_r ~ 4) and the air inside it: tau ~ 0.1-0.5 ms
        return ConductingHousing(0.3e-3 * strength)

    def transfer(self) -> lti.Modal:
        return lti.shorted_turn(self.time_constant, self.coupling)


@dataclass(frozen=True)
class Diffusion:
    """Eddy currents diffusing into the rod, by default acting on the magnetisation: the
    rod's M (the paper's) is filtered by the mean-flux transfer of a lamination (slab,
    tanh(q)/q) or of the solid rod (cylinder, 2 I_1(q)/(q I_0(q))); the applied field H, and
    with it the hysteresis input and B's mu_0 H term, are not. ``acts_on="field"`` filters
    H instead, as the first formulation does (so M and B follow)."""

    diffusion_time: float  # tau: slab mu sigma d^2 / 4, cylinder mu sigma a^2, [s]
    geometry: str = "slab"  # "slab" or "cylinder"
    acts_on: str = "magnetization"  # or "field"

    def __post_init__(self) -> None:
        if self.geometry not in ("slab", "cylinder") or self.acts_on not in ("magnetization",
                                                                             "field"):
            raise LabsimError(f"eddy diffusion: geometry = {self.geometry!r}, acts_on = "
                              f"{self.acts_on!r}; must be 'slab' or 'cylinder', "
                              "'magnetization' or 'field'")

    @staticmethod
    def slab(strength: float) -> "Diffusion":
        # tau = 0.5 ms at strength 1 (lag omega tau / 3 = 5.5 deg at 100 Hz): plates 5 mm
        # thick (two across the 10-mm rod) of Terfenol-D (sigma ~ 1.7 MS/m) give
        # 13 us x mu_r, so 0.5 ms needs mu_r ~ 37; with the paper's |mu| ~ 3-4 they give
        # ~0.05 ms (strength ~0.1): strength 1 stands for a slower flux path, as for the
        # first formulation
        return Diffusion(0.5e-3 * strength, "slab")

    @staticmethod
    def cylinder(strength: float) -> "Diffusion":
        # the first formulation's solid rod, tau = mu sigma a^2 = 1 ms at strength 1 (lag
        # omega tau / 8), acting on M only
        return Diffusion(1.0e-3 * strength, "cylinder")

    @staticmethod
    def random(strength: float, seed: int | None = None) -> "Diffusion":
        """Geometry (slab or cylinder) and target (M or H) drawn per seed, tau the
        geometry's strength-1 value times exp(N(0, 0.3))."""
        rng = np.random.default_rng(np.random.SeedSequence(0 if seed is None else seed,
                                                           spawn_key=(1803,)))
        geometry = ("slab", "cylinder")[int(rng.integers(2))]
        acts_on = ("magnetization", "field")[int(rng.integers(2))]
        base = 0.5e-3 if geometry == "slab" else 1.0e-3
        tau = base * strength * float(np.exp(0.3 * rng.standard_normal()))
        return Diffusion(tau, geometry, acts_on)

    def transfer(self) -> lti.Modal:
        if self.geometry == "slab":
            return lti.slab_diffusion(self.diffusion_time)
        return lti.cylinder_diffusion(self.diffusion_time)


@dataclass(frozen=True)
class BesselSensor:
    """The displacement sensor's conditioning chain as a Bessel low-pass (maximally flat
    group delay): a near-constant delay with a small amplitude roll-off, instead of a pure
    delay."""

    group_delay: float  # tau_g at DC: 100 us at strength 1, [s]
    order: int = 2

    @staticmethod
    def at(strength: float) -> "BesselSensor":
        # order 2 with tau_g = 100 us: -3 dB at 2.17 kHz, the bandwidth of a typical LVDT or
        # eddy-current displacement-sensor conditioner
        return BesselSensor(100e-6 * strength)

    delay = 0.0  # no pure delay

    def sensor(self) -> lti.Zpk:
        return lti.bessel(self.order, self.group_delay)


@dataclass(frozen=True)
class ContinuumRod:
    """The rod as a 1-D elastic continuum (density from the paper's m by the one-third rule,
    Young's modulus E^H) fixed at its base, driving a load mass M_L at its tip; the sensor
    on the tip (module ``rod``)."""

    load_mass: float  # M_L: 2.5 kg at strength 1, [kg]
    loss_rate: float = 2000.0  # decay rate d / (2 rho) of the rod's own modes, [1/s]
    elements: int = 16  # finite elements along the rod

    @staticmethod
    def at(strength: float) -> "ContinuumRod":
        # M_L = 2.5 kg: piston, end plate and the reflected inertance of the oil column of a
        # pump, which puts the first mode near 440 Hz; the rod's own modes (9 kHz and up)
        # decay at 2000 1/s (Q ~ 14 at 9 kHz; Terfenol-D's mechanical Q is ~3-20)
        return ContinuumRod(2.5 * strength)

    def mechanics(self, transducer) -> lti.Modal:
        return rod.tip_response(transducer, self.load_mass, self.loss_rate, self.elements)


@dataclass(frozen=True)
class MagnetWarming:
    """The bias magnet warms: M_b(T) = M_b (1 + alpha_B dT_m), alpha_B the reversible
    temperature coefficient of an NdFeB magnet; dT_m(t) from a two-node thermal network,
    coil -> magnet -> ambient, with the coil loss P (I_m / 1 A)^2 switched on at t = 0."""

    coil_initial: float  # dT_c(0): 80 K at strength 1, [K]
    magnet_initial: float  # dT_m(0): 40 K at strength 1, [K]
    loss_1A: float  # coil loss at I_m = 1 A (R_coil I_m^2 / 2): 15 W at strength 1, [W]
    coil_to_magnet: float = 2.0  # R_cm, [K/W]
    magnet_to_ambient: float = 4.0  # R_ma, [K/W]
    coil_capacity: float = 30.0  # C_c, [J/K]
    magnet_capacity: float = 5.0  # C_m, [J/K]
    temperature_coefficient: float = -0.0012  # alpha_B of the remanence, [1/K]

    @staticmethod
    def at(strength: float) -> "MagnetWarming":
        # NdFeB: alpha(B_r) ~ -0.11 to -0.12 %/K (reversible; e.g. Coey, Magnetism and
        # Magnetic Materials, 2010, ch. 11). The coil is hotter than the magnet at the run's
        # start (after the previous runs), so the magnet warms at ~2 K/s at first.
        return MagnetWarming(80.0 * strength, 40.0 * strength, 15.0 * strength)

    def magnet_temperature(self, current_amplitude: float):
        """dT_m(t) = final + sum_i coefficient_i exp(-rate_i t): (final [K], rates [1/s],
        coefficients [K])."""
        c_c, c_m = self.coil_capacity, self.magnet_capacity
        r_cm, r_ma = self.coil_to_magnet, self.magnet_to_ambient
        system = np.array([[-1.0 / (r_cm * c_c), 1.0 / (r_cm * c_c)],
                           [1.0 / (r_cm * c_m), -1.0 / (r_cm * c_m) - 1.0 / (r_ma * c_m)]])
        power = self.loss_1A * current_amplitude**2
        final = np.array([power * (r_cm + r_ma), power * r_ma])
        start = np.array([self.coil_initial, self.magnet_initial])
        eigenvalues, vectors = np.linalg.eig(system)
        weights = np.linalg.solve(vectors, start - final)
        return float(final[1]), -eigenvalues.real, vectors[1].real * weights.real

    def bias_drift(self, current_amplitude: float):
        """Relative change of M_b, eps(t) = alpha_B dT_m(t): (final, rates, coefficients)."""
        final, rates, coefficients = self.magnet_temperature(current_amplitude)
        alpha = self.temperature_coefficient
        return alpha * final, rates, alpha * coefficients


@dataclass(frozen=True)
class GeneralPreisach:
    """The classical Preisach model (Mayergoyz 1991) with a general density of relays over
    (coercive field, loop centre), added to the paper's magnetisation (module ``preisach``);
    input the field H_eff. The populations switch fully within the drive's field amplitude
    at 0.6 and 1 A, so the added magnetisation saturates on each branch."""

    saturation: float  # M_s of the relay population: see PREISACH_SATURATION, [A/m]
    density: preisach.Density
    shape: str = "lognormal_normal"

    phase_points = 8192

    def periodic(self, amplitude: float, phase: np.ndarray) -> np.ndarray:
        """Added magnetisation on the closed loop at u = A cos(phase), [A/m]."""
        return 2.0 * self.saturation * preisach.steady_loop(self.density, amplitude)(phase)

    def sequence(self, u: np.ndarray) -> np.ndarray:
        """Added magnetisation for the field samples u from the switch-on, [A/m]."""
        return preisach.sequence(self.density, self.saturation, u)

    def window(self, omega: float, amplitude: float) -> float:
        """Time after the switch-on when the state is periodic: both extremes swept, [s]."""
        return 1.25 * 2.0 * math.pi / omega

    @staticmethod
    def of_shape(shape: str, strength: float) -> "GeneralPreisach":
        return GeneralPreisach(PREISACH_SATURATION * strength,
                               preisach.Density(PREISACH_SHAPES[shape]), shape)

    @staticmethod
    def random(strength: float, seed: int | None = None) -> "GeneralPreisach":
        """A shape drawn per seed with its fields scaled by factors exp(N(0, 0.15)) and an
        offset of the loop centres uniform in +-0.8 kA/m."""
        rng = np.random.default_rng(np.random.SeedSequence(0 if seed is None else seed,
                                                           spawn_key=(1801,)))
        shape = list(PREISACH_SHAPES)[int(rng.integers(len(PREISACH_SHAPES)))]
        scale = float(np.exp(0.15 * rng.standard_normal()))
        offset = float(rng.uniform(-800.0, 800.0))
        populations = tuple(
            preisach.Population(p.weight, p.coercive_median * scale,
                                p.coercive_spread * float(np.exp(0.15 * rng.standard_normal())),
                                p.centre + offset, p.width * scale, p.width_slope, p.law)
            for p in PREISACH_SHAPES[shape])
        return GeneralPreisach(PREISACH_SATURATION * strength, preisach.Density(populations),
                               f"random:{shape}")


#: M_s of the relay population at strength 1: the relays then add 9-14 % third harmonic to
#: B and y at 1 A (README.md), as saturating Preisach hysteresis does in Terfenol-D's minor
#: loops; an assumption of this generator, [A/m].
PREISACH_SATURATION = 12e3
P = preisach.Population
#: Relay densities (coercive median [A/m], log-spread, centre [A/m], width [A/m], slope, law):
#: most of the relays switch inside the 0.6 A drive's +-8.9 kA/m.
PREISACH_SHAPES = {
    # factorised: lognormal coercive fields times normal centres, symmetric loops
    "lognormal_normal": (P(1.0, 2.5e3, 0.35, 0.0, 1.2e3),),
    # two populations, soft and hard, with opposite centre offsets: asymmetric loops
    "bimodal": (P(0.45, 1.2e3, 0.30, -500.0, 0.8e3), P(0.55, 4.5e3, 0.20, 800.0, 1.0e3)),
    # not factorised: the centres' spread grows with the coercive field; offset centres
    "correlated": (P(1.0, 2.5e3, 0.40, 600.0, 0.4e3, 0.45),),
    # Lorentzian (Cauchy) interaction fields: heavy tails, some relays never switch
    "lorentzian": (P(1.0, 2.5e3, 0.35, 0.0, 0.6e3, 0.0, "cauchy"),),
}
del P
