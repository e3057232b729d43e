"""Pump chamber: volume swept by the transducer's piston, pressure from compressibility."""
from __future__ import annotations

from dataclasses import dataclass

from gmt.errors import ParameterError, check_range

from .fluid import FluidParameters, effective_bulk_modulus


@dataclass(frozen=True)
class PumpChamberParameters:
    """Pump chamber (SI).

    Attributes
    ----------
    dead_volume : float
        Chamber volume with the rod at its reference position, [m^3]
        (2.5 cm^3: with 1.4 GPa oil and A_d = 1256 mm^2 the oil's stiffness on
        the rod, beta A_d^2 / V, is ~9e8 N/m, ~45 times Table 2's K).
    piston_area : float
        A_d, [m^2] (paper, Table 2: 1256 mm^2).
    reference_displacement : float
        Rod displacement at which the volume equals ``dead_volume``, [m]
        (the transducer's bias displacement, 73.5 um with Table 2).
    """

    dead_volume: float = 2.5e-6
    piston_area: float = 1256e-6
    reference_displacement: float = 73.47e-6

    def __post_init__(self):
        check_range("dead_volume", self.dead_volume, 0.0, 1.0, unit="m^3")
        check_range("piston_area", self.piston_area, 0.0, 1.0, unit="m^2")
        check_range("reference_displacement", self.reference_displacement, -1.0, 1.0, unit="m")


def chamber_volume(chamber: PumpChamberParameters, displacement):
    """V = V_0 - A_d (y - y_ref): the chamber shrinks as the rod extends, [m^3].

    Raises
    ------
    ParameterError
        If the rod would sweep the whole chamber (V <= 0).
    """
    v = chamber.dead_volume - chamber.piston_area * (displacement - chamber.reference_displacement)
    if v <= 0.0:
        raise ParameterError(
            f"displacement = {displacement:g} m empties the pump chamber "
            f"(dead_volume = {chamber.dead_volume:g} m^3)")
    return v


def chamber_pressure_rate(chamber: PumpChamberParameters, fluid: FluidParameters, pressure,
                          displacement, velocity, outflow):
    """dp/dt = beta_e(p) / V (A_d dy/dt - Q_out), [Pa/s].

    Parameters
    ----------
    pressure : float
        Chamber pressure, [Pa].
    displacement, velocity : float
        Rod y [m] and dy/dt [m/s] (positive compresses the chamber).
    outflow : float
        Net flow leaving the chamber through its valves, [m^3/s].
    """
    return (effective_bulk_modulus(fluid, pressure) / chamber_volume(chamber, displacement)
            * (chamber.piston_area * velocity - outflow))
