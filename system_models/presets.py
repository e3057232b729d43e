"""Named circuit configurations: the ideal limit of eqs 40/41 and realistic defaults.

Realistic values are typical of smart-material pumps (Sirohi & Chopra 2003,
Chaudhuri & Wereley 2012, Rupinsky & Dapino 2006) and of fluid-power handbooks
(Merritt, Hydraulic Control Systems, 1967):

* oil: 860 kg/m^3, 1.6 GPa without air, 0.5 % entrained air at 1 bar, which
  gives an effective bulk modulus of about 1.2 GPa at the 1.5-2 MPa the
  circuit runs at;
* active valves: 20 mm^2 flow area, C_d = 0.65, laminar below 10 kPa,
  0.2 ms actuation dead time (piezo- or magnetostrictive-driven valves open
  in 0.1-1 ms);
* pump chamber: 2.5 cm^3 dead volume, the paper's piston A_d = 1256 mm^2;
* accumulator: 1 MPa pre-charge, 50 cm^3 gas, adiabatic (n = 1.4), run at
  1.5 MPa;
* cylinder: 20 mm bore, 10 mm rod, 50 mm stroke, 1 kg moving mass,
  500 N s/m viscous friction.

Valve response. A *dead time* is the default. A first-order valve response
(``response="first_order"``) leaves V1 and V3 (or V2 and V4) partly open
together for about the opening time after each switch; with the rod-side
cavity above the cap side (accumulator pressure times the area ratio) oil
then short-circuits S -> P -> B and the cylinder moves without the pump.
That is real and worth studying (it is why active-valve drives need
break-before-make timing), but it is not the pumping the flow check is about.

The ideal limit (eqs 40/41 hold): a 100x stiffer oil, 10x wider valves that
switch instantly, no load.
"""
from __future__ import annotations

from .circuit import CircuitParameters
from .fluid import FluidParameters
from .valves import ValveParameters

#: Load of the realistic study, [N]: 150 N down-load, about 0.1 MPa of
#: pressure rise the pump must deliver on top of the area-ratio pressure
#: difference (a differential cylinder balances p_S A_S against p_B A_B).
REALISTIC_LOAD = 150.0


def ideal_circuit() -> CircuitParameters:
    """Stiff oil, fast wide valves: the limit in which q = f A_d dy (eqs 40/41)."""
    valve = ValveParameters(area=200e-6, response="ideal", opening_time=0.0)
    return CircuitParameters(fluid=FluidParameters(bulk_modulus=1.0e11),
                             valves=(valve,) * 4)


def realistic_circuit() -> CircuitParameters:
    """The realistic defaults of the module docstring."""
    valve = ValveParameters(area=20e-6, discharge_coefficient=0.65, transition_pressure=1e4,
                            response="delay", opening_time=2e-4)
    return CircuitParameters(fluid=FluidParameters(air_fraction=0.005), valves=(valve,) * 4)
