"""Active valves V1-V4: orifice flow and opening response.

Bridge (the paper's Figure 2): P pump chamber, B big (cap) cavity, S small
(rod) cavity, A accumulator; V1 joins P and B, V2 joins B and A, V3 joins P
and S, V4 joins S and A.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gmt.errors import ParameterError, check_range

from ._jit import jitable

#: Valve names in bridge order, with the (upstream, downstream) ports each joins;
#: a positive flow goes from the first port to the second.
BRIDGE = (("V1", "P", "B"), ("V2", "B", "A"), ("V3", "P", "S"), ("V4", "S", "A"))

#: Opening responses a valve can have.
RESPONSES = ("ideal", "first_order", "delay")


@dataclass(frozen=True)
class ValveParameters:
    """One active valve (SI).

    Attributes
    ----------
    area : float
        Flow area fully open, [m^2].
    discharge_coefficient : float
        C_d, [-] (0.6-0.7 for sharp-edged orifices; von Mises' ideal
        sharp-edged orifice gives pi / (pi + 2) = 0.61: Merritt, Hydraulic
        Control Systems, 1967, ch. 3).
    transition_pressure : float
        Pressure difference below which the flow turns laminar (linear in
        the pressure difference), [Pa].
    leakage_fraction : float
        Closed-valve area as a fraction of ``area``, [-].
    response : {"ideal", "first_order", "delay"}
        Opening follows the command at once, with a first-order lag of
        ``opening_time``, or after a dead time of ``opening_time``.
    opening_time : float
        Time constant or dead time of the opening response, [s].
    """

    area: float = 20e-6
    discharge_coefficient: float = 0.65
    transition_pressure: float = 1.0e4
    leakage_fraction: float = 1e-6
    response: str = "first_order"
    opening_time: float = 2e-4

    def __post_init__(self):
        check_range("area", self.area, 0.0, 1.0, unit="m^2")
        check_range("discharge_coefficient", self.discharge_coefficient, 0.0, 1.0, unit="-",
                    high_open=False)
        check_range("transition_pressure", self.transition_pressure, 0.0, 1e7, unit="Pa")
        check_range("leakage_fraction", self.leakage_fraction, 0.0, 1.0, unit="-",
                    low_open=False)
        check_range("opening_time", self.opening_time, 0.0, 1.0, unit="s", low_open=False)
        if self.response not in RESPONSES:
            raise ParameterError(f"response = {self.response!r} is not one of {RESPONSES}")
        if self.response != "ideal" and self.opening_time <= 0.0:
            raise ParameterError(
                f"opening_time = {self.opening_time:g} s must be > 0 for a "
                f"{self.response!r} valve response")


@jitable
def orifice_flow(area, pressure_difference, density, discharge_coefficient,
                 transition_pressure):
    """Volume flow through an orifice, [m^3/s], positive from high to low pressure.

    Q = C_d A sqrt(2/rho) dp / (dp^2 + dp_t^2)^(1/4): the turbulent law
    C_d A sqrt(2 |dp| / rho) for |dp| >> dp_t, linear (laminar) near zero with
    no square-root singularity, smooth everywhere.

    Parameters
    ----------
    area : float or array
        Open flow area, [m^2].
    pressure_difference : float or array
        Upstream minus downstream pressure, [Pa].
    density : float
        [kg/m^3].
    discharge_coefficient : float
        [-].
    transition_pressure : float
        dp_t, [Pa].
    """
    dp = pressure_difference
    return (discharge_coefficient * area * np.sqrt(2.0 / density) * dp
            / (dp * dp + transition_pressure * transition_pressure) ** 0.25)


def open_area(valve: ValveParameters, opening):
    """Flow area at an opening fraction in [0, 1], leakage included, [m^2]."""
    return opening_area(opening, valve.area, valve.leakage_fraction)


@jitable
def opening_area(opening, area, leakage_fraction):
    """:func:`open_area` on plain numbers (for the compiled kernel), [m^2]."""
    x = np.minimum(np.maximum(opening, 0.0), 1.0)
    return area * (leakage_fraction + (1.0 - leakage_fraction) * x)


def opening_rate(valve: ValveParameters, opening, command):
    """d(opening)/dt of a first-order valve, (command - opening) / tau, [1/s]."""
    return (command - opening) / valve.opening_time


def orifice_flow_derivative(area, pressure_difference, density, discharge_coefficient,
                            transition_pressure):
    """dQ/d(dp) of :func:`orifice_flow`, [m^3/(s Pa)].

    C_d A sqrt(2/rho) (dp^2/2 + dp_t^2) / (dp^2 + dp_t^2)^(5/4), positive
    everywhere, largest at dp = 0.
    """
    dp2 = pressure_difference * pressure_difference
    t2 = transition_pressure * transition_pressure
    return (discharge_coefficient * area * np.sqrt(2.0 / density) * (0.5 * dp2 + t2)
            / (dp2 + t2) ** 1.25)
