"""The pump cycle's linear periodic model against closed forms, and the co-simulation's stall
loads against it."""
import math

import pytest

from smeha.studies import position
from smeha.studies.positionenvelope import tolerance
from smeha.studies.positionlimits import pump_limits
from smeha.studies.pumpcycle import CycleModel

#: Table 2's rod and piston, the study's chamber (2.5 cm^3 of 1.2 GPa oil) and its 20 mm
#: bore, 1 kg piston.
A_D, K, A_B = 1256e-6, 1.963e7, math.pi * 0.02 ** 2 / 4
C = A_D ** 2 / K + 2.5e-6 / 1.2e9


def model(**changes) -> CycleModel:
    base = dict(frequency=50.0, stroke=30e-6, phase=0.0, piston_area=A_D, rod_stiffness=K,
                rod_damping=0.0, chamber_compliance=2.5e-6 / 1.2e9,
                cavity_compliance=1e-3 * C, cavity_area=A_B, mass=1.0, friction=1500.0)
    return CycleModel(**{**base, **changes})


def test_without_a_drive_the_piston_gives_way_as_a_damped_oscillator_from_rest():
    # Y = 0: at the switch the load, held by P_s on the closed cavity, pushes the piston
    # back on the chamber's compliance: the step response of a damped one-degree system,
    # u = u_s (1 - exp(-z w t) (cos w_d t + z / sqrt(1 - z^2) sin w_d t)), u_s = C P_s / A_L
    # (Inman, Engineering Vibration, 4th ed. 2014, ch. 3), at the valves' closing t = T/2.
    # The closed cavity is nearly rigid (1e-3 C) and its ringing dies in the expansion
    # (exp(-b T / 4 m) = 6e-4), so 0.2 % holds the cavity's share of the pressure.
    m = model(stroke=0.0)
    hold = 3e5
    k = A_B ** 2 / C
    wn = math.sqrt(k / m.mass)
    z = m.friction / (2.0 * math.sqrt(k * m.mass))
    wd = wn * math.sqrt(1.0 - z * z)
    t = 0.5 / m.frequency
    u = C * hold / A_B * (1.0 - math.exp(-z * wn * t) * (math.cos(wd * t)
                                                         + z / math.sqrt(1 - z * z)
                                                         * math.sin(wd * t)))
    assert m.travel(hold) == pytest.approx(u, rel=2e-3)
    assert m.swing_frequency == pytest.approx(wn / (2 * math.pi), rel=1e-12)


def test_a_light_piston_gives_the_quasi_static_cycle():
    # m -> 0 (critically damped, 1e-6 kg: it follows the oil within microseconds) and a
    # compliant cavity: the cavity's oil returns each cycle what it takes, so the travel
    # is the quasi-static du = (C P_s - A_d Y cos phi) / A_L (Merritt, Hydraulic Control
    # Systems, 1967, sec. 2.5: the chamber's compliance C = A_d^2 / K + V_c / beta)
    k = A_B ** 2 / C
    m = model(mass=1e-6, friction=2.0 * math.sqrt(k * 1e-6), cavity_compliance=0.1 * C,
              phase=0.5, rod_damping=2945.0)
    for hold in (0.0, 2e5, 6e5):
        expected = (C * hold - A_D * 30e-6 * math.cos(0.5)) / A_B
        assert m.travel(hold) == pytest.approx(expected, rel=1e-2, abs=1e-3 * A_D * 30e-6 / A_B)
    assert m.stall_pressure() == pytest.approx(m.quasi_static_stall_pressure(), rel=1e-2)


def test_the_model_refuses_a_massless_piston():
    with pytest.raises(ValueError, match="mass"):
        model(mass=0.0)


@pytest.mark.integration
@pytest.mark.parametrize("circuit", ["differential", "realistic"])
def test_the_co_simulation_stalls_up_where_the_pump_cycle_does(circuit):
    # compensated, 100 Hz: the quasi-static hand calculation puts the stall up at 7 N
    # (differential) and 10 N (realistic), the co-simulation at 35 and 36 N; the pump cycle
    # at 35.0 and 37.1 N. At the hand's stall load less (more) the tolerance, 0.1 p_lim A_S
    # (11 N: module positionenvelope), full drive up lets the piston sink (lifts it; x grows
    # down, the load opposes down): the co-simulation's stall lies within the tolerance
    s = position.PositionSettings(frequency=100.0, circuit=circuit, backend="direct")
    hand = pump_limits(100.0, "compensated", circuit)
    stall, tol = hand.cycle_stall_load_up, tolerance(hand, "up")
    assert abs(stall - hand.stall_load_up) > 2.0 * tol  # the quasi-static one would fail
    assert position.full_drive_velocity(s, "up", stall - tol) > 0.0
    assert position.full_drive_velocity(s, "up", stall + tol) < 0.0
