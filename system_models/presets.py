"""Named circuit configurations: the ideal limit of eqs 40/41, the differential circuit, and
realistic defaults.

``realistic`` (the study's default): values typical of smart-material pumps
(Sirohi & Chopra, J. Intell. Mater. Syst. Struct. 14, 2003; Rupinsky &
Dapino, Proc. SPIE 6173, 2006; Chaudhuri & Wereley, J. Intell. Mater. Syst.
Struct. 23, 2012) and of fluid-power practice (Merritt, *Hydraulic Control
Systems*, 1967):

* oil: 860 kg/m^3, 1.6 GPa without air (mineral oil, Merritt ch. 2), 0.5 %
  entrained air at 1 bar, which gives an effective bulk modulus of about
  1.2 GPa at the 1.5-2 MPa the circuit runs at;
* active valves: 20 mm^2 flow area, C_d = 0.65 (a sharp-edged orifice,
  Merritt sec. 3.2), laminar below 10 kPa, 0.2 ms actuation dead time
  (piezo- or magnetostrictive-driven valves open in 0.1-1 ms);
* pump chamber: 2.5 cm^3 dead volume, the paper's piston A_d = 1256 mm^2;
* accumulator: 1 MPa pre-charge, 50 cm^3 gas, adiabatic (n = 1.4), run at
  1.5 MPa;
* differential cylinder: 20 mm bore, 10 mm rod, 50 mm stroke, 1 kg moving
  mass, 500 N s/m viscous friction; a 150 N load.

Valve response. A *dead time* is the default. A first-order valve response
(``response="first_order"``) leaves V1 and V3 (or V2 and V4) partly open
together for about the opening time after each switch; with the rod-side
cavity above the cap side (accumulator pressure times the area ratio) oil
then short-circuits S -> P -> B and the cylinder moves without the pump.
That is real and worth studying (it is why active-valve drives need
break-before-make timing), but it is not the pumping the flow check is about.

``ideal``: the limit in which eqs 40/41 hold. They take dy from the *free*
transducer (paper, eqs 39-41 and Table 3), which is right only if the pump
chamber's pressure does not load the rod differently in the two strokes.
So: the chamber, both cavities and the accumulator at one constant pressure
-- an equal-area (through-rod) cylinder, so that p_B = p_S with no load; no
friction and a 10 mg piston, so that moving it takes no pressure difference
(the digital compensator's current steps jerk the oil column: a 1 g piston
raised ~70 kPa spikes at 70 Hz, 0.6 % of the flow); a 1 m stroke;
a 1 L isothermal accumulator (the ~0.05 cm^3 a stroke exchanges moves its
pressure by ~70 Pa, 0.1 N on the rod); a 100x stiffer oil without air and
10x wider valves that switch instantly, so that the pumped volume reaches the
cylinder uncompressed. The chamber's constant pressure shifts the rod by
A_d p / K, the same in both strokes, and the rod's dy between the valve
switches is the free transducer's.

``differential``: the ideal oil and valves of ``ideal`` with the realistic
differential cylinder and accumulator, no load. The cylinder puts the
rod-side cavity above the cap side (p_S A_S = p_B A_B): the chamber pressure
steps by ~0.37 MPa at every valve switch, the rod rebounds elastically and
the pump delivers ~1.6x the flow eqs 40/41 give for the free transducer
(dy 58 um against 35 um at 50 Hz). It shows why the ideal limit needs the
equal areas. Its oil is an idealisation in one more way: without air and 100x
stiffer, it holds tension. While the big cavity is shut the 1 kg piston rings
on that stiff oil and, in the uncompensated runs (and compensated at 70-80 Hz),
pulls the cavity's pressure below zero absolute (to -0.2 to -3.3 MPa at 50-100
Hz), where a real oil would cavitate; the flow study flags those rows
(``cavitation``, :func:`smeha.studies.flow.flag_row`) rather than model it. The
``realistic`` circuit (0.5 % air) and ``ideal`` stay above 1 MPa over the flow
table.
"""
from __future__ import annotations

from .accumulator import AccumulatorParameters
from .circuit import CircuitParameters
from .cylinder import CylinderParameters
from .defaults import REALISTIC_LOAD  # its home: plain numbers, read by --help
from .fluid import FluidParameters
from .valves import ValveParameters


def _stiff_oil_fast_valves() -> dict:
    valve = ValveParameters(area=200e-6, response="ideal", opening_time=0.0)
    return {"fluid": FluidParameters(bulk_modulus=1.0e11), "valves": (valve,) * 4}


def ideal_circuit() -> CircuitParameters:
    """The limit in which q = f A_d dy_free holds (eqs 40/41; module docstring)."""
    cylinder = CylinderParameters(through_rod=True, mass=1e-5, friction=0.0, stroke=1.0)
    accumulator = AccumulatorParameters(gas_volume=1e-3, polytropic_index=1.0)
    return CircuitParameters(cylinder=cylinder, accumulator=accumulator,
                             **_stiff_oil_fast_valves())


def differential_circuit() -> CircuitParameters:
    """Stiff oil and fast wide valves on the differential cylinder: the rebound (docstring)."""
    return CircuitParameters(**_stiff_oil_fast_valves())


def realistic_circuit() -> CircuitParameters:
    """The realistic defaults of the module docstring."""
    valve = ValveParameters(area=20e-6, discharge_coefficient=0.65, transition_pressure=1e4,
                            response="delay", opening_time=2e-4)
    return CircuitParameters(fluid=FluidParameters(air_fraction=0.005), valves=(valve,) * 4)


#: The named circuits, by name (``smeha flow --circuit``).
CIRCUITS = {"realistic": realistic_circuit, "ideal": ideal_circuit,
            "differential": differential_circuit}


def circuit(name: str) -> CircuitParameters:
    """The named circuit; a ParameterError names the allowed ones."""
    if name not in CIRCUITS:
        from gmt.errors import ParameterError
        raise ParameterError(f"circuit = {name!r} is not one of {tuple(CIRCUITS)}")
    return CIRCUITS[name]()


def default_load(name: str) -> float:
    """The load a named circuit is studied with, [N]: 150 N realistic, none otherwise."""
    return REALISTIC_LOAD if name == "realistic" else 0.0
