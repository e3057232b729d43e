"""Truth of ``mechanical_resonance``: the rod and an output mass on a compliant joint.

Two masses, the sensor on the second (G. Engdahl (ed.), *Handbook of Giant
Magnetostrictive Materials*, Academic Press 2000, ch. 4).
"""
from __future__ import annotations

import numpy as np

from gmt.forward import bias_displacement

from .foh import foh_response

__all__ = ["two_mass_matrices", "two_mass_response"]

def two_mass_matrices(rod_mass, damping, stiffness, output_mass, joint_stiffness,
                      joint_damping):
    """Continuous state-space (A, B) of the rod + output-mass model.

    State x = [y_1, v_1, y_2, v_2] (rod end, output mass), input the
    magnetostrictive force F on the rod (eq 28)::

        m_1 y_1'' = F - K y_1 - c y_1' - k_j (y_1 - y_2) - c_j (y_1' - y_2')
        m_2 y_2'' = k_j (y_1 - y_2) + c_j (y_1' - y_2')

    With k_j, c_j -> inf the joint is rigid and this is eq 27 with
    m = m_1 + m_2.
    """
    m1, m2, k, c, kj, cj = rod_mass, output_mass, stiffness, damping, joint_stiffness, joint_damping
    a = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-(k + kj) / m1, -(c + cj) / m1, kj / m1, cj / m1],
        [0.0, 0.0, 0.0, 1.0],
        [kj / m2, cj / m2, -kj / m2, -cj / m2],
    ])
    b = np.array([0.0, 1.0 / m1, 0.0, 0.0])
    return a, b


def two_mass_response(force, step, params, truth, paper_displacement):
    """Output-mass displacement y_2 at t_k, [m].

    The force of a sinusoidal current is smooth, so it is taken linear between
    samples (first-order hold, :func:`foh_response`): a held force would ring
    the lightly damped joint at every sample. The truth is

        y_2 = y_paper + [y_2 of the two-mass model - y of eq 27 with m = m_1 + m_2],

    both bracketed responses to the same interpolated force F - F_bias,
    starting in static equilibrium with the first force: the continuous paper model
    (``paper_displacement``) plus what the compliant joint changes. As k_j -> inf
    the bracket vanishes.
    """
    m2 = truth["output_mass"]
    a2, b2 = two_mass_matrices(params.mass - m2, params.damping, params.stiffness, m2,
                               truth["joint_stiffness"], truth["joint_damping"])
    a1 = np.array([[0.0, 1.0], [-params.stiffness / params.mass, -params.damping / params.mass]])
    b1 = np.array([0.0, 1.0 / params.mass])
    u = np.asarray(force, dtype=float) - bias_displacement(params) * params.stiffness
    # both start in static equilibrium with the first force (the joint is
    # unloaded at rest), so the bracket starts at 0 and holds no start step
    y_start = u[0] / params.stiffness
    y2 = foh_response(a2, b2, [0.0, 0.0, 1.0, 0.0], u, step,
                       x0=[y_start, 0.0, y_start, 0.0])
    y1 = foh_response(a1, b1, [1.0, 0.0], u, step, x0=[y_start, 0.0])
    return paper_displacement + (y2 - y1)
