"""Hydraulic fluid: density, effective bulk modulus with entrained air, viscosity.

Defaults are a mineral hydraulic oil of viscosity grade ISO VG 32 at 40 C (ISO 3448:
32 mm^2/s, so ~0.03 Pa s at the density of mineral oil, 850-870 kg/m^3), and the
pure-oil bulk modulus of mineral oils, 1.4-1.8 GPa (Merritt, Hydraulic Control
Systems, 1967, ch. 2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gmt.errors import check_range

from ._jit import jitable


@dataclass(frozen=True)
class FluidParameters:
    """Fluid properties (SI).

    Attributes
    ----------
    density : float
        Density at the reference pressure, [kg/m^3].
    bulk_modulus : float
        Bulk modulus of the air-free oil, [Pa].
    air_fraction : float
        Volume fraction of entrained (undissolved) air at the reference
        pressure, [-]; 0 gives pure oil.
    reference_pressure : float
        Pressure at which ``air_fraction`` is stated, [Pa] (absolute).
    air_polytropic_index : float
        Polytropic exponent of the air bubbles, [-]: 1.4 (adiabatic) suits
        pumping at 50-100 Hz.
    viscosity : float
        Dynamic viscosity, [Pa s].
    """

    density: float = 860.0
    bulk_modulus: float = 1.6e9
    air_fraction: float = 0.0
    reference_pressure: float = 1.0e5
    air_polytropic_index: float = 1.4
    viscosity: float = 0.03

    def __post_init__(self):
        check_range("density", self.density, 0.0, 5000.0, unit="kg/m^3")
        check_range("bulk_modulus", self.bulk_modulus, 0.0, 1e13, unit="Pa")
        check_range("air_fraction", self.air_fraction, 0.0, 0.5, unit="-", low_open=False)
        check_range("reference_pressure", self.reference_pressure, 0.0, 1e8, unit="Pa")
        check_range("air_polytropic_index", self.air_polytropic_index, 1.0, 1.67, unit="-",
                    low_open=False, high_open=False)
        check_range("viscosity", self.viscosity, 0.0, 10.0, unit="Pa s")


#: Pressure below which the air model is not evaluated, [Pa]: keeps the
#: effective bulk modulus finite when a chamber is sucked towards vacuum. It is
#: also where the model's oil stops being a real one: a liquid's absolute
#: pressure cannot fall below its vapour pressure, and air dissolved in a
#: mineral oil comes out of solution well above that (Merritt, Hydraulic Control
#: Systems, 1967, ch. 2). Cavitation is not modelled: a run with entrained air
#: stops there (:class:`system_models.implicit.CavitationError`), and a flow
#: study row whose oil went below it is flagged (:func:`smeha.studies.flow.flag_row`).
MINIMUM_PRESSURE = 1.0e3


def effective_bulk_modulus(fluid: FluidParameters, pressure):
    """Effective bulk modulus of the oil-air mixture, [Pa].

    1 / beta_e = (1 - a) / beta_oil + a / (n p), a the air fraction at p:
    series compliance of oil and air (Merritt, Hydraulic Control Systems,
    1967, sec. 2.5). With no air it is the oil's modulus.

    Examples
    --------
    >>> f = FluidParameters(air_fraction=0.005)
    >>> round(float(effective_bulk_modulus(f, 2e6)) / 1e9, 2)
    1.2
    """
    return mixture_bulk_modulus(pressure, fluid.bulk_modulus, fluid.air_fraction,
                                fluid.reference_pressure, fluid.air_polytropic_index)


@jitable
def mixture_bulk_modulus(pressure, oil_bulk_modulus, air_fraction, reference_pressure,
                         polytropic_index):
    """:func:`effective_bulk_modulus` on plain numbers, [Pa].

    The form the compiled co-simulation kernel (:mod:`system_models.kernel`)
    calls; arguments as the fields of :class:`FluidParameters` (SI).
    """
    p = np.maximum(pressure, MINIMUM_PRESSURE)
    air = air_fraction * (reference_pressure / p) ** (1.0 / polytropic_index)
    a = air / (1.0 - air_fraction + air)
    return 1.0 / ((1.0 - a) / oil_bulk_modulus + a / (polytropic_index * p))
