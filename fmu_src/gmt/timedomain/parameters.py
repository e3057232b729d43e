"""Parameters of the time-domain magnetics beyond Table 2.

The loss coefficients K_h, n, K_e, K_ex stay Table 2's
(:class:`gmt.TransducerParameters`); the time-domain form needs three more
numbers, the extended dynamic loss law (:mod:`gmt.timedomain.dynamic`)
five, a second hysteresis density two and a break of the hysteresis exponent
two, whose defaults switch them off:
a frozen dataclass validated on construction.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

from ..constants import MU_0
from ..errors import check_range

__all__ = ["TimeDomainParameters", "REVERSIBLE_PERMEABILITY"]

#: Relative permeability of the reversible curve, [-]: the least-squares fit of the
#: time-domain model to the paper's Table 1 at 5 Hz (0.5 A: 0.0300 T, 0.7 A: 0.0530 T)
#: under a sinusoidal current, with the other defaults below
#: (``gmt.timedomain.fit.fit_reversible_permeability``; docs/TIMEDOMAIN.md).
REVERSIBLE_PERMEABILITY = 12.08


@dataclass(frozen=True)
class TimeDomainParameters:
    """What the field separation needs besides Table 2 (:mod:`gmt.timedomain`).

    Attributes
    ----------
    reversible_permeability : float
        mu_rev of the reversible curve H_rev = B / (mu_0 mu_rev) about the bias,
        [-], in (1, 1e4]. Default fitted to Table 1's 5 Hz points.
    steinmetz_upper : float
        r_max, [T], in (0, 2]: the largest flux-density half-swing for which the
        hysteresis loss per cycle is K_h B_m^n (eq 7); above it the loss grows
        linearly with the swing. The default, 0.2 T, is twice the largest
        amplitude a 1 A drive reaches (~0.1 T at DC).
    steinmetz_lower : float
        r_0, [T], in (0, steinmetz_upper): below this half-swing the loss law
        turns from K_h B_m^n into that of one stop (a Rayleigh-like region), so
        that dH/dB stays finite at reversals. Default 2 mT.
    rate_coefficient : float
        k_w of the rate field H_w = k_w dB_pp^(beta - q) |dB/dt|^(q - 1) sign(dB/dt),
        [A/m T^(q - beta) (s/T)^(q - 1)], >= 0. Default 0: no rate field.
    rate_exponent : float
        q, [-], in [1, 4]: the loss of a flux transition grows as |dB/dt|^q.
    swing_exponent : float
        beta, [-], in [1, 4]: the rate field and the relaxation scale with the
        loop's peak-to-peak swing dB_pp as dB_pp^(beta - q) and dB_pp^(beta - 2).
    second_hysteresis_coefficient : float
        K_h2 of a second stop density, [J/(m^3 T^n2)], >= 0: the hysteresis loss per
        cycle becomes K_h B_m^n + K_h2 B_m^n2
        (:class:`gmt.timedomain.hysteresis.BranchSum`). Default 0: eq 7 alone.
    second_steinmetz_exponent : float
        n2, [-], in (1, 4]: with n2 > n the hysteresis exponent rises from n at
        small amplitudes to n2 at large ones.
    steinmetz_break : float
        r_b, [T], in (steinmetz_lower, 2]: above this half-swing the hysteresis loss per
        cycle grows with the exponent ``steinmetz_exponent_high`` instead of n (the stop
        densities turn from r^(n - 3) to r^(m - 3), :mod:`gmt.timedomain.hysteresis`).
        Default 2 T: no break below the largest allowed ``steinmetz_upper``.
    steinmetz_exponent_high : float
        m, [-], in (1, 4]: the exponent above ``steinmetz_break`` (n's 3 in a ferrite's
        Rayleigh region, about 2 above it).
    relaxation_coefficient : float
        k_r of the relaxation field H_r = k_r dB_pp^(beta - 2) x, [A/(m T) T^(2 - beta)],
        >= 0. Default 0: no relaxation.
    relaxation_time : float
        tau of dx/dt = dB/dt - x/tau, [s], in (0, 1].
    """

    reversible_permeability: float = REVERSIBLE_PERMEABILITY
    steinmetz_upper: float = 0.2
    steinmetz_lower: float = 2e-3
    rate_coefficient: float = 0.0
    rate_exponent: float = 2.0
    swing_exponent: float = 2.0
    relaxation_coefficient: float = 0.0
    relaxation_time: float = 1e-6
    second_hysteresis_coefficient: float = 0.0
    second_steinmetz_exponent: float = 3.5
    steinmetz_break: float = 2.0
    steinmetz_exponent_high: float = 2.0

    def __post_init__(self):
        check_range("reversible_permeability", self.reversible_permeability, 1.0, 1e4,
                    unit="-", high_open=False)
        check_range("steinmetz_upper", self.steinmetz_upper, 0.0, 2.0, unit="T",
                    high_open=False)
        check_range("steinmetz_lower", self.steinmetz_lower, 0.0, self.steinmetz_upper,
                    unit="T")
        check_range("rate_coefficient", self.rate_coefficient, 0.0, None, low_open=False)
        check_range("rate_exponent", self.rate_exponent, 1.0, 4.0, unit="-",
                    low_open=False, high_open=False)
        check_range("swing_exponent", self.swing_exponent, 1.0, 4.0, unit="-",
                    low_open=False, high_open=False)
        check_range("relaxation_coefficient", self.relaxation_coefficient, 0.0, None,
                    low_open=False)
        check_range("relaxation_time", self.relaxation_time, 0.0, 1.0, unit="s",
                    high_open=False)
        check_range("second_hysteresis_coefficient", self.second_hysteresis_coefficient, 0.0,
                    None, low_open=False)
        check_range("second_steinmetz_exponent", self.second_steinmetz_exponent, 1.0, 4.0,
                    unit="-", high_open=False)
        check_range("steinmetz_break", self.steinmetz_break, self.steinmetz_lower, 2.0,
                    unit="T", high_open=False)
        check_range("steinmetz_exponent_high", self.steinmetz_exponent_high, 1.0, 4.0,
                    unit="-", high_open=False)

    @property
    def has_extension(self) -> bool:
        """True when the rate field or the relaxation is on."""
        return self.rate_coefficient > 0.0 or self.relaxation_coefficient > 0.0

    def replace(self, **changes) -> "TimeDomainParameters":
        """Copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of the fields, in declaration order."""
        return tuple(f.name for f in fields(cls))

    @property
    def reversible_field_per_tesla(self) -> float:
        """1 / (mu_0 mu_rev), [A/(m T)]."""
        return 1.0 / (MU_0 * self.reversible_permeability)
