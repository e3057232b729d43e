"""The transducer's rod as the plant carries it: eq 27 driven by the magnetostrictive force.

In the force-port coupling (:mod:`system_models.cosim`) the transducer FMU
delivers the magnetostrictive force F = A_r E^H lambda (paper, eq 28), which
does not depend on the rod's motion (eqs 1-26, 28, 31-37 contain no y), and
the plant integrates the rod together with the pump chamber it drives: the
rod and the chamber's oil form the stiff ~30 kHz mode, which an implicit
integrator then steps as one system.

One mass (paper, eq 27, with the chamber's force as the external load)::

    m y'' + c y' + K y = F - A_d p_P

Two masses (rod m_1 on the transducer's c and K, output m_2 on a joint k_j,
c_j; the standard two-degree-of-freedom model, e.g. Thomson & Dahleh, *Theory
of Vibration with Applications*, 5th ed. 1998, ch. 5), the pump piston on the
output::

    m_1 y_1'' + c y_1' + K y_1 + c_j (y_1' - y_2') + k_j (y_1 - y_2) = F
    m_2 y_2'' + c_j (y_2' - y_1') + k_j (y_2 - y_1) = -A_d p_P

The values come from the transducer (its FMU's calculated parameters, see
:meth:`gmt.Transducer.rod_mechanics`), so the plant and the transducer share
one set of mechanics. States, SI: (y, v) for one mass; (y_1, v_1, y_2, v_2)
for two, the chamber moving with (y_2, v_2).
"""
from __future__ import annotations

from dataclasses import dataclass

from gmt.errors import check_range

from ._jit import jitable


@dataclass(frozen=True)
class RodParameters:
    """Mechanics of the rod (SI); the fields of :class:`gmt.RodMechanics`.

    Attributes
    ----------
    mass, damping, stiffness : float
        m [kg] (the rod's m_1 with two masses), c [N s/m], K [N/m] of eq 27;
        default Table 2.
    output_mass : float
        m_2, [kg]; 0 for one mass.
    joint_stiffness, joint_damping : float
        k_j [N/m] and c_j [N s/m] of the joint (two masses only).
    """

    mass: float = 0.02
    damping: float = 2945.0
    stiffness: float = 1.963e7
    output_mass: float = 0.0
    joint_stiffness: float = 0.0
    joint_damping: float = 0.0

    def __post_init__(self):
        check_range("mass", self.mass, 0.0, 1e6, unit="kg")
        check_range("damping", self.damping, 0.0, 1e12, unit="N s/m", low_open=False)
        check_range("stiffness", self.stiffness, 0.0, 1e15, unit="N/m")
        check_range("output_mass", self.output_mass, 0.0, 1e6, unit="kg", low_open=False)
        if self.output_mass > 0.0:
            check_range("joint_stiffness", self.joint_stiffness, 0.0, 1e15, unit="N/m")
        check_range("joint_damping", self.joint_damping, 0.0, 1e12, unit="N s/m",
                    low_open=False)

    @classmethod
    def of(cls, mechanics) -> "RodParameters":
        """From a :class:`gmt.RodMechanics` (or any 3- or 6-sequence in its order)."""
        return cls(*(float(v) for v in mechanics))

    @property
    def size(self) -> int:
        """Number of states: 2 (y, v) or 4 (y_1, v_1, y_2, v_2)."""
        return 4 if self.output_mass > 0.0 else 2

    def rest_state(self, displacement: float) -> tuple:
        """At rest at ``displacement`` [m] (both masses there)."""
        return (displacement, 0.0) * (self.size // 2)

    def loaded_state(self, displacement: float, force: float) -> tuple:
        """At rest under ``force`` [N] on the output (the chamber's A_d p_P, opposing
        elongation), ``displacement`` [m] being the rest without it: the statics of the
        equations above, K y_1 = K y_free - F, and with two masses k_j (y_1 - y_2) = F."""
        y1 = displacement - force / self.stiffness
        if self.size == 2:
            return (y1, 0.0)
        return (y1, 0.0, y1 - force / self.joint_stiffness, 0.0)

    def static_deflection(self, force: float) -> float:
        """How far ``force`` [N] on the output pushes the output back at rest, [m]
        (:meth:`loaded_state`)."""
        deflection = force / self.stiffness
        return deflection if self.size == 2 else deflection + force / self.joint_stiffness


@jitable
def rod_rates(y1, v1, y2, v2, force, external_force, mass, damping, stiffness, output_mass,
              joint_stiffness, joint_damping):
    """Time derivatives of the rod's states, [m/s, m/s^2].

    ``force`` F drives the rod; ``external_force`` (A_d p_P) opposes the
    output's elongation, on the rod itself when ``output_mass`` is 0 (then
    y2, v2 are ignored and their rates are 0).

    Returns
    -------
    (float, float, float, float)
        dy_1/dt, dv_1/dt, dy_2/dt, dv_2/dt.
    """
    if output_mass > 0.0:
        joint = joint_stiffness * (y1 - y2) + joint_damping * (v1 - v2)
        return (v1, (force - stiffness * y1 - damping * v1 - joint) / mass,
                v2, (joint - external_force) / output_mass)
    return (v1, (force - external_force - stiffness * y1 - damping * v1) / mass, 0.0, 0.0)
