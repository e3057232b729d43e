"""What an FMU variable of this project is: the record every variable table is made of, and
the units they use.

The FMUs of this project each define their variables once, in a table next to their slave
(``smeha_fmu_interface.py``: the transducer; ``smeha_plant_interface.py``: the hydraulic
plant; ``smeha_drive_fmu.py``: the drive signal), as :class:`Variable` records; the slaves
register them, ``smeha.fmu.build`` writes their units into the FMI 2.0 model description
from :data:`UNITS`, and ``docs/FMU.md`` documents them.

Bundled into each FMU's resources under this name and the build's identifier.
It imports nothing beyond the standard library.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: Units: name -> exponents of the SI base units (kg, m, s, A, K, mol, cd, rad).
#: ``None`` marks a unit that integer exponents cannot express (the Steinmetz
#: law's T^n and the excess-loss law's T^1.5): it is declared by name only.
UNITS: dict[str, dict[str, int] | None] = {
    "1": {},
    "A": {"A": 1},
    "A/m": {"A": 1, "m": -1},
    "A/V": {"kg": -1, "m": -2, "s": 3, "A": 2},
    "Hz": {"s": -1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "N/m": {"kg": 1, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "Pa.s": {"kg": 1, "m": -1, "s": -1},
    "Pa/m3": {"kg": 1, "m": -4, "s": -2},
    "T": {"kg": 1, "s": -2, "A": -1},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "W.s/(m3.T^n)": None,  # K_h of eq 7; the exponent n is itself a parameter
    "W.s/(m3.(A/m)3)": {"kg": 1, "m": 2, "s": -2, "A": -3},  # K'_h of eq 6
    "W.s2/(m3.T2)": {"kg": -1, "m": -1, "s": 3, "A": 2},  # K_e of eq 9
    "W.s1.5/(m3.T1.5)": None,  # K_ex of eq 11: half-integer exponents
    "A/m.T^(q-beta).(s/T)^(q-1)": None,  # k_w of the rate field; q, beta are parameters
    "A/m.T^(1-beta)": None,  # k_r of the relaxation; beta is a parameter
    "kg": {"kg": 1},
    "kg/m3": {"kg": 1, "m": -3},
    "m": {"m": 1},
    "m/V": {"kg": -1, "m": -1, "s": 3, "A": 1},
    "m/s": {"m": 1, "s": -1},
    "m2": {"m": 2},
    "m2/A2": {"m": 2, "A": -2},
    "m3": {"m": 3},
    "m3/s": {"m": 3, "s": -1},
    "s": {"s": 1},  # also FMI 3.0's independent variable time
}


@dataclass(frozen=True)
class Variable:
    """One FMU variable.

    Attributes
    ----------
    name : str
        Variable name (for parameters, the field name of the physics dataclass it goes to,
        or that name prefixed by the component's).
    kind : {"Real", "Integer", "Boolean", "String"}
        FMI 2.0 type (FMI 3.0: Float64, Int32, Boolean, String).
    causality : {"input", "parameter", "calculatedParameter", "output"}
    unit : str or None
        Key of :data:`UNITS` (every Real has one; "1" for dimensionless).
    description : str
    start : float, int, bool, str or None
        Start value (inputs and parameters); outputs start at :attr:`initial_value`.
    group : str
        Which physics object a parameter goes to (each table names its groups).
    """

    name: str
    kind: str
    causality: str
    unit: str | None
    description: str
    start: Any
    group: str

    @property
    def variability(self) -> str:
        """FMI variability: fixed parameters, continuous Reals, discrete others."""
        if self.causality in ("parameter", "calculatedParameter"):
            return "fixed"
        return "continuous" if self.kind == "Real" else "discrete"

    @property
    def initial_value(self):
        """Value the slave holds before its first step."""
        if self.start is not None:
            return self.start
        return {"Real": 0.0, "Integer": 0, "Boolean": False, "String": ""}[self.kind]

    def coerce(self, value):
        """``value`` converted to this variable's Python type (no range check)."""
        if self.kind == "Real":
            return float(value)
        if self.kind == "Integer":
            return int(value)
        if self.kind == "Boolean":
            return bool(value)
        return str(value)


def unit_problems(variables) -> list[str]:
    """Reals of ``variables`` whose unit is not in :data:`UNITS` (a table's self-check)."""
    return [f"{v.name}: unit {v.unit!r} is not in UNITS" for v in variables
            if v.kind == "Real" and v.unit not in UNITS]
