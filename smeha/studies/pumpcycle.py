"""The pump cycle with the cylinder's piston in it: the stall loads of a linear periodic model.

The quasi-static pressure limit (:mod:`smeha.studies.positionlimits`) takes the cylinder's
piston to follow the oil at every instant. It does not on the study's cylinder: its 1 kg
rides on the pump's compliance, and each valve switch starts a swing. At the switch into
compression the loaded cavity L (the big one down, the small one up) joins the chamber,
which comes from the accumulator at p_A. The piston, held so far by the closed cavity at
p_A + P_s (P_s the pressure rise that holds the load), is pushed back by P_s A_L and swings
on the stiffness A_L^2 / C at w_n = A_L / sqrt(m C) (130-170 Hz on the study's circuits),
damped by its friction b. The valves close at the stroke's end wherever the swing has
carried it, and the piston stays there on the closed cavity's oil. So the stroke per cycle
depends on the swing's phase at the valve switch: at 20 Hz the swing has died out
(quasi-static), at 100-200 Hz it has not.

The model (SI): u the piston's travel that shrinks L, w = du/dt, P = p_L - p_A, E the
rod's elastic deflection beyond its rest at p_A. In compression (L joined to the chamber;
the other cavity and the chamber's other side at p_A):

    m w' = A_L (P_s - P) - b w                        (the piston; Merritt ch. 5)
    c E' = -(K E + A_d P)                             (the rod, eq 27 without its mass)
    C_o P' = A_d (y_f' + E') + A_L w,   C_o = (V_c + V_L) / beta
                                                      (continuity; Merritt sec. 2.5)

y_f the free rod, its fundamental y_f = -(Y/2) cos(w t - phi) from the compression
window's start (Y the free rod's peak-to-peak, phi its lag behind the drive less the
valves' dead time w t_d: the window opens t_d after the drive's extreme). In expansion (L
closed, the chamber at p_A):

    m w' = A_L (P_s - P) - b w,     C_L P' = A_L w,   C_L = V_L / beta

At the switch into compression the cavity's oil shares its pressure with the chamber's,
P -> C_L P / C_o, and the rod starts relaxed (E = 0: it relaxes in c / K = 0.15 ms). Each
phase is linear with constant coefficients, so its flow over half a period is a matrix
exponential (the drive's sine and cosine and the constant carried as states; the
state-transition matrix of a time-invariant linear system: Ogata, *Modern Control
Engineering*, 5th ed. 2010, ch. 9). The period's map is the product of the two phases'
(the monodromy matrix of Floquet theory) and the steady cycle its fixed point in
(w, P, E); the piston's travel over it, du, is affine in P_s, and the pump stalls where
du = 0. With m -> 0 and c -> 0 it is the quasi-static limit,
du = (C P_s - A_d Y cos phi) / A_L with C = A_d^2 / K + V_c / beta (the cavity's oil
returns each cycle what it takes).

What it leaves out: the orifices' resistance (kPa at these flows), the rod's mass (its
own mode is over-damped at ~5 kHz), the accumulator's pressure swing (50 cm^3 of gas: ~2 kPa),
the oil's pressure-dependent modulus (beta at p_A), and harmonics of the free rod.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from gmt.errors import check_range

__all__ = ["CycleModel", "cycle_model", "free_rod_fundamental"]

#: State order of the period map: travel, velocity, pressure, rod deflection, the drive's
#: sine and cosine, and the constant 1 (which carries P_s).
_U, _W, _P, _E, _S, _C, _ONE = range(7)


@dataclass(frozen=True, kw_only=True)
class CycleModel:
    """One direction of the pump on the cylinder (SI; module docstring)."""

    frequency: float  #: pump frequency f, [Hz]
    stroke: float  #: Y, the free rod's peak-to-peak (fundamental), [m]
    phase: float  #: phi, the free rod's lag behind the compression window's start, [rad]
    piston_area: float  #: A_d, [m^2]
    rod_stiffness: float  #: K, [N/m]
    rod_damping: float  #: c, [N s/m]
    chamber_compliance: float  #: V_c / beta, [m^3/Pa]
    cavity_compliance: float  #: V_L / beta of the loaded cavity, [m^3/Pa]
    cavity_area: float  #: A_L, [m^2]
    mass: float  #: m of the cylinder's piston and load, [kg]
    friction: float  #: b, [N s/m]

    def __post_init__(self):
        check_range("frequency", self.frequency, 0.0, 1e5, unit="Hz")
        check_range("stroke", self.stroke, 0.0, 1e-2, unit="m", low_open=False)
        for name in ("piston_area", "rod_stiffness", "chamber_compliance",
                     "cavity_compliance", "cavity_area", "mass"):
            check_range(name, getattr(self, name), 0.0, math.inf)
        for name in ("rod_damping", "friction"):
            check_range(name, getattr(self, name), 0.0, math.inf, low_open=False)

    @property
    def compliance(self) -> float:
        """C = A_d^2 / K + V_c / beta, the chamber's with the rod, [m^3/Pa]."""
        return self.piston_area ** 2 / self.rod_stiffness + self.chamber_compliance

    @property
    def swing_frequency(self) -> float:
        """A_L / sqrt(m C) / (2 pi): the piston on the pump's compliance, undamped, [Hz]."""
        return self.cavity_area / math.sqrt(self.mass * self.compliance) / (2.0 * math.pi)

    @property
    def pressure_limit(self) -> float:
        """A_d Y / C: the largest pressure rise the rod's whole stroke makes, [Pa]."""
        return self.piston_area * self.stroke / self.compliance

    def quasi_static_stall_pressure(self) -> float:
        """A_d Y cos(phi) / C: the limit m -> 0, c -> 0 (module docstring), [Pa]."""
        return self.pressure_limit * math.cos(self.phase)

    def _phases(self, hold: float):
        """The compression and expansion matrices and the jump into compression."""
        m, b, a_l, a_d = self.mass, self.friction, self.cavity_area, self.piston_area
        k, c, w = self.rod_stiffness, self.rod_damping, 2.0 * math.pi * self.frequency
        c_o = self.chamber_compliance + self.cavity_compliance
        comp, exp = np.zeros((7, 7)), np.zeros((7, 7))
        for a in (comp, exp):
            a[_U, _W] = 1.0
            a[_W, _W], a[_W, _P], a[_W, _ONE] = -b / m, -a_l / m, a_l * hold / m
            a[_S, _C], a[_C, _S] = w, -w
        drive = a_d * 0.5 * self.stroke * w  # A_d y_f' = drive * sin(w t - phi)
        jump = np.eye(7)
        jump[_E, _E] = 0.0
        if c > 0.0:
            comp[_E, _E], comp[_E, _P] = -k / c, -a_d / c
            comp[_P] = a_d * comp[_E] / c_o
            comp[_P, _S] += drive / c_o
            comp[_P, _W] += a_l / c_o
            jump[_P, _P] = self.cavity_compliance / c_o
        else:  # the rod at rest under the chamber's pressure: its compliance joins the oil's
            comp[_P, _S], comp[_P, _W] = drive / (c_o + a_d ** 2 / k), a_l / (c_o + a_d ** 2 / k)
            jump[_P, _P] = self.cavity_compliance / (c_o + a_d ** 2 / k)
        exp[_P, _W] = a_l / self.cavity_compliance
        return comp, exp, jump

    def travel(self, hold: float) -> float:
        """du over the steady cycle with the load held by ``hold`` = P_s [Pa], [m]
        (positive: the piston gives way to the load)."""
        comp, exp, jump = self._phases(hold)
        half = 0.5 / self.frequency
        period_map = expm(exp * half) @ expm(comp * half) @ jump
        drive = np.array([math.sin(-self.phase), math.cos(-self.phase), 1.0])
        inner, outer = [_W, _P, _E], [_S, _C, _ONE]
        z = np.linalg.solve(np.eye(3) - period_map[np.ix_(inner, inner)],
                            period_map[np.ix_(inner, outer)] @ drive)
        start = np.zeros(7)
        start[inner], start[outer] = z, drive
        return float((period_map @ start)[_U])

    def travel_line(self) -> tuple[float, float]:
        """du = slope (P_s - stall): the stall pressure [Pa] and the slope [m/Pa] (du is
        affine in P_s: the model is linear and P_s enters as a constant force)."""
        scale = max(abs(self.pressure_limit), 1.0)
        at_zero, at_scale = self.travel(0.0), self.travel(scale)
        slope = (at_scale - at_zero) / scale
        return -at_zero / slope, slope

    def stall_pressure(self) -> float:
        """P_s at which the steady cycle's travel is zero, [Pa]."""
        return self.travel_line()[0]


def free_rod_fundamental(frequency: float, mode: str) -> tuple[float, float]:
    """The free rod's peak-to-peak Y [m] and lag phi [rad] behind the valves' switch at
    the drive's extreme, from the transducer alone: uncompensated the fundamental of eq
    30's periodic solution (the current i = I_m cos w t); compensated the inverse makes
    the rod follow the demand, phi = 0 and Y the stroke between the switches
    (:func:`smeha.studies.flow.free_dy`)."""
    import gmt
    from gmt.forward import periodic_response

    from . import flow
    if mode == "compensated":
        return flow.free_dy(frequency, mode), 0.0
    params = gmt.TransducerParameters()
    point = gmt.operating_point(params, gmt.Excitation(frequency, flow.CURRENT_AMPLITUDE))
    samples = 1024
    t = np.arange(samples) / (samples * frequency)
    y = periodic_response(params, point, t)["displacement"]
    phasor = 2.0 / samples * np.sum(y * np.exp(-2j * math.pi * frequency * t))
    return 2.0 * abs(phasor), float(-np.angle(phasor))


def cycle_model(frequency: float, mode: str, circuit: str, direction: str) -> CycleModel:
    """The model of one direction on a named circuit (:mod:`system_models.presets`): the
    cavity at mid-stroke, the oil's modulus at the accumulator's resting pressure, the
    rod's K and c from the transducer (Table 2)."""
    import gmt
    from system_models import presets
    from system_models.circuit import initial_state
    from system_models.controller import dead_times
    from system_models.cylinder import cavity_volumes
    from system_models.fluid import effective_bulk_modulus

    from . import flow
    params = presets.circuit(circuit)
    cyl = params.cylinder
    rod = gmt.Transducer(excitation=gmt.Excitation(frequency, flow.CURRENT_AMPLITUDE)
                         ).rod_mechanics()
    beta = float(effective_bulk_modulus(params.fluid, float(initial_state(params)[0])))
    big, small = cavity_volumes(cyl, 0.5 * cyl.stroke)
    volume, area = (big, cyl.big_area) if direction == "down" else (small, cyl.small_area)
    stroke, lag = free_rod_fundamental(frequency, mode)
    dead = max(dead_times(params.valves))
    return CycleModel(frequency=float(frequency), stroke=stroke,
                      phase=lag - 2.0 * math.pi * frequency * dead,
                      piston_area=params.chamber.piston_area,
                      rod_stiffness=float(rod.stiffness), rod_damping=float(rod.damping),
                      chamber_compliance=params.chamber.dead_volume / beta,
                      cavity_compliance=volume / beta, cavity_area=area, mass=cyl.mass,
                      friction=cyl.friction)
