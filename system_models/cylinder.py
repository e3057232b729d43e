"""Two-cavity cylinder with its load: differential (single rod) or equal-area (through rod).

The piston position x is measured from the end where the big (cap) cavity is
smallest; x grows as the cylinder moves "down" (Figure 2: oil into the big
cavity), shrinking the small (rod-side) cavity.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gmt.errors import check_range

from ._jit import jitable


@dataclass(frozen=True)
class CylinderParameters:
    """Cylinder and load (SI).

    Attributes
    ----------
    bore_diameter, rod_diameter : float
        Piston and piston-rod diameters, [m].
    stroke : float
        Travel between the end stops, [m].
    dead_volume_big, dead_volume_small : float
        Cavity volumes at the end of travel that empties them, [m^3]
        (ports, hoses and valve bodies included).
    mass : float
        Piston, rod and load mass, [kg].
    friction : float
        Viscous friction coefficient, [N s/m].
    stop_stiffness, stop_damping : float
        End-stop contact stiffness [N/m] and damping [N s/m].
    through_rod : bool
        False: a differential cylinder (the rod on the small cavity's side
        only, A_B > A_S). True: the rod runs through both cavities, so both
        have the annulus area (an equal-area, "double-rod" cylinder).
    """

    bore_diameter: float = 20e-3
    rod_diameter: float = 10e-3
    stroke: float = 50e-3
    dead_volume_big: float = 2.0e-6
    dead_volume_small: float = 2.0e-6
    mass: float = 1.0
    friction: float = 500.0
    stop_stiffness: float = 1.0e8
    stop_damping: float = 1.0e4
    through_rod: bool = False

    def __post_init__(self):
        check_range("bore_diameter", self.bore_diameter, 0.0, 1.0, unit="m")
        check_range("rod_diameter", self.rod_diameter, 0.0, self.bore_diameter, unit="m")
        check_range("stroke", self.stroke, 0.0, 10.0, unit="m")
        check_range("dead_volume_big", self.dead_volume_big, 0.0, 1.0, unit="m^3")
        check_range("dead_volume_small", self.dead_volume_small, 0.0, 1.0, unit="m^3")
        check_range("mass", self.mass, 0.0, 1e6, unit="kg")
        check_range("friction", self.friction, 0.0, 1e9, unit="N s/m", low_open=False)
        check_range("stop_stiffness", self.stop_stiffness, 0.0, 1e12, unit="N/m")
        check_range("stop_damping", self.stop_damping, 0.0, 1e9, unit="N s/m", low_open=False)

    @property
    def big_area(self) -> float:
        """Piston area on the big cavity's side A_B, [m^2] (the annulus with a through rod)."""
        if self.through_rod:
            return self.small_area
        return math.pi * self.bore_diameter ** 2 / 4.0

    @property
    def small_area(self) -> float:
        """Annulus area on the rod side A_S, [m^2]."""
        return math.pi * (self.bore_diameter ** 2 - self.rod_diameter ** 2) / 4.0


def cavity_volumes(cyl: CylinderParameters, position):
    """(V_B, V_S) at piston position x, [m^3]."""
    return (cyl.dead_volume_big + cyl.big_area * position,
            cyl.dead_volume_small + cyl.small_area * (cyl.stroke - position))


def end_stop_force(cyl: CylinderParameters, position, velocity):
    """Contact force of the end stops, [N] (positive pushes towards larger x).

    A one-sided spring-damper engaged beyond either end of travel; the damper
    only pushes (no sticking to the stop).
    """
    return stop_force(position, velocity, cyl.stroke, cyl.stop_stiffness, cyl.stop_damping)


@jitable
def stop_force(position, velocity, stroke, stiffness, damping):
    """:func:`end_stop_force` on plain numbers (for the compiled kernel), [N]."""
    if position < 0.0:
        return max(-stiffness * position - damping * velocity, 0.0)
    if position > stroke:
        return min(-stiffness * (position - stroke) - damping * velocity, 0.0)
    return 0.0


def piston_acceleration(cyl: CylinderParameters, pressure_big, pressure_small, position,
                        velocity, load_force):
    """d^2x/dt^2 of piston and load, [m/s^2].

    m a = p_B A_B - p_S A_S - b v - F_load + F_stop; ``load_force`` opposes
    motion towards larger x (down) when positive, [N].
    """
    return piston_acceleration_of(pressure_big, pressure_small, position, velocity, load_force,
                                  cyl.big_area, cyl.small_area, cyl.friction, cyl.mass,
                                  cyl.stroke, cyl.stop_stiffness, cyl.stop_damping)


@jitable
def piston_acceleration_of(pressure_big, pressure_small, position, velocity, load_force,
                           big_area, small_area, friction, mass, stroke, stop_stiffness,
                           stop_damping):
    """:func:`piston_acceleration` on plain numbers (for the compiled kernel), [m/s^2]."""
    force = (pressure_big * big_area - pressure_small * small_area - friction * velocity
             - load_force + stop_force(position, velocity, stroke, stop_stiffness, stop_damping))
    return force / mass
