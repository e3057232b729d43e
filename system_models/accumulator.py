"""Gas-charged accumulator: the low-pressure reservoir of the bridge."""
from __future__ import annotations

from dataclasses import dataclass

from gmt.errors import check_range

from ._jit import jitable


@dataclass(frozen=True)
class AccumulatorParameters:
    """Accumulator (SI).

    Attributes
    ----------
    precharge_pressure : float
        Gas pressure with no oil inside, [Pa] (absolute; the 0.5-3 MPa bias of
        smart-material pumps such as Sirohi & Chopra's (2003) and Rupinsky &
        Dapino's (2006) keeps the pump chamber from cavitating on expansion).
    gas_volume : float
        Gas volume at the pre-charge, [m^3].
    polytropic_index : float
        n of p V^n = const for the gas, [-] (1 isothermal, 1.4 adiabatic).
    port_stiffness : float
        Pressure drop per m^3 of oil withdrawn from an empty accumulator,
        [Pa/m^3] (the oil in its port alone).
    """

    precharge_pressure: float = 1.0e6
    gas_volume: float = 50e-6
    polytropic_index: float = 1.4
    port_stiffness: float = 1.6e9 / 1e-6

    def __post_init__(self):
        check_range("precharge_pressure", self.precharge_pressure, 0.0, 1e8, unit="Pa")
        check_range("gas_volume", self.gas_volume, 0.0, 10.0, unit="m^3")
        check_range("polytropic_index", self.polytropic_index, 1.0, 1.67, unit="-",
                    low_open=False, high_open=False)
        check_range("port_stiffness", self.port_stiffness, 0.0, 1e20, unit="Pa/m^3")


def accumulator_pressure(acc: AccumulatorParameters, oil_volume):
    """Pressure at a stored oil volume, [Pa].

    p = p_0 (V_0 / (V_0 - V_oil))^n while oil is stored; below empty the port's
    oil alone (stiff) carries the pressure down.
    """
    return gas_spring_pressure(oil_volume, acc.precharge_pressure, acc.gas_volume,
                               acc.polytropic_index, acc.port_stiffness)


@jitable
def gas_spring_pressure(oil_volume, precharge_pressure, gas_volume, polytropic_index,
                        port_stiffness):
    """:func:`accumulator_pressure` on plain numbers (for the compiled kernel), [Pa]."""
    if oil_volume >= 0.0:
        return precharge_pressure * (gas_volume / (gas_volume - oil_volume)) ** polytropic_index
    return precharge_pressure + port_stiffness * oil_volume


def oil_volume_at(acc: AccumulatorParameters, pressure):
    """Stored oil volume at a pressure (inverse of :func:`accumulator_pressure`), [m^3]."""
    if pressure >= acc.precharge_pressure:
        return acc.gas_volume * (1.0 - (acc.precharge_pressure / pressure) ** (1.0 / acc.polytropic_index))
    return (pressure - acc.precharge_pressure) / acc.port_stiffness
