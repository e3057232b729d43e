"""Mechanical resonance: the mechanics of eq 27 re-identified, or two masses on a joint.

Eq 27 lumps rod, output rod and load into one mass-spring-damper. Two
formulations of what it may miss, each one extension of the cause
``mechanical_resonance``:

* ``one_dof`` (:class:`MechanicsForm`): eq 27 with its own m, c, K
  (:class:`ReidentifiedMechanics`); the blocked force A_r E^H lambda (eq 28)
  is the rod's and keeps Table 2's E^H;
* ``two_dof`` (:class:`TwoMassForm`): the rod m_1 (with eq 27's c and K) and
  an output mass m_2 on a compliant joint k_j, c_j, the sensor and the load on
  the output (:class:`TwoMassMechanics`; Thomson & Dahleh, *Theory of
  Vibration with Applications*, 5th ed., Prentice Hall 1998, ch. 5).

Periodic forms: the continuous frequency responses (or, at a step h, their ZOH
sampled versions). Time-stepped forms: the exact ZOH of eq 27 with the new
m, c, K (:func:`gmt.mechanics.zoh_matrices`), and for the two masses the exact
ZOH of the 4-state model with two held inputs, the magnetostrictive force on
the rod and the external force on the output, by one matrix exponential of
the augmented system (C. F. Van Loan, IEEE Trans. Autom. Control 23 (1978)
395-404; :func:`gmt.extensions._numerics.expm`).

Two masses: where the outputs and the load are
----------------------------------------------
The diagnosis compares the output m_2's displacement with the measured y:
the displacement sensor sits on the output. The pump's piston, and so the
chamber's force, is on the output too. The two-mass form therefore applies
the external force to m_2 and reports the output's y_2, v_2 as
``displacement`` and ``velocity``; the rod's y_1, v_1 are its memory.
Statically y_1 = (F - F_ext)/K and y_2 = y_1 - F_ext/k_j: the joint yields
under the load.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ParameterError, check_range
from ._base import Y_LINEAR_LOOKALIKE, Extension, FitSpec, Parameter, agrees
from ._numerics import expm
from .steady import mechanics_response


@dataclass(frozen=True)
class ReidentifiedMechanics:
    """Eq 27 with re-identified m, c, K (one degree of freedom).

    The blocked force A_r E^H lambda (eq 28) is the rod's and keeps Table 2's
    E^H; m, c, K are those of the mass-spring-damper the force drives, so a
    compliant output joint or an added mass shows as another m, c (a resonance
    moving into the band shows as amplitude rising with f).

    Attributes
    ----------
    mass, damping, stiffness : float
        m [kg], c [N s/m], K [N/m].
    """

    mass: float
    damping: float
    stiffness: float

    def __post_init__(self):
        check_range("mass", self.mass, 0.0, math.inf, unit="kg")
        check_range("damping", self.damping, 0.0, math.inf, unit="N s/m", low_open=False)
        check_range("stiffness", self.stiffness, 0.0, math.inf, unit="N/m")

    def response(self, angular_frequency, step=None):
        """Y/F at w, [m/N]: continuous, or the ZOH-sampled model at ``step`` [s]."""
        return mechanics_response(self.mass, self.damping, self.stiffness,
                                  angular_frequency, step)


@dataclass(frozen=True)
class TwoMassMechanics:
    """Rod and output mass joined by a compliant joint: two degrees of freedom.

    Eq 27 lumps rod, output rod and load into one mass. When the joint
    between the rod's end and the output (a push rod, a piston, a bolted or
    glued interface) is compliant, the output mass m_2 moves on its own
    spring k_j and damper c_j (the standard two-degree-of-freedom model of
    vibration texts, e.g. Thomson & Dahleh, *Theory of Vibration with
    Applications*, 5th ed. 1998, ch. 5; Inman, *Engineering Vibration*,
    ch. 4). With the magnetostrictive force F on the rod (eq 28) and the
    sensor on the output:

        m_1 y_1'' + c y_1' + K y_1 + c_j (y_1' - y_2') + k_j (y_1 - y_2) = F
        m_2 y_2'' + c_j (y_2' - y_1') + k_j (y_2 - y_1) = 0

    In the frequency domain (dynamic stiffness D = K - m w^2 + j w c)

        Y_2 / F = Z_j / [(D_1 + Z_j)(D_2 + Z_j) - Z_j^2],
        Z_j = k_j + j w c_j, D_1 = K - m_1 w^2 + j w c, D_2 = -m_2 w^2,

    which tends to eq 27's 1/(K - (m_1 + m_2) w^2 + j w c) as the joint
    stiffens (Z_j -> inf), and has the same static compliance 1/K.

    Attributes
    ----------
    rod_mass, output_mass : float
        m_1, m_2, [kg].
    damping, stiffness : float
        c [N s/m] and K [N/m] of the rod and prestress spring (eq 27).
    joint_stiffness, joint_damping : float
        k_j [N/m], c_j [N s/m].
    """

    rod_mass: float
    output_mass: float
    damping: float
    stiffness: float
    joint_stiffness: float
    joint_damping: float

    def __post_init__(self):
        for name, unit in (("rod_mass", "kg"), ("output_mass", "kg"), ("stiffness", "N/m"),
                           ("joint_stiffness", "N/m")):
            check_range(name, getattr(self, name), 0.0, math.inf, unit=unit)
        for name in ("damping", "joint_damping"):
            check_range(name, getattr(self, name), 0.0, math.inf, unit="N s/m",
                        low_open=False)

    @classmethod
    def from_joint(cls, mass, damping, stiffness, output_fraction, joint_frequency,
                   joint_damping_ratio):
        """From the moving mass ``mass`` = m_1 + m_2, eq 27's c and K, the output's share
        m_2/(m_1 + m_2), and the joint's own mode.

        The joint's natural frequency is that of m_2 on k_j with the rod held,
        f_j = sqrt(k_j/m_2)/(2 pi) [Hz], and its damping ratio
        c_j / (2 sqrt(k_j m_2)).
        """
        check_range("output_fraction", output_fraction, 0.0, 1.0)
        m2 = mass * output_fraction
        kj = m2 * (2.0 * math.pi * joint_frequency) ** 2
        return cls(mass - m2, m2, damping, stiffness, kj,
                   2.0 * joint_damping_ratio * math.sqrt(kj * m2))

    def matrices(self):
        """Continuous (A, B, C), x = [y_1, v_1, y_2, v_2], input F, output y_2."""
        m1, m2, c, k = self.rod_mass, self.output_mass, self.damping, self.stiffness
        kj, cj = self.joint_stiffness, self.joint_damping
        a = np.array([[0.0, 1.0, 0.0, 0.0],
                      [-(k + kj) / m1, -(c + cj) / m1, kj / m1, cj / m1],
                      [0.0, 0.0, 0.0, 1.0],
                      [kj / m2, cj / m2, -kj / m2, -cj / m2]])
        return a, np.array([0.0, 1.0 / m1, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, 0.0])

    def zoh_matrices(self, step):
        """Exact ZOH discretisation (A_d, B_d) for one step h, F held over it.

        From one matrix exponential of the augmented system (Van Loan 1978;
        Franklin, Powell & Workman, *Digital Control of Dynamic Systems*,
        sec. 4.3): exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, 1]].
        """
        a, b, _ = self.matrices()
        aug = np.zeros((5, 5))
        aug[:4, :4] = a
        aug[:4, 4] = b
        e = expm(aug * step)
        return e[:4, :4], e[:4, 4]

    def response(self, angular_frequency, step=None):
        """Y_2/F at w, [m/N]: continuous, or the ZOH-sampled model at ``step`` [s].

        The sampled form is C (z I - A_d)^-1 B_d at z = e^{j w h}, with y_2 the
        state at the start of the step, as
        :func:`gmt.extensions.steady.mechanics_response` gives for eq 27.
        """
        w = np.atleast_1d(np.asarray(angular_frequency, dtype=float))
        if w.ndim > 1:
            return self.response(w.ravel(), step).reshape(w.shape)
        if step is None:
            zj = self.joint_stiffness + 1j * w * self.joint_damping
            d1 = self.stiffness - self.rod_mass * w * w + 1j * w * self.damping
            d2 = -self.output_mass * w * w
            return zj / ((d1 + zj) * (d2 + zj) - zj * zj)
        z = np.exp(1j * w * step)
        modes = _two_mass_modes(self)
        if modes is not None:
            # A = V diag(l) V^-1: A_d = V e^{L h} V^-1, B_d = V diag((e^{l h} - 1)/l) V^-1 B,
            # C (z I - A_d)^-1 B_d = sum_i r_i (e^{l_i h} - 1) / (l_i (z - e^{l_i h})),
            # r_i = (C V)_i (V^-1 B)_i
            lam, res = modes
            gain = res * np.expm1(lam * step) / lam
            return (gain[None, :] / (z[:, None] - np.exp(lam * step)[None, :])).sum(axis=1)
        ad, bd = self.zoh_matrices(step)  # (nearly) repeated eigenvalues
        _, _, c = self.matrices()
        lhs = z[:, None, None] * np.eye(4) - ad
        x = np.linalg.solve(lhs, np.broadcast_to(bd.astype(complex), (w.size, 4))[..., None])
        return x[:, :, 0] @ c


@lru_cache(maxsize=64)
def _two_mass_modes(system: TwoMassMechanics):
    """Eigenvalues l_i of A and residues (C V)_i (V^-1 B)_i; None when A is (nearly) defective."""
    a, b, c = system.matrices()
    lam, vec = np.linalg.eig(a)
    if not np.linalg.cond(vec) < 1e8:
        return None
    return lam, (c @ vec) * np.linalg.solve(vec, b.astype(complex))


class MechanicsForm(Extension):
    """Eq 27 with re-identified m, c, K (:class:`ReidentifiedMechanics`).

    The diagnosis fits m/m_0, c/c_0 and K/K_0 against Table 2's values. The
    time-stepped form steps eq 27's ZOH with the new m, c, K, and its rest
    state is the bias force over the new K.
    """

    cause = "mechanical_resonance"
    form = "one_dof"
    stage = "mechanics"
    signals = "y only"
    lookalike = Y_LINEAR_LOOKALIKE
    parameters = (Parameter("mass_kg", "kg", 0.0, math.inf),
                  Parameter("damping_N_s_per_m", "N s/m", 0.0, math.inf, low_open=False),
                  Parameter("stiffness_N_per_m", "N/m", 0.0, math.inf))
    fit = FitSpec(("m/m0", "c/c0", "K/K0"), ((1.0, 1.0, 1.0), (3.0, 0.5, 1.0),
                                             (0.5, 2.0, 1.0)),
                  (0.02, 0.02, 0.3), (50.0, 50.0, 3.0), neutral=(1.0, 1.0, 1.0))

    @classmethod
    def validate(cls, values):
        cls.mechanics_of(values)

    @staticmethod
    def mechanics_of(values) -> ReidentifiedMechanics:
        return ReidentifiedMechanics(values["mass_kg"], values["damping_N_s_per_m"],
                                     values["stiffness_N_per_m"])

    @classmethod
    def from_fit(cls, x, context):
        p = context["params"]
        return {"mass_kg": p.mass * x[0], "damping_N_s_per_m": p.damping * x[1],
                "stiffness_N_per_m": p.stiffness * x[2]}

    @classmethod
    def steady_mechanics(cls, values, params, angular_frequencies, step=None):
        return cls.mechanics_of(values).response(angular_frequencies, step)

    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        mech = self.mechanics_of(values)
        self.mechanics = (mech.mass, mech.damping, mech.stiffness)


class TwoMassForm(Extension):
    """Rod and output mass on a compliant joint (:class:`TwoMassMechanics`).

    eq 27's c and K (the transducer's ``damping`` and ``stiffness``) act on the
    rod m_1, the output m_2 rides on the joint k_j, c_j. The diagnosis fits the
    output's share m_2/M of the moving mass M = m_1 + m_2, log10 of the joint's
    frequency sqrt(k_j/m_2)/(2 pi) [Hz], its damping ratio, and M over eq 27's m:
    a load carried on a joint adds its mass to the transducer's own (labsim's output
    mass, 50 g on Table 2's 20 g: with M held at m the fit pressed the output's share
    on its bound and, without a sense voltage, the resonance beside saturation or eddy
    currents was ``unexplained``). The time-stepped form advances
    x = [y_1, v_1, y_2, v_2] (module docstring); memory: the rod's y_1 [m],
    v_1 [m/s].
    """

    cause = "mechanical_resonance"
    form = "two_dof"
    stage = "mechanics"
    signals = "y only"
    parameters = (Parameter("rod_mass_kg", "kg", 0.0, math.inf),
                  Parameter("output_mass_kg", "kg", 0.0, math.inf),
                  Parameter("joint_stiffness_N_per_m", "N/m", 0.0, math.inf),
                  Parameter("joint_damping_N_s_per_m", "N s/m", 0.0, math.inf,
                            low_open=False),
                  Parameter("joint_frequency_Hz", "Hz", 0.0, math.inf, optional=True),
                  Parameter("joint_damping_ratio", "-", 0.0, math.inf, low_open=False,
                            optional=True))
    fit = FitSpec(("m2/M", "log10_f_joint_Hz", "zeta_joint", "M/m"),
                  ((0.5, 2.7, 0.1, 1.0), (0.3, 3.0, 0.3, 1.0), (0.7, 2.4, 0.05, 1.0),
                   (0.7, 2.7, 0.1, 3.0)),
                  (0.02, 1.5, 0.005, 0.5), (0.98, 4.5, 3.0, 10.0),
                  neutral=(0.02, 4.5, 0.1, 1.0))

    @classmethod
    def validate(cls, values):
        m2, kj = values["output_mass_kg"], values["joint_stiffness_N_per_m"]
        if "joint_frequency_Hz" in values:
            agrees(cls.cause, "joint_frequency_Hz", values, "Hz",
                   math.sqrt(kj / m2) / (2.0 * math.pi),
                   "sqrt(joint_stiffness_N_per_m / output_mass_kg) / (2 pi)")
        if "joint_damping_ratio" in values:
            agrees(cls.cause, "joint_damping_ratio", values, "",
                   values["joint_damping_N_s_per_m"] / (2.0 * math.sqrt(kj * m2)),
                   "joint_damping_N_s_per_m / (2 sqrt(joint_stiffness_N_per_m "
                   "output_mass_kg))")

    @classmethod
    def from_fit(cls, x, context):
        p = context["params"]
        m = TwoMassMechanics.from_joint(p.mass * x[3], p.damping, p.stiffness, x[0],
                                        10.0 ** x[1], x[2])
        return {"rod_mass_kg": m.rod_mass, "output_mass_kg": m.output_mass,
                "joint_stiffness_N_per_m": m.joint_stiffness,
                "joint_damping_N_s_per_m": m.joint_damping,
                "joint_frequency_Hz": 10.0 ** x[1], "joint_damping_ratio": x[2]}

    @staticmethod
    def system_of(values, params) -> TwoMassMechanics:
        return TwoMassMechanics(values["rod_mass_kg"], values["output_mass_kg"],
                                params.damping, params.stiffness,
                                values["joint_stiffness_N_per_m"],
                                values["joint_damping_N_s_per_m"])

    @classmethod
    def steady_mechanics(cls, values, params, angular_frequencies, step=None):
        return cls.system_of(values, params).response(angular_frequencies, step)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.system = self.system_of(values, params)
        # eq 27's K carries the rest: both masses at the bias force over K
        self.mechanics = (values["rod_mass_kg"] + values["output_mass_kg"], params.damping,
                          params.stiffness)
        self.rod_displacement, self.rod_velocity = 0.0, 0.0

    def zoh(self, step):
        """(A_d, B_d) of x = [y_1, v_1, y_2, v_2] for F on the rod and F_ext on the output, held."""
        return _two_mass_zoh(self.system, float(step))

    def advance(self, stepper, force, current, step, external_force):
        """Both masses over one step by the exact ZOH, F and F_ext held."""
        ad, bd = self.zoh(step)
        x = np.array((self.rod_displacement, self.rod_velocity, stepper.displacement,
                      stepper.velocity))
        x = ad @ x + bd @ np.array((float(force), external_force))
        (self.rod_displacement, self.rod_velocity, stepper.displacement,
         stepper.velocity) = (float(v) for v in x)

    def reset(self, rest_displacement):
        self.rod_displacement, self.rod_velocity = float(rest_displacement), 0.0

    def get_state(self):
        return (self.rod_displacement, self.rod_velocity)

    def set_state(self, state):
        if len(state) != 2:
            raise ParameterError(f"{self.cause} ({self.form}) state has {len(state)} values; "
                                 "the rod's displacement and velocity are 2")
        self.rod_displacement, self.rod_velocity = float(state[0]), float(state[1])


@lru_cache(maxsize=64)
def _two_mass_zoh(system, step):
    """ZOH of the two masses with two inputs, by one exponential (Van Loan 1978).

    exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, I]] with B = [b_F, b_ext]:
    b_F the force on the rod (:meth:`TwoMassMechanics.matrices`) and
    b_ext = [0, 0, 0, -1/m_2] the external force opposing the output's
    elongation. :meth:`TwoMassMechanics.zoh_matrices` is the same with b_F alone.
    """
    a, b, _ = system.matrices()
    aug = np.zeros((6, 6))
    aug[:4, :4] = a
    aug[:4, 4] = b
    aug[3, 5] = -1.0 / system.output_mass
    e = expm(aug * step)
    return e[:4, :4].copy(), e[:4, 4:].copy()
