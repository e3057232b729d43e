"""The pump's stall loads by hand: the pressure limit of the transducer's blocked force.

The pump chamber is bounded by the transducer's rod (stiffness K, eq 27 and Table 2) and
its piston (area A_d, Table 2). Between the valve switches at the drive's extremes the
free rod strokes dy (eqs 40/41). Each switch joins the chamber to the other side of the
bridge (Figure 2), so its pressure steps by the pump's pressure rise dp, and oil flows back
through the valve until the chamber and the rod have taken it up: the rod shortens by
A_d dp / K and the chamber's oil is compressed by V_c dp / beta. A cycle so delivers

    V = A_d dy - C dp,    C = A_d^2 / K + V_c / beta         (the pump's compliance)

and stalls at the pressure limit p_stall = A_d dy / C: with stiff oil the blocked force
K dy over the piston area. (Merritt, *Hydraulic Control Systems*, 1967, sec. 2.5 for the
oil's compliance; the blocked force of a linear actuator, e.g. Sirohi & Chopra, J. Intell.
Mater. Syst. Struct. 14, 2003.)

The cylinder turns dp into load. Down (stages 1-2), the small cavity stays at the
accumulator's pressure p_A and the pump fills the big one: p_B A_B = F + p_A A_S, so
dp = (F + p_A A_S) / A_B - p_A. Up (stages 3-4), the big cavity stays at p_A and the pump
fills the small one: dp = (p_A A_B - F) / A_S - p_A. The stall loads (F opposing down):

    down:  F_down = A_B p_stall + p_A (A_B - A_S)
    up:    F_up   = p_A (A_B - A_S) - A_S p_stall

A differential cylinder at p_A is pushed down by p_A times the rod's area, which shifts
both. The piston moves down for F < F_down and up for F > F_up; a position loop needs both.
This is quasi-static: the cylinder's piston follows the oil at every instant. It decides
before a run which loads are far outside what the pump moves. Above ~50 Hz the piston's
mass swings on the pump's compliance at each switch and the valves catch it mid-swing:
:mod:`smeha.studies.pumpcycle` gives the stall pressures of that cycle (``cycle_*``), which
the speed-load envelope is checked against.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from system_models import presets
from system_models.circuit import initial_state
from system_models.fluid import effective_bulk_modulus

from .pumpcycle import cycle_model

__all__ = ["PumpLimits", "pump_limits"]


@dataclass(frozen=True, kw_only=True)
class PumpLimits:
    """The hand calculation's figures at one frequency, mode and circuit (SI)."""

    frequency: float  #: [Hz]
    mode: str
    circuit: str
    free_stroke: float  #: dy of the free transducer between the valve switches, [m]
    stiffness: float  #: the rod's K, [N/m]
    piston_area: float  #: A_d, [m^2]
    compliance: float  #: the pump's C = A_d^2 / K + V_c / beta, [m^3/Pa]
    accumulator_pressure: float  #: p_A, [Pa]
    big_area: float  #: A_B, [m^2]
    small_area: float  #: A_S, [m^2]
    #: the pump cycle's (:mod:`~smeha.studies.pumpcycle`) stall pressure rise P_s down and
    #: up, [Pa], the piston's travel per Pa of P_s each way, [m/Pa], and the pressure limit
    #: A_d Y / C of the free rod's whole stroke, [Pa] (NaN: not computed)
    cycle_stall_pressure_down: float = math.nan
    cycle_stall_pressure_up: float = math.nan
    cycle_slope_down: float = math.nan
    cycle_slope_up: float = math.nan
    pressure_limit: float = math.nan

    @property
    def blocked_force(self) -> float:
        """K dy, [N]."""
        return self.stiffness * self.free_stroke

    @property
    def stall_pressure(self) -> float:
        """The pump's pressure limit A_d dy / C, [Pa] (module docstring)."""
        return self.piston_area * self.free_stroke / self.compliance

    @property
    def rod_force(self) -> float:
        """p_A (A_B - A_S): the accumulator's push down on a differential piston, [N]."""
        return self.accumulator_pressure * (self.big_area - self.small_area)

    @property
    def stall_load_down(self) -> float:
        """The largest load the pump moves down against, [N]."""
        return self.big_area * self.stall_pressure + self.rod_force

    @property
    def stall_load_up(self) -> float:
        """The smallest load (opposing down) the pump lifts, [N]."""
        return self.rod_force - self.small_area * self.stall_pressure

    def pressure_rise(self, load: float, direction: str) -> float:
        """dp the pump must deliver to move the cylinder ``direction`` at ``load``, [Pa]."""
        p = self.accumulator_pressure
        if direction == "down":
            return (load + p * self.small_area) / self.big_area - p
        return (p * self.big_area - load) / self.small_area - p

    def load_at(self, pressure_rise: float, direction: str) -> float:
        """The load [N] that the pressure rise ``pressure_rise`` [Pa] holds
        (:meth:`pressure_rise` inverted)."""
        p = self.accumulator_pressure
        if direction == "down":
            return (pressure_rise + p) * self.big_area - p * self.small_area
        return p * self.big_area - (pressure_rise + p) * self.small_area

    @property
    def cycle_stall_load_down(self) -> float:
        """The pump cycle's stall load down, [N]."""
        return self.load_at(self.cycle_stall_pressure_down, "down")

    @property
    def cycle_stall_load_up(self) -> float:
        """The pump cycle's stall load up, [N]."""
        return self.load_at(self.cycle_stall_pressure_up, "up")

    def cycle_velocity(self, load: float, direction: str) -> float:
        """The pump cycle's mean piston velocity at full drive, [m/s] (x grows down): its
        travel per cycle, affine in the pressure rise, times f; past the stall the load
        pushes the piston back through the pump."""
        down = direction == "down"
        stall = self.cycle_stall_pressure_down if down else self.cycle_stall_pressure_up
        slope = self.cycle_slope_down if down else self.cycle_slope_up
        travel = slope * (stall - self.pressure_rise(load, direction))
        return self.frequency * travel if down else -self.frequency * travel

    def velocity(self, load: float, direction: str) -> float:
        """The quasi-static piston velocity at full drive, [m/s] (x grows down): the cycle's
        volume f (A_d dy - C dp) over the filled cavity's area, 0 past the stall."""
        volume = max(self.piston_area * self.free_stroke
                     - self.compliance * self.pressure_rise(load, direction), 0.0)
        if direction == "down":
            return self.frequency * volume / self.big_area
        return 0.0 - self.frequency * volume / self.small_area  # 0.0, not -0.0, at a stall

    def as_dict(self) -> dict:
        d = asdict(self)
        d.update(stall_pressure=self.stall_pressure, blocked_force=self.blocked_force,
                 rod_force=self.rod_force, stall_load_down=self.stall_load_down,
                 stall_load_up=self.stall_load_up,
                 cycle_stall_load_down=self.cycle_stall_load_down,
                 cycle_stall_load_up=self.cycle_stall_load_up)
        return d


def pump_limits(frequency: float, mode: str, circuit: str = "realistic") -> PumpLimits:
    """The hand calculation for the paper's transducer (Table 2's K and A_d, the free
    stroke of :func:`smeha.studies.flow.free_dy`) on a named circuit
    (:mod:`system_models.presets`), the accumulator at the circuit's resting pressure."""
    import gmt

    from . import flow
    params = presets.circuit(circuit)
    rod = gmt.Transducer(excitation=gmt.Excitation(frequency, flow.CURRENT_AMPLITUDE)
                         ).rod_mechanics()
    chamber, cyl = params.chamber, params.cylinder
    p_a = float(initial_state(params)[0])
    beta = float(effective_bulk_modulus(params.fluid, p_a))
    area = chamber.piston_area
    compliance = area ** 2 / rod.stiffness + chamber.dead_volume / beta
    dy = flow.free_dy(frequency, mode)
    if not math.isfinite(dy):
        dy = 0.0
    cycle = {}
    for direction in ("down", "up"):
        model = cycle_model(frequency, mode, circuit, direction)
        stall, slope = model.travel_line()
        cycle[f"cycle_stall_pressure_{direction}"] = stall
        cycle[f"cycle_slope_{direction}"] = slope
        cycle["pressure_limit"] = model.pressure_limit
    return PumpLimits(frequency=float(frequency), mode=mode, circuit=circuit, free_stroke=dy,
                      stiffness=float(rod.stiffness), piston_area=area,
                      compliance=compliance, accumulator_pressure=p_a,
                      big_area=cyl.big_area, small_area=cyl.small_area, **cycle)
