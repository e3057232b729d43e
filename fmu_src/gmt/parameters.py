"""Parameters of the giant magnetostrictive transducer (GMT) and its drive.

All fields are SI. Defaults are the paper's Table 2 (its mm, mm^2 and kA/m
converted to SI); field names are the FMU's variable names, so a
parameter set can be handed to the FMU as start values unchanged.

Three frozen dataclasses, each validated on construction:

* :class:`TransducerParameters` -- the rod, coil, loss and mechanical constants
  (Table 2);
* :class:`Excitation` -- the sinusoidal operating point the complex permeability
  is defined for: frequency, current amplitude and, optionally, the measured
  flux-density amplitude B_m (Table 1);
* :class:`DriveParameters` -- amplifier gain, current limit and the inverse
  compensator's settings (Figure 9).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from .errors import ParameterError, check_range

#: Range accepted for the Steinmetz exponent n of eq 7. The paper states
#: "n varying from 1.5 to 2.5"; identification on other materials can land a
#: little outside, so 1 to 3 is accepted and anything beyond is rejected.
STEINMETZ_RANGE = (1.0, 3.0)

#: Root-selection rules of the inverse compensator (see gmt.inverse).
BRANCH_RULES = ("control", "demand")

#: The compensator's default root rule: the direction of the demanded magnetisation. With
#: it the compensated stroke does not depend on the sample period (within 0.2 % from
#: T_c = 2 us to 100 us at 50 and 100 Hz); Figure 9's literal rule ("control") converges
#: only for T_c <= 10 us, far below a host's communication step (gmt.inverse, "Sampling").
BRANCH_RULE = "demand"

#: Sample period of the digital inverse compensator, [s]: 10 kHz. Figure 9 works on
#: samples u(n), u(n-1) but the paper gives no rate. Digital-control texts sample at 20 to
#: 40 times the highest frequency the loop must reproduce (Franklin, Powell & Workman,
#: *Digital Control of Dynamic Systems*, 3rd ed. 1998, ch. 11). The compensated current
#: at the paper's fastest drive (100 Hz) carries harmonics falling to ~6 % of its
#: fundamental by the fifth (500 Hz; measured on the model): 10 kHz is 20 samples a
#: period of that harmonic and 100 of the fundamental. The zero-order hold delays the
#: current by half a sample (50 us, 1.8 deg at 100 Hz).
COMPENSATOR_PERIOD = 1e-4


@dataclass(frozen=True)
class TransducerParameters:
    """Constants of the transducer, paper Table 2 (SI).

    Attributes
    ----------
    rod_diameter : float
        Diameter d of the Terfenol-D rod, [m].
    rod_length : float
        Length L of the rod, [m] (eq 1).
    mass : float
        Equivalent moving mass m, [kg] (eq 27).
    damping : float
        Equivalent viscous damping c, [N s/m] (eq 27).
    stiffness : float
        Equivalent stiffness K, [N/m] (eq 27).
    bias_magnetization : float
        Bias magnetisation M_b from the permanent magnet, [A/m] (eq 25).
    coil_turns : float
        Excitation coil turns N, [-] (eq 1).
    hysteresis_coefficient : float
        K_h of eq 7, power per volume per B^n per Hz, [W s/(m^3 T^n)].
    steinmetz_exponent : float
        n of eq 7, [-].
    eddy_coefficient : float
        K_e of eq 9, [W s^2/(m^3 T^2)].
    excess_coefficient : float
        K_ex of eq 11, [W s^1.5/(m^3 T^1.5)].
    magnetostriction_coefficient : float
        K_lambda of eq 26, [m^2/A^2].
    sense_turns : float
        Sensing-coil turns N_c, [-] (eq 21).
    sense_area : float
        Sensing-coil cross-section A_c, [m^2] (eq 21): a 22 mm coil, 380 mm^2.
    leakage_coefficient : float
        Flux leakage coefficient k_f, [-] (eq 1), at least 1.
    low_field_hysteresis_coefficient : float
        K'_h of eq 6 for the low-field (Rayleigh) loss law of eq 15,
        [W s/(m^3 (A/m)^3)]. The paper gives no value; 0 (the default) means
        "not identified", and asking for the low-field regime then raises.

    Notes
    -----
    The paper does not give Young's modulus E^H. It is derived from the rod's
    stiffness, E^H = K L / A_r: E^H = 20 GPa reproduces Table 2's K from its rod
    (d = 10 mm, L = 80 mm) to four digits.
    """

    rod_diameter: float = 10e-3
    rod_length: float = 80e-3
    mass: float = 0.02
    damping: float = 2945.0
    stiffness: float = 1.963e7
    bias_magnetization: float = 250e3
    coil_turns: float = 1300.0
    hysteresis_coefficient: float = 85805.0
    steinmetz_exponent: float = 1.8092
    eddy_coefficient: float = 2753.39
    excess_coefficient: float = 895.80
    magnetostriction_coefficient: float = 1.4694e-14
    sense_turns: float = 150.0
    sense_area: float = 380e-6
    leakage_coefficient: float = 1.1
    low_field_hysteresis_coefficient: float = 0.0

    def __post_init__(self):
        positive = {
            "rod_diameter": "m", "rod_length": "m", "mass": "kg",
            "stiffness": "N/m", "coil_turns": "-", "sense_turns": "-",
            "sense_area": "m^2",
            "magnetostriction_coefficient": "m^2/A^2",
        }
        for name, unit in positive.items():
            check_range(name, getattr(self, name), 0.0, math.inf, unit=unit)
        non_negative = {
            "damping": "N s/m", "bias_magnetization": "A/m",
            "hysteresis_coefficient": "W s/(m^3 T^n)",
            "eddy_coefficient": "W s^2/(m^3 T^2)",
            "excess_coefficient": "W s^1.5/(m^3 T^1.5)",
            "low_field_hysteresis_coefficient": "W s/(m^3 (A/m)^3)",
        }
        for name, unit in non_negative.items():
            check_range(name, getattr(self, name), 0.0, math.inf, unit=unit,
                        low_open=False)
        check_range("steinmetz_exponent", self.steinmetz_exponent,
                    *STEINMETZ_RANGE, unit="-", low_open=False, high_open=False)
        check_range("leakage_coefficient", self.leakage_coefficient, 1.0, 10.0,
                    unit="-", low_open=False, high_open=False)

    # -- derived quantities -------------------------------------------------
    @property
    def rod_area(self) -> float:
        """Rod cross-section A_r = pi d^2 / 4, [m^2] (eq 28)."""
        return math.pi * self.rod_diameter ** 2 / 4.0

    @property
    def rod_volume(self) -> float:
        """Rod volume V = A_r L, [m^3] (eqs 6-14)."""
        return self.rod_area * self.rod_length

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus at constant field E^H = K L / A_r, [Pa] (eq 28; not in Table 2)."""
        return self.stiffness * self.rod_length / self.rod_area

    @property
    def field_per_ampere(self) -> float:
        """Applied field per coil ampere N / (k_f L), [A/m per A] (eq 1)."""
        return self.coil_turns / (self.leakage_coefficient * self.rod_length)

    def replace(self, **changes) -> "TransducerParameters":
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of the fields, in declaration order."""
        return tuple(f.name for f in fields(cls))


@dataclass(frozen=True)
class Excitation:
    """Sinusoidal operating point of the complex-permeability model.

    The model of the paper is defined for a current i = I_m cos(w t) of known
    amplitude and frequency (eqs 1-2): mu' and mu'' belong to that operating
    point.

    Attributes
    ----------
    frequency : float
        Excitation frequency f, [Hz], in (0, 1000].
    current_amplitude : float
        Current amplitude I_m, [A], in (0, 100].
    flux_density_amplitude : float
        Measured flux-density amplitude B_m, [T]. ``0`` (the default) means
        "not measured": the model then takes it from a calibration table
        (:mod:`gmt.calibration`, by default built from Table 1).
    follow_drive : bool
        ``False`` (default): the model stays at (f, I_m) and flags a drive that
        departs from it (:mod:`gmt.design_point`). ``True``: the operating point
        follows the sinusoid the transducer is driven with, measured over each
        period (B_m then from the calibration); DC and steps stay flagged.
    """

    frequency: float = 50.0
    current_amplitude: float = 1.0
    flux_density_amplitude: float = 0.0
    follow_drive: bool = False

    def __post_init__(self):
        check_range("frequency", self.frequency, 0.0, 1000.0, unit="Hz",
                    high_open=False)
        check_range("current_amplitude", self.current_amplitude, 0.0, 100.0,
                    unit="A", high_open=False)
        check_range("flux_density_amplitude", self.flux_density_amplitude, 0.0,
                    2.0, unit="T", low_open=False)
        if not isinstance(self.follow_drive, bool):
            raise ParameterError(f"follow_drive = {self.follow_drive!r} must be True or False")

    @property
    def angular_frequency(self) -> float:
        """w = 2 pi f, [rad/s] (eq 1)."""
        return 2.0 * math.pi * self.frequency

    @property
    def has_measured_flux_density(self) -> bool:
        """True when B_m was given rather than taken from calibration."""
        return self.flux_density_amplitude > 0.0


@dataclass(frozen=True)
class DriveParameters:
    """Power amplifier and inverse compensator (paper, Figure 9).

    Attributes
    ----------
    amplifier_gain : float
        K_a, coil current per volt of control signal, [A/V]. The paper uses 1.
    current_limit : float
        Largest coil current magnitude the amplifier delivers, [A].
    compensated : bool
        ``False``: i = K_a u (the paper's uncompensated drive).
        ``True``: i = K_a * inverse(y_d), y_d = ``displacement_per_volt`` * u
        (Figure 9).
    displacement_per_volt : float
        Commanded displacement per volt of control signal, [m/V]; the paper's
        y_d = 10 u um gives 10e-6.
    control_offset : float
        u_0, [V]. The compensator asks for y = y_bottom + displacement_per_volt
        (u - u_0), where y_bottom is the lowest displacement the rod reaches
        about its bias at the operating point (:func:`gmt.inverse.stroke`).
        With u_0 = 0, u = 0 commands the bottom of the stroke, as Table 3
        zeroes its compensated displacements at u = 0; the paper's control
        signals u = a + a cos(w t) (a = 2.2, 1.9, 1.7, 1.5 V) then span
        0 to 20 a um of the stroke.
    branch_rule : {"control", "demand"}
        How the compensator picks the root of eq 33: by the sign of
        u(n) - u(n-1) as Figure 9 does (``"control"``), or by the direction of
        the magnetisation the demand needs (``"demand"``, default
        :data:`BRANCH_RULE`: the one whose result does not depend on the sample
        period); see :mod:`gmt.inverse`.
    compensator_period : float
        Sample period T_c of the digital compensator, [s], in [0, 1]: it samples u
        at t_n = n T_c from the start and its DAC holds the current until the
        next sample (:class:`gmt.Transducer`). Default :data:`COMPENSATOR_PERIOD`
        (10 kHz). 0 samples at the start of every step instead (each step is one
        sample, the idealised limit as the step shrinks).
    """

    amplifier_gain: float = 1.0
    current_limit: float = 3.0
    compensated: bool = False
    displacement_per_volt: float = 10e-6
    control_offset: float = 0.0
    branch_rule: str = BRANCH_RULE
    compensator_period: float = COMPENSATOR_PERIOD

    def __post_init__(self):
        check_range("amplifier_gain", self.amplifier_gain, 0.0, 1000.0, unit="A/V")
        check_range("current_limit", self.current_limit, 0.0, 100.0, unit="A",
                    high_open=False)
        check_range("displacement_per_volt", self.displacement_per_volt, 0.0,
                    1e-3, unit="m/V")
        check_range("control_offset", self.control_offset, -1000.0, 1000.0,
                    unit="V", low_open=False, high_open=False)
        check_range("compensator_period", self.compensator_period, 0.0, 1.0, unit="s",
                    low_open=False, high_open=False)
        if self.branch_rule not in BRANCH_RULES:
            raise ParameterError(
                f"branch_rule = {self.branch_rule!r} is not one of {BRANCH_RULES}")
        if not isinstance(self.compensated, (bool, int)):
            raise ParameterError(
                f"compensated = {self.compensated!r} must be a boolean")
