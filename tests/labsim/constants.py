"""Physical constants of the transducer, typed in from the source paper.

Every number below is typed from the paper's tables (Li et al., "Modeling and inverse
compensation for giant magnetostrictive transducer applied in smart material
electrohydrostatic actuator", Tables 1 and 2) or from a textbook, converted to SI by hand.
Nothing is imported from the project's packages: this generator must stay independent of
the code it is used to test.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

#: Permeability of free space, [H/m] (4 pi 1e-7; the 2019 SI value differs by 5e-10 relative).
MU_0 = 4.0e-7 * math.pi


class LabsimError(ValueError):
    """A bad argument to the generator; the message names the parameter, value and range."""


@dataclass(frozen=True)
class Transducer:
    """The giant magnetostrictive transducer of the paper, Table 2 in SI.

    E^H is not in Table 2: the rod stiffness K = E^H A_r / L of a rod in tension-compression
    gives E^H = K L / A_r = 20.0 GPa with Table 2's K, L and d (a typical Terfenol-D value).
    """

    rod_diameter: float = 10e-3  # d = 10 mm, Table 2, [m]
    rod_length: float = 80e-3  # L = 80 mm, Table 2, [m]
    mass: float = 0.02  # m = 0.02 kg, Table 2, [kg]
    damping: float = 2945.0  # c = 2945 N s/m, Table 2, [N s/m]
    stiffness: float = 1.963e7  # K = 1.963e7 N/m, Table 2, [N/m]
    bias_magnetization: float = 250e3  # M_b = 250 kA/m, Table 2, [A/m]
    coil_turns: float = 1300.0  # N = 1300, Table 2, [-]
    hysteresis_coefficient: float = 85805.0  # K_h, Table 2, [W s/(m^3 T^n)]
    steinmetz_exponent: float = 1.8092  # n, Table 2, [-]
    eddy_coefficient: float = 2753.39  # K_e, Table 2, [W s^2/(m^3 T^2)]
    excess_coefficient: float = 895.80  # K_ex, Table 2, [W s^1.5/(m^3 T^1.5)]
    magnetostriction_coefficient: float = 1.4694e-14  # K_lambda, Table 2, [m^2/A^2]
    sense_turns: float = 150.0  # N_c = 150, Table 2, [-]
    sense_area: float = 380e-6  # A_c = 380 mm^2, Table 2 (d_c = 22 mm), [m^2]
    leakage_coefficient: float = 1.1  # k_f, Table 2, [-]

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if not (math.isfinite(value) and value > 0.0):
                raise LabsimError(f"Transducer.{field.name} = {value!r}: must be finite and > 0")

    @property
    def rod_area(self) -> float:
        """Rod cross-section A_r = pi d^2 / 4, [m^2]."""
        return math.pi * self.rod_diameter**2 / 4.0

    @property
    def youngs_modulus(self) -> float:
        """E^H = K L / A_r, [Pa] (about 20 GPa)."""
        return self.stiffness * self.rod_length / self.rod_area

    @property
    def force_per_strain(self) -> float:
        """A_r E^H of eq 28 (= K L), [N]."""
        return self.rod_area * self.youngs_modulus

    def jittered(self, factors: dict[str, float]) -> "Transducer":
        """A copy with some parameters multiplied by the given factors."""
        return replace(self, **{name: getattr(self, name) * k for name, k in factors.items()})


#: Table 1 of the paper: (f [Hz], I_m [A], B_m [T]) measured with the sensing coil (eq 22).
TABLE_1 = (
    (5.0, 0.5, 0.0300),
    (5.0, 0.7, 0.0530),
    (50.0, 1.0, 0.0637),
    (70.0, 1.0, 0.0590),
    (80.0, 1.0, 0.0570),
    (100.0, 1.0, 0.0531),
)

#: Stated in the paper's text: uncompensated peak-to-peak displacement at I_m = 1 A, [m].
PEAK_TO_PEAK_1A = {50.0: 46e-6, 100.0: 36e-6}

#: Parameters of this generator's amplitude-permeability law (module ``bmlaw``), fitted once by
#: the labsim author to Table 1 (least squares on log B_m, 6 points, 4 parameters; largest
#: deviation 1.43 %, at 100 Hz) and typed in here rounded to 4 digits.
RAYLEIGH_INITIAL = 1.148  # mu_i, relative amplitude permeability as H_m -> 0, [-]
RAYLEIGH_SLOPE = 2.878e-4  # eta, Rayleigh coefficient of the amplitude permeability, [m/A]
RELAXATION_FREQUENCY = 27.52  # f_r, Debye relaxation frequency, [Hz]
RELAXED_FRACTION = 0.4846  # rho = mu(f >> f_r) / mu(f -> 0), [-]
