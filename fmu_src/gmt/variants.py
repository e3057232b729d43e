"""Model variants: the paper's model, or the paper's plus one extension, time-stepped.

``smeha diagnose`` names the physical effect the paper's model (eq 30) misses
and fits the extension of :mod:`gmt.extensions` that adds it, in its periodic
(steady-state) form. This module makes that extended model a product: a
:class:`ModelVariant` (the cause and the extension's SI parameters, as the
diagnosis reports them) given to :class:`gmt.Transducer` time-steps the
extended model sample by sample, for the FMU and the system study.

Each extension has a *step form* (:class:`StepForm` subclasses below, one per
cause and form, registered in :data:`FORMS`). Run long enough under a
sinusoidal current at the operating point, every step form reaches the
periodic steady state the diagnosis evaluates for that form
(``smeha.diagnose._Evaluator.predict``); ``tests/test_variants.py`` checks
this for every form and states the tolerance.

=============================  ==================  =======================================
cause (form)                   acts on             step form
=============================  ==================  =======================================
rate_independent_hysteresis    magnetisation M     play operators stepped on H (per sample),
                                                   minus their describing-function
                                                   fundamental at the operating point
magnetization_saturation       magnetisation M     tanh law applied to each sample of M,
                                                   minus its fundamental at the operating
                                                   point
eddy_current_diffusion (lag)   field in the rod    first-order lag, or a bank of first-order
                                                   sections fitted to (1 + j w tau)^-alpha;
                                                   mu' re-solved so B_m is kept
eddy_current_diffusion (slab,  field profile       the diffusion's modes (first-order lags)
cylinder)                      across the rod      carry H and H_q; B and M are section
                                                   means, the strain the section mean of
                                                   eq 25; mu at the surface flux density
transport_delay                sensor only         delay line on the sensed displacement
mechanical_resonance (one_dof) mechanics           eq 27 with the re-identified m, c, K
mechanical_resonance (two_dof) mechanics           rod and output masses on a joint, ZOH of
                                                   the 4-state model; the load and the
                                                   outputs on the output mass
thermal_drift                  strain (force)      offset and gain of the strain drift with
                                                   the heating dose, from the start of the run
=============================  ==================  =======================================

How the magnetic extensions keep the describing-function split
--------------------------------------------------------------
The paper's mu' and mu'' are the describing function of the magnetisation at
the operating point (I_m, w): its first harmonic per unit H_m (Gelb & Vander
Velde 1968). The diagnosis therefore adds to the paper's M only the part of a
hysteresis or saturation operator's output that is *not* its fundamental
(:func:`gmt.extensions.harmonic_remainder`). In the time domain the same split
is: the operator applied to each sample, minus a fixed linear term
c_h H + c_q H_q, where H_q = H_m sin(w t) is the quadrature field the paper's
model already rebuilds (eq 31) and c_h, c_q are the operator's fundamental at
the operating point, c_h - j c_q = (2 / (N H_m)) sum_n P_n e^{-j theta_n},
computed once at construction over one period of N = :data:`GRID` samples of
the operator's periodic output. For i = I_m cos(w t) this is exactly the
periodic form; for any other waveform (the compensated current, a host's
input) it applies the same correction, as the paper applies mu' and mu'' of
its operating point to any waveform.

The eddy-current lag in the time domain
---------------------------------------
H_in = g H, g(s) = (1 + s tau)^-alpha. For alpha = 1 it is one first-order
section, stepped exactly for the held input by :meth:`EddyCurrentLag.step`.
For 0 < alpha < 1 the function is a Stieltjes function, a positive mixture of
first-order lags with time constants in (0, tau] (the "diffusive
representation" of fractional operators, Montseny 1998):

    (1 + s tau)^-alpha = (sin(pi alpha) / pi) int_0^inf t^-alpha / (1 + t + s tau) dt.

It is realised by a small bank of first-order sections r_j / (1 + s tau_j) with
tau_j log-spaced from tau down to one tenth of the smallest time scale of the
band, :data:`SECTIONS_PER_DECADE` a decade, plus a direct term r_0, the weights
fitted by non-negative least squares to g over 0 to :data:`LAG_BAND` Hz
(relative error weighted) and scaled to the exact DC gain 1. The fit's largest
relative error over the band is :attr:`SectionBank.max_relative_error`: below
2.5e-4 for every alpha in [0.3, 1) and tau in [1 us, 0.1 s] (2.1e-4 measured;
3 to 33 sections; ``tests/test_variants.py``). Each section is stepped exactly for the
held input (as :meth:`EddyCurrentLag.step`), and the field held over a step is
the *mean* of the section's response over the step,
u + (x - u) (tau_j / h)(1 - e^{-h/tau_j}): the zero-order hold delays by h/2
and the mean over the step advances by h/2, so the held field equals the
continuous g H at t_k to second order in w h (relative error about
(w h)^2 / 12). The quadrature field H_q passes through the same bank, so that
B = mu_0 (mu' H_in + mu'' H_in,q) and M = (mu' - 1) H_in + mu'' H_in,q are
the paper's eqs 4-5 applied to the field inside the rod, and mu' is re-solved
(:func:`gmt.extensions.eddy_calibrated_permeability`) so that the coil still
sees the measured B_m.

The diffusion in the time domain: section means from the modes
----------------------------------------------------------------
For the slab and the cylinder (:class:`gmt.extensions.EddyCurrentDiffusion`,
q^2 = s tau) the local field per unit applied field, cosh(q x/a)/cosh q or
I_0(q r/a)/I_0(q), has simple poles at s = -p_n^2/tau, p_n = (n - 1/2) pi
(slab) or j_{0,n} (cylinder, the zeros of J_0). Its partial fractions give the
local field as a sum of first-order lags, each with a fixed profile:

    H_in(x, t) = sum_n w_n(x) x_n(t),      tau_n dx_n/dt = H(t) - x_n,  tau_n = tau/p_n^2,
    slab      w_n(x) = 2 (-1)^(n+1) cos(p_n x/a) / p_n,
    cylinder  w_n(r) = 2 J_0(p_n r/a) / (p_n J_1(p_n))

(the residue at each pole, worked out for this module). The profiles are the
eigenfunctions of the diffusion operator on the section (cosines; J_0 with the
weight r), so they are orthogonal, and w_n is the projection of the uniform
profile 1 on the n-th of them, phi_n: w_n = (<phi_n> / <phi_n^2>) phi_n. Hence
<w_n w_k> = 0 for n != k, and <w_n> and <w_n^2> are both <phi_n>^2 / <phi_n^2>:

    <w_n> = <w_n^2> = r_n   (2/p_n^2 slab, 4/p_n^2 cylinder),

the weights of :meth:`EddyCurrentDiffusion.modes`. eq 5 acts locally; with
H_q through the same modes, M(x, t) = sum_n w_n(x) M_n(t),
M_n = (mu' - 1) x_n + mu'' x_q,n, and at every instant (Parseval)

    <M> = sum_n r_n M_n,        <M^2> = sum_n r_n M_n^2,

so the section mean of eq 25, which the rod's force needs (the section moves
as one), is exact in the time domain:

    <lambda> = K_lambda <(M_b + M)^2>
             = K_lambda (M_b + <M>)^2 + K_lambda sum_n r_n (M_n - <M>)^2,

the paper's strain of the mean magnetisation plus K_lambda times the variance
of M over the section (sum_n r_n = 1). Under i = I_m cos(w t) each
M_n = Re(M_s e^{j w t} / (1 + j w tau_n)) with M_s = (mu - 1) H_m at the
surface, and the force has the diagnosis' fundamental 2 c M_b <g> M_s and
second harmonic c M_s^2 <g^2> / 2, with <g^2> = sum_n r_n / (1 + j w tau_n)^2,
and the mean c (M_b^2 + |M_s|^2 <|g|^2> / 2), <|g|^2> = sum_n r_n /
|1 + j w tau_n|^2 (the diagnosis does not use the mean; the tests check it
against :meth:`EddyCurrentDiffusion.mean_squares`' closed forms too). B and M
seen by the coil are the section means. mu is the material's at the surface,
as in the diagnosis: mu'' from eq 16 at B_s = B_m / |<g>| and mu' from eq 20
at B_s.

The modes are kept one by one down to a time constant of a twentieth of
1 / (2 pi :data:`LAG_BAND`) (8 to 256 of them); the rest share one amplitude,
one more section (:class:`ModalBank`). Modes that share an amplitude still
form a profile orthogonal to the others whose mean square equals its weight,
so the Parseval sums hold for the bank as they are. Its weight is the
remainder :meth:`EddyCurrentDiffusion.modes` leaves, and its time constant
makes the first moment sum_n r_n tau_n exactly tau/3 (slab) or tau/8
(cylinder), the low-frequency lags of <g>. The bank's <g> and <g^2> are within
2.1e-4 of the closed forms over 0 to 100 kHz for tau up to 0.05 s (at most 256
modes), and within 3.2e-6 over 0 to 1 kHz for tau up to 1 s
(:attr:`ModalBank.max_relative_error`). Each section steps exactly for the held
input, as :meth:`EddyCurrentDiffusion.step` does, and holds the mean of its
response over the step, as the lag's sections do: the stepped loop is within
about (w h)^2 / 12 of the periodic one.

Two masses: where the outputs and the load are
----------------------------------------------
:class:`gmt.extensions.TwoMassMechanics` drives the rod m_1 (with eq 27's c
and K) by the magnetostrictive force, and the diagnosis compares the output
m_2's displacement Y_2 with the measured y: the displacement sensor sits on
the output. The pump's piston, and so the chamber's force, is on the output
too (the output rod is what the rod pushes through the compliant joint). The
two-mass variant therefore applies the external force to m_2 and reports the
output's y_2, v_2 as ``displacement`` and ``velocity``, the names the
paper's one mass (rod, output and load lumped) has; the rod's y_1, v_1 are
saved with the state (:class:`TwoMassStepper`). Held over a step, both forces
enter one exact ZOH, one matrix exponential of the 6 x 6 augmented system
(Van Loan 1978). Statically y_1 = (F - F_ext)/K and y_2 = y_1 - F_ext/k_j:
the joint yields under the load.

Where the transport delay acts
------------------------------
The diagnosis delays y's harmonics but not B's, both referred to the measured
current: the delay lies between the rod and the displacement signal, i.e. in
the displacement sensor's chain (electronics, filtering, acquisition skew),
not in the amplifier (a delayed coil current would delay B as much as y). So
the variant delays only :attr:`TransducerOutput.sensed_displacement`: the rod,
its force on the oil and therefore the cylinder flow of the system study are
exactly the paper's. Selecting it in a system model changes nothing but what
a displacement sensor reads (and whatever a controller does with that
reading).

Where the thermal drift acts
----------------------------
The diagnosis' drift, y_meas = (1 + g u) y + o u with the heating dose
u(t) = I_m^2 t_th (1 - e^{-t/t_th}) (:class:`gmt.extensions.LinearDrift`), is
physical: K_lambda and M_b fall with temperature (gain) and the rod expands
(offset). The step form applies it to the strain, about the operating point's
mean strain lambda_0 (eq 25's mean term): lambda' = lambda_0 + (1 + g u)
(lambda - lambda_0) + (o / L) u, o / L being the rod's free thermal strain rate,
so the rod pushes on its load with the drifted force. Quasi-statically (the
drift is slow against the mechanics) the displacement is then the diagnosis'
form about its mean; t is the time since the start of the run (the FMU's
initialisation), saved with the state.

Adding a candidate
------------------
Write a :class:`StepForm` subclass (its ``cause``, its ``form`` when the
diagnosis has several formulations of the cause, its ``parameters`` as the
diagnosis reports them, ``optional`` for those it derives from the others,
the hooks it changes, and ``stepper`` when the mechanics need more state, as
the two masses do) and add it to the tuple that builds :data:`FORMS`. Its
variant name is the cause, or ``cause:form`` for a formulation other than the
cause's first (:data:`VARIANTS`); the FMU's ``model_variant`` list follows
(``smeha_fmu_interface.check_against_gmt`` fails the build until it does).

References
----------
* A. Gelb, W. E. Vander Velde, *Multiple-Input Describing Functions and
  Nonlinear System Design*, McGraw-Hill 1968.
* G. Montseny, "Diffusive representation of pseudo-differential
  time-operators", ESAIM Proc. 5 (1998) 159-175.
* K. Kuhnen, Eur. J. Control 9 (2003) 407-418 (Prandtl-Ishlinskii operator).
* R. L. Stoll, *The Analysis of Eddy Currents*, Clarendon 1974 (diffusion into
  a lamination and a rod; the eigenfunction expansions).
* W. T. Thomson, M. D. Dahleh, *Theory of Vibration with Applications*, 5th ed.,
  Prentice Hall 1998, ch. 5 (two-degree-of-freedom systems).
* C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE
  Trans. Autom. Control 23 (1978) 395-404.
* G. Engdahl (ed.), *Handbook of Giant Magnetostrictive Materials*, Academic
  Press 2000 (thermal behaviour).
"""
from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from . import extensions as ext
from .constants import MU_0
from .errors import ParameterError, check_range
from .forward import ForwardStepper, Magnetics, OperatingPoint, magnetics, strain_harmonics
from .losses import imaginary_permeability, separate_losses
from .magnetostriction import magnetostriction, magnetostrictive_force
from .parameters import TransducerParameters
from .permeability import amplitude_permeability, flux_density, magnetization, real_permeability

#: Name of the paper's model (no extension).
PAPER = "paper"
#: Samples of one period over which a magnetic operator's fundamental is computed.
GRID = 4096
#: Upper end of the band over which the fractional lag's sections are fitted, [Hz].
LAG_BAND = 1e5
#: First-order sections a decade of time constants in the fractional lag.
SECTIONS_PER_DECADE = 6


# ================================================================== parameters


@dataclass(frozen=True)
class Parameter:
    """One parameter of a variant, named as ``smeha diagnose --json`` names it.

    Attributes
    ----------
    name : str
        Key in the candidate's ``parameters`` (SI, unit suffix as in the diagnosis).
    unit : str
        Unit shown in messages.
    low, high : float
        Allowed range; ``low_open``/``high_open`` exclude the bound.
    is_list : bool
        A non-empty list of numbers rather than one number.
    optional : bool
        A value the diagnosis reports but derives from the others (e.g. the
        joint's frequency from its stiffness and mass): it may be left out, and
        when given the form checks that it agrees (:meth:`StepForm.validate`).
    """

    name: str
    unit: str
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = True
    high_open: bool = True
    is_list: bool = False
    optional: bool = False

    def check(self, cause, value):
        """``value`` as a float (or tuple of floats), or ParameterError naming it."""
        where = f"{cause} parameter {self.name}"
        if self.is_list:
            if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
                raise ParameterError(f"{where} = {value!r} must be a non-empty list of numbers")
            items = list(value)
            if not items:
                raise ParameterError(f"{where} = [] must be a non-empty list of numbers")
            return tuple(self._one(f"{where}[{k}]", v) for k, v in enumerate(items))
        return self._one(where, value)

    def _one(self, where, value):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                             np.integer)):
            raise ParameterError(f"{where} = {value!r} is not a number")
        low = None if self.low == -math.inf else self.low
        high = None if self.high == math.inf else self.high
        v = float(value)
        if math.isinf(v) and ((v > 0 and self.high == math.inf and not self.high_open)
                              or (v < 0 and self.low == -math.inf and not self.low_open)):
            return v
        if not math.isfinite(v):
            lo = "-inf" if low is None else f"{low:g}"
            hi = "inf" if high is None else f"{high:g}"
            raise ParameterError(f"{where} = {v!r} {self.unit} is outside the allowed range "
                                 f"{'(' if self.low_open else '['}{lo}, {hi}"
                                 f"{')' if self.high_open else ']'} {self.unit}")
        return check_range(where, v, low, high, unit=self.unit, low_open=self.low_open,
                           high_open=self.high_open)


# ================================================================== the variant


@dataclass(frozen=True, eq=False)
class ModelVariant:
    """The paper's model (``cause = "paper"``) or the paper's plus one extension.

    Attributes
    ----------
    cause : str
        ``"paper"`` or one of the causes ``smeha diagnose`` names
        (:data:`gmt.extensions.CAUSES`).
    parameters : mapping
        The extension's parameters in SI, keyed as the candidate's
        ``parameters`` of ``smeha diagnose --json`` (e.g. ``{"delay_s": 5e-4}``);
        empty for the paper. Stored read-only; lists become tuples.
    form : str
        The formulation, for a cause the diagnosis models in several ways:
        ``"lag"``, ``"slab"`` or ``"cylinder"`` for the eddy currents,
        ``"one_dof"`` or ``"two_dof"`` for the mechanics; "" takes the cause's
        first, and is replaced by its name. Another value is refused, naming
        the cause's forms.

    Raises
    ------
    ParameterError
        Unknown cause or form, a missing or unknown parameter, or a value out
        of its range (the message names the parameter, its value and the range).

    Examples
    --------
    >>> ModelVariant().is_paper
    True
    >>> ModelVariant("transport_delay", {"delay_s": 5e-4}).as_dict()
    {'cause': 'transport_delay', 'parameters': {'delay_s': 0.0005}}
    """

    cause: str = PAPER
    parameters: Mapping = field(default_factory=dict)
    form: str = ""

    def __post_init__(self):
        causes = (PAPER,) + tuple(dict.fromkeys(c for c, _ in FORMS))
        if self.cause not in causes:
            raise ParameterError(f"cause = {self.cause!r} is not one of {causes}")
        if not isinstance(self.parameters, Mapping):
            raise ParameterError(f"parameters = {self.parameters!r} must be a mapping of "
                                 "parameter name to value")
        forms = [f for c, f in FORMS if c == self.cause]
        if self.cause == PAPER or not self.form:
            object.__setattr__(self, "form", forms[0] if forms else "")
        elif self.form not in forms:
            allowed = (f"the allowed forms are {forms}" if forms != [""] else
                       "it has one form (leave form empty)")
            raise ParameterError(f"form = {self.form!r} is not a form of {self.cause!r}: "
                                 f"{allowed} (gmt.variants.FORMS)")
        spec = FORMS[self.cause, self.form].parameters if self.cause != PAPER else ()
        names = tuple(p.name for p in spec)
        unknown = [k for k in self.parameters if k not in names]
        missing = [p.name for p in spec if p.name not in self.parameters and not p.optional]
        if unknown or missing:
            what = "; ".join(s for s in (
                f"unknown {', '.join(map(repr, unknown))}" if unknown else "",
                f"missing {', '.join(map(repr, missing))}" if missing else "") if s)
            required = [p.name for p in spec if not p.optional]
            optional = [p.name for p in spec if p.optional]
            also = f" and optionally {optional} (derived; checked if given)" if optional else ""
            raise ParameterError(f"parameters of {variant_name(self.cause, self.form)!r}: "
                                 f"{what}; expected exactly "
                                 f"{required}{also} (SI, as smeha diagnose --json reports "
                                 "them)")
        clean = {p.name: p.check(self.cause, self.parameters[p.name]) for p in spec
                 if p.name in self.parameters}
        object.__setattr__(self, "parameters", MappingProxyType(clean))
        if self.cause != PAPER:
            FORMS[self.cause, self.form].validate(clean)

    # -- identity: equal and hashable by value, picklable (the read-only mapping is not)
    def _key(self):
        return (self.cause, self.form, tuple(sorted(self.parameters.items())))

    def __eq__(self, other):
        return isinstance(other, ModelVariant) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def __reduce__(self):
        return (ModelVariant, (self.cause, dict(self.parameters), self.form))

    def __repr__(self):
        form = f", form={self.form!r}" if self.form else ""
        return f"ModelVariant({self.cause!r}, {dict(self.parameters)!r}{form})"

    @property
    def is_paper(self) -> bool:
        """True for the paper's model alone."""
        return self.cause == PAPER

    @property
    def name(self) -> str:
        """The variant's name in :data:`VARIANTS` (the FMU's ``model_variant``)."""
        return variant_name(self.cause, self.form)

    def as_dict(self) -> dict:
        """``{"cause": ..., ["form": ...,] "parameters": {...}}``, JSON-able (lists for tuples)."""
        out = {"cause": self.cause}
        if self.form:
            out["form"] = self.form
        out["parameters"] = {k: (list(v) if isinstance(v, tuple) else v)
                             for k, v in self.parameters.items()}
        return out

    def describe(self) -> str:
        """One line: the variant and its parameters (SI)."""
        if self.is_paper:
            return "paper (eq 30, no extension)"

        def fmt(v):
            return ("[" + ", ".join(f"{x:.4g}" for x in v) + "]" if isinstance(v, tuple)
                    else f"{v:.4g}")
        return f"{self.name} (" + ", ".join(f"{k} = {fmt(v)}"
                                            for k, v in self.parameters.items()) + ")"

    @classmethod
    def from_name(cls, name: str, parameters: Mapping | None = None) -> "ModelVariant":
        """From a name of :data:`VARIANTS` (``cause`` or ``cause:form``) and the parameters."""
        if name not in VARIANTS:
            raise ParameterError(f"model variant {name!r} is not one of {VARIANTS}")
        cause, _, form = name.partition(":")
        return cls(cause, dict(parameters or {}), form)

    # -- constructors from the diagnosis -----------------------------------------
    @classmethod
    def from_diagnosis(cls, diagnosis: Mapping, cause: str | None = None,
                       form: str | None = None) -> "ModelVariant":
        """The winning extension of a diagnosis (``smeha diagnose --json`` or ``smeha paper``'s).

        Parameters
        ----------
        diagnosis : mapping
            With ``"cause"`` and ``"candidates"``, each candidate with ``"cause"``
            and ``"parameters"`` (SI) and, for a cause with several formulations,
            ``"form"``; the winner's form is the top-level ``"form"``.
        cause : str, optional
            Take this candidate instead of the winner.
        form : str, optional
            With ``cause``: take this form of it (default: its best-scoring form).

        The winner is the candidate of the diagnosis' ``"cause"`` *and* ``"form"``
        (a candidate without ``"form"`` is its cause's first form, as in
        diagnoses written before causes had several); its ``"parameters"`` are
        taken as they are. Without a form to go by (a top-level ``"form"`` that
        is absent or "", or ``cause`` without ``form``) the cause's candidate
        with the lowest ``"score"`` (``smeha diagnose``) or held-out RMS
        (``smeha paper``) is taken.

        Returns
        -------
        ModelVariant
            The paper's model when the cause is ``"none"``.

        Raises
        ------
        ParameterError
            ``"unexplained"`` (no winner; name a candidate with ``cause``), an
            unknown form (the message names it and the cause's forms), or no
            candidate of that cause and form in the diagnosis.

        Examples
        --------
        >>> d = {"cause": "mechanical_resonance", "form": "two_dof", "candidates": [
        ...     {"cause": "mechanical_resonance", "form": "one_dof", "score": 9.0,
        ...      "parameters": {"mass_kg": 0.02, "damping_N_s_per_m": 2945.0,
        ...                     "stiffness_N_per_m": 1.963e7}},
        ...     {"cause": "mechanical_resonance", "form": "two_dof", "score": 5.0,
        ...      "parameters": {"rod_mass_kg": 0.01, "output_mass_kg": 0.01,
        ...                     "joint_stiffness_N_per_m": 4e8,
        ...                     "joint_damping_N_s_per_m": 400.0}}]}
        >>> ModelVariant.from_diagnosis(d).name
        'mechanical_resonance:two_dof'
        >>> ModelVariant.from_diagnosis(d, "mechanical_resonance", "one_dof").name
        'mechanical_resonance'
        """
        if not isinstance(diagnosis, Mapping) or "cause" not in diagnosis:
            raise ParameterError("diagnosis must be a mapping with 'cause' and 'candidates' "
                                 "(the output of smeha diagnose --json)")
        chosen = diagnosis["cause"] if cause is None else cause
        if chosen in ("none", PAPER):
            return cls()
        candidates = [c for c in diagnosis.get("candidates") or () if isinstance(c, Mapping)]
        names = [c.get("cause") for c in candidates]
        if chosen == "unexplained":
            raise ParameterError("the diagnosis names no extension (cause 'unexplained'); "
                                 f"choose one of its candidates {names} explicitly")
        forms = [f for c, f in FORMS if c == chosen]
        if not forms:
            raise ParameterError(f"cause = {chosen!r} is not one of "
                                 f"{tuple(dict.fromkeys(c for c, _ in FORMS))}")
        wanted = (diagnosis.get("form") if cause is None else form) or ""
        if wanted and wanted not in forms:
            raise ParameterError(f"form = {wanted!r} is not a form of {chosen!r}: the allowed "
                                 f"forms are {forms}")
        matches = [c for c in candidates if c.get("cause") == chosen]
        if not matches:
            raise ParameterError(f"cause = {chosen!r} has no candidate in the diagnosis "
                                 f"(candidates: {names})")
        if wanted:
            present = [c.get("form") or forms[0] for c in matches]
            matches = [c for c, f in zip(matches, present) if f == wanted]
            if not matches:
                raise ParameterError(f"cause = {chosen!r} has no candidate of form "
                                     f"{wanted!r} in the diagnosis (its forms there: "
                                     f"{sorted(set(present))})")

        def rank(c):
            for key in ("score", "heldout_rms_um"):
                if isinstance(c.get(key), (int, float)):
                    return float(c[key])
            return math.inf
        best = min(matches, key=rank)
        return cls(chosen, dict(best.get("parameters") or {}), best.get("form") or "")

    @classmethod
    def from_dict(cls, data: Mapping) -> "ModelVariant":
        """From a diagnosis (has ``"candidates"``) or ``{"cause": ..., "parameters": {...}}``.

        The small form may carry ``"form"`` (default: the cause's first, e.g.
        ``"lag"``, ``"one_dof"``). ``"none"`` is the paper's model; other
        top-level keys (``"provenance"``, notes) are ignored.
        """
        if not isinstance(data, Mapping) or "cause" not in data:
            raise ParameterError("a model variant is a JSON object with 'cause' (and "
                                 "'parameters'), or the output of smeha diagnose --json")
        if "candidates" in data:
            return cls.from_diagnosis(data)
        cause = data["cause"]
        if cause == "none":
            cause = PAPER
        return cls(cause, dict(data.get("parameters") or {}), data.get("form") or "")

    @classmethod
    def from_json(cls, text: str) -> "ModelVariant":
        """:meth:`from_dict` of a JSON text."""
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise ParameterError(f"not valid JSON ({exc})") from None
        return cls.from_dict(data)

    def step_form(self, params: TransducerParameters, point: OperatingPoint):
        """The extension's :class:`StepForm` at an operating point (None for the paper)."""
        if self.is_paper:
            return None
        return FORMS[self.cause, self.form](dict(self.parameters), params, point)


# ================================================================== step forms


class StepForm:
    """The paper's model inside :class:`ExtendedStepper`; each extension overrides hooks.

    Parameters
    ----------
    values : dict
        The variant's parameters (SI, checked).
    params : TransducerParameters
    point : OperatingPoint
        The paper's operating point.

    Attributes
    ----------
    point : OperatingPoint
        The operating point the stepped model uses (the eddy lag re-solves mu').
    mechanics : tuple
        (m [kg], c [N s/m], K [N/m]) of eq 27; the rest displacement is the bias
        force over K.
    """

    cause = ""
    form = ""  # the diagnosis' name of the formulation, when a cause has several
    parameters: tuple = ()
    #: The stepper class the form runs in (None: :class:`ExtendedStepper`; the two
    #: masses need :class:`TwoMassStepper`).
    stepper = None

    @staticmethod
    def validate(values) -> None:
        """Checks that need more than each parameter's own range (no transducer needed)."""

    def __init__(self, values, params: TransducerParameters, point: OperatingPoint):
        self.values = values
        self.params = params
        self.point = point
        self.mechanics = (params.mass, params.damping, params.stiffness)

    def magnetics(self, current, quadrature, step, time) -> Magnetics:
        """H, H_q, B, M, lambda, F held over the step from t = ``time`` [s]; may advance memory."""
        return magnetics(self.params, self.point, current, quadrature)

    def sensed(self, displacement, time) -> float:
        """What a displacement sensor reads at ``time`` [s] (the rod's y by default), [m]."""
        return displacement

    def reset(self, rest_displacement) -> None:
        """Memory to its rest value."""

    def get_state(self) -> tuple:
        """The extension's memory as floats."""
        return ()

    def set_state(self, state) -> None:
        """Restore :meth:`get_state`."""
        if len(state):
            raise ParameterError(f"{self.cause or 'this variant'} has no state; got "
                                 f"{len(state)} values")

    # helpers for the magnetic forms
    def _with_magnetization(self, base: Magnetics, delta) -> Magnetics:
        """``base`` with delta [A/m] added to M (and mu_0 delta to B), eqs 4-5, 25, 28."""
        p = self.params
        m = base.magnetization + delta
        lam = magnetostriction(m, p.bias_magnetization, p.magnetostriction_coefficient)
        return Magnetics(base.field, base.quadrature_field,
                         base.flux_density + MU_0 * delta, m, lam,
                         magnetostrictive_force(lam, p.rod_area, p.youngs_modulus))

    def _fundamental(self, periodic_output):
        """(c_h, c_q): the fundamental of one period as c_h H + c_q H_q (module docstring)."""
        n = len(periodic_output)
        c1 = 2.0 * np.fft.rfft(periodic_output)[1] / n
        hm = self.point.field_amplitude
        return float(c1.real / hm), float(-c1.imag / hm)

    def _grid(self):
        return 2.0 * np.pi * np.arange(GRID) / GRID


class HysteresisForm(StepForm):
    """Prandtl-Ishlinskii operator on H (:class:`gmt.extensions.PrandtlIshlinskii`).

    Per step the plays advance with the held H (:meth:`PrandtlIshlinskii.step`);
    M gains P[H] - (c_h H + c_q H_q), the operator's output minus its
    fundamental at the operating point. Memory: the plays' outputs, [A/m]
    (zero: the demagnetised state).
    """

    cause = "rate_independent_hysteresis"
    parameters = (Parameter("thresholds_A_per_m", "A/m", 0.0, math.inf, low_open=False,
                            is_list=True),
                  Parameter("weights", "-", is_list=True))

    @staticmethod
    def validate(values):
        _pi(values)

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        self.operator = _pi(values)
        th = self._grid()
        self.coefficients = self._fundamental(
            self.operator.periodic(point.field_amplitude, th))
        self.plays = np.zeros(len(self.operator.thresholds))

    def magnetics(self, current, quadrature, step, time):
        base = super().magnetics(current, quadrature, step, time)
        out, self.plays = self.operator.step(base.field, self.plays)
        ch, cq = self.coefficients
        return self._with_magnetization(base, out - (ch * base.field
                                                     + cq * base.quadrature_field))

    def reset(self, rest_displacement):
        self.plays = np.zeros(len(self.operator.thresholds))

    def get_state(self):
        return tuple(float(z) for z in self.plays)

    def set_state(self, state):
        if len(state) != len(self.plays):
            raise ParameterError(f"{self.cause} state has {len(state)} values; the operator "
                                 f"has {len(self.plays)} plays")
        self.plays = np.array(state, dtype=float)


def _pi(values):
    return ext.PrandtlIshlinskii(tuple(values["thresholds_A_per_m"]), tuple(values["weights"]))


class SaturationForm(StepForm):
    """tanh saturation of the total magnetisation (:class:`gmt.extensions.SoftSaturation`).

    Memoryless: per sample M gains M_sat(M) - M - (c_h H + c_q H_q), the
    saturation's change minus its fundamental at the operating point.
    """

    cause = "magnetization_saturation"
    parameters = (Parameter("saturation_magnetization_A_per_m", "A/m", 0.0, math.inf),)

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        ms = values["saturation_magnetization_A_per_m"]
        if not ms > params.bias_magnetization:
            raise ParameterError(
                f"{self.cause} parameter saturation_magnetization_A_per_m = {ms:g} A/m is "
                f"outside the allowed range (bias_magnetization = {params.bias_magnetization:g}"
                ", inf) A/m")
        self.law = ext.SoftSaturation(ms, params.bias_magnetization)
        th = self._grid()
        m = point.field_amplitude * ((point.mu_real - 1.0) * np.cos(th)
                                     + point.mu_imag * np.sin(th))
        self.coefficients = self._fundamental(self.law.magnetization(m) - m)

    def magnetics(self, current, quadrature, step, time):
        base = super().magnetics(current, quadrature, step, time)
        m = base.magnetization
        ch, cq = self.coefficients
        delta = float(self.law.magnetization(m)) - m - (ch * base.field
                                                        + cq * base.quadrature_field)
        return self._with_magnetization(base, delta)


class SectionBank:
    """A bank of first-order lags approximating g(s) = (1 + s tau)^-alpha (module docstring).

    g(s) ~ r_0 + sum_j r_j / (1 + s tau_j), r >= 0, sum r = 1 (exact DC gain).

    Parameters
    ----------
    lag : EddyCurrentLag
        tau [s] and alpha.
    band : float
        Upper end of the fitted band, [Hz].

    Attributes
    ----------
    time_constants : array
        tau_j, [s].
    weights : array
        r_j, [-].
    direct : float
        r_0, [-].
    max_relative_error : float
        max |g_bank - g| / |g| over 0 to ``band`` Hz (4000 log-spaced points and DC).
    """

    def __init__(self, lag, band=LAG_BAND):
        from scipy.optimize import nnls

        tau, alpha = lag.time_constant, lag.order
        self.lag = lag
        if tau == 0.0 or alpha == 1.0:
            self.time_constants = np.array([tau]) if tau > 0.0 else np.zeros(0)
            self.weights = np.ones(self.time_constants.size)
            self.direct = 0.0 if tau > 0.0 else 1.0
            self.max_relative_error = 0.0
            return
        x_max = 2.0 * math.pi * band * tau  # w tau at the top of the band
        lowest = math.log10(0.1 / x_max) if x_max > 0.1 else 0.0
        n = int(math.ceil(-lowest * SECTIONS_PER_DECADE)) + 1
        rho = np.logspace(0.0, lowest, n)  # tau_j / tau
        x = np.concatenate(([0.0], np.logspace(-4.0, math.log10(x_max), 600)))

        def design(xs):
            return np.concatenate((1.0 / (1.0 + 1j * np.outer(xs, rho)),
                                   np.ones((xs.size, 1))), axis=1)

        target = (1.0 + 1j * x) ** (-alpha)
        a = design(x) / np.abs(target)[:, None]
        b = target / np.abs(target)
        r, _ = nnls(np.vstack((a.real, a.imag)), np.concatenate((b.real, b.imag)),
                    maxiter=50 * (n + 1))
        r = r / r.sum()
        keep = r[:-1] > 0.0
        self.time_constants = tau * rho[keep]
        self.weights = r[:-1][keep]
        self.direct = float(r[-1])
        xt = np.concatenate(([0.0], np.logspace(-5.0, math.log10(x_max), 4000)))
        gt = (1.0 + 1j * xt) ** (-alpha)
        approx = design(xt)[:, np.concatenate((keep, [True]))] @ np.concatenate(
            (self.weights, [self.direct]))
        self.max_relative_error = float(np.max(np.abs(approx - gt) / np.abs(gt)))

    @property
    def size(self) -> int:
        """Number of sections (states per filtered signal)."""
        return int(self.time_constants.size)

    def transfer(self, angular_frequency):
        """The bank's g(j w), [-]."""
        w = np.asarray(angular_frequency, dtype=float)
        return self.direct + np.sum(self.weights / (1.0 + 1j * np.multiply.outer(
            w, self.time_constants)), axis=-1)

    def step(self, signal, state, step):
        """(held output over the step, new state) for inputs ``signal`` held over ``step`` [s].

        ``signal`` has shape (k,), ``state`` (k, size): k signals through the
        same bank. The held output is the mean of each section's exact
        response over the step (module docstring).
        """
        u = np.asarray(signal, dtype=float)[:, None]
        if self.size == 1 and self.direct == 0.0:
            new = self.lag.step(u, state, step)  # first order: EddyCurrentLag.step, exact
        else:
            a = np.exp(-step / self.time_constants)
            new = a * state + (1.0 - a) * u
        mean = u + (state - u) * (-(self.time_constants / step)
                                  * np.expm1(-step / self.time_constants))
        out = self.direct * u[:, 0] + mean @ self.weights
        return out, new


class _FilterBankState:
    """State of a form whose memory is a bank of first-order sections for H and H_q.

    ``self.bank`` (with ``size``) is set by the form; the state is its filters' outputs.
    """

    def reset(self, rest_displacement):
        self.filters = np.zeros((2, self.bank.size))

    def get_state(self):
        return tuple(float(v) for v in self.filters.ravel())

    def set_state(self, state):
        if len(state) != self.filters.size:
            raise ParameterError(f"{self.cause} ({self.form}) state has {len(state)} values; "
                                 f"its sections need {self.filters.size}")
        self.filters = np.array(state, dtype=float).reshape(self.filters.shape)


class EddyLagForm(_FilterBankState, StepForm):
    """Field inside the rod lagging the applied field (:class:`gmt.extensions.EddyCurrentLag`).

    H and H_q pass through :class:`SectionBank`; eqs 4-5 act on the field
    inside, with mu' re-solved by
    :func:`gmt.extensions.eddy_calibrated_permeability` so that B_m is kept.
    Memory: the sections' states for H and H_q, [A/m].
    """

    cause = "eddy_current_diffusion"
    form = "lag"
    parameters = (Parameter("time_constant_s", "s", 0.0, math.inf, low_open=False),
                  Parameter("order", "-", 0.0, 1.0, high_open=False))

    @staticmethod
    def validate(values):
        ext.EddyCurrentLag(values["time_constant_s"], values["order"])

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        self.lag = ext.EddyCurrentLag(values["time_constant_s"], values["order"])
        g1 = complex(self.lag.transfer(point.angular_frequency))
        mu_r = ext.eddy_calibrated_permeability(point.flux_density_amplitude,
                                                point.field_amplitude, point.mu_imag, g1)
        if not math.isfinite(mu_r):
            raise ParameterError(
                f"{self.cause}: time_constant_s = {self.lag.time_constant:g} s and order = "
                f"{self.lag.order:g} make mu' imaginary at f = {point.frequency:g} Hz: "
                f"B_m / (mu_0 H_m |g|) = {abs(point.mu_real - 1j * point.mu_imag) / abs(g1):g}"
                f" must exceed mu'' = {point.mu_imag:g}")
        self.point = replace(point, mu_real=mu_r)
        self.bank = SectionBank(self.lag)
        self.filters = np.zeros((2, self.bank.size))

    def magnetics(self, current, quadrature, step, time):
        p, pt = self.params, self.point
        h = p.field_per_ampere * current
        hq = p.field_per_ampere * quadrature
        (h_in, hq_in), self.filters = self.bank.step((h, hq), self.filters, step)
        h_in, hq_in = float(h_in), float(hq_in)
        m = magnetization(h_in, hq_in, pt.mu_real, pt.mu_imag)
        lam = magnetostriction(m, p.bias_magnetization, p.magnetostriction_coefficient)
        return Magnetics(h, hq, flux_density(h_in, hq_in, pt.mu_real, pt.mu_imag), m, lam,
                         magnetostrictive_force(lam, p.rod_area, p.youngs_modulus))



#: First moment of the section's mean field, -d<g>/d(j w tau) at w = 0: <g> = 1 - j w tau/3
#: (slab) or 1 - j w tau/8 (cylinder) at low frequency (gmt.extensions.EddyCurrentDiffusion).
DIFFUSION_FIRST_MOMENT = {"slab": 1.0 / 3.0, "cylinder": 1.0 / 8.0}
#: Fewest and most diffusion modes kept one by one (module docstring).
MIN_MODES, MAX_MODES = 8, 256


class ModalBank:
    """The diffusion's field profile as modes (module docstring; :class:`EddyCurrentDiffusion`).

    H_in(x, t) = sum_n w_n(x) x_n(t) with tau_n dx_n/dt = H - x_n; the modes
    are orthogonal and the weights r_n = <w_n> = <w_n^2>, so for any signal
    carried by the modes (H, H_q, M) the section mean is sum_n r_n x_n and the
    mean of its square sum_n r_n x_n^2 (Parseval).

    Kept one by one: the modes of :meth:`EddyCurrentDiffusion.modes` whose time
    constant tau_n is at least a twentieth of the band's shortest time scale,
    1 / (2 pi ``band``) (at least :data:`MIN_MODES`, at most :data:`MAX_MODES`).
    The rest share one amplitude: one more section whose weight is the
    remainder ``modes`` leaves (so the weights add up to 1, the static gain)
    and whose time constant makes the first moment sum r_n tau_n exactly
    tau/3 (slab) or tau/8 (cylinder). Modes sharing an amplitude are still a
    field profile orthogonal to the others (mean square = weight), so mean and
    mean square stay consistent; the error falls as the fifth power of the
    number of modes, where taking the rest as instantaneous (as ``modes`` does)
    gives the third.

    Parameters
    ----------
    diffusion : EddyCurrentDiffusion
    band : float
        Frequencies the bank must follow, 0 to ``band``, [Hz].

    Attributes
    ----------
    time_constants : array
        tau_n of the kept modes, then the shared section's, [s].
    weights : array
        r_n, [-]; they add up to 1.
    mode_count : int
        Modes kept one by one (``EddyCurrentDiffusion.modes(mode_count)``).
    """

    def __init__(self, diffusion, band=LAG_BAND):
        self.diffusion = diffusion
        self.band = band
        tau = diffusion.time_constant
        self._step = None
        if tau == 0.0:  # no diffusion: the applied field everywhere
            self.time_constants, self.weights, self.mode_count = np.zeros(0), np.zeros(0), 0
            return
        floor = 0.05 / (2.0 * math.pi * band)
        taus, _ = diffusion.modes(MAX_MODES)
        count = int(min(max(np.count_nonzero(taus[:-1] >= floor), MIN_MODES), MAX_MODES))
        taus, weights = diffusion.modes(count)
        rest = float(weights[-1])
        moment = DIFFUSION_FIRST_MOMENT[diffusion.geometry] * tau - float(
            weights[:-1] @ taus[:-1])
        self.mode_count = count
        self.time_constants = np.append(taus[:-1], max(moment, 0.0) / rest)
        self.weights = weights

    @property
    def size(self) -> int:
        """Number of sections (states per carried signal)."""
        return int(self.time_constants.size)

    def _lags(self, angular_frequency):
        w = np.asarray(angular_frequency, dtype=float)
        return 1.0 / (1.0 + 1j * np.multiply.outer(w, self.time_constants))

    def transfer(self, angular_frequency):
        """The bank's <g>(j w), [-] (1 without diffusion)."""
        if not self.size:
            return np.ones(np.shape(angular_frequency), complex)
        return self._lags(angular_frequency) @ self.weights

    def mean_squares(self, angular_frequency):
        """The bank's (<g^2>, <|g|^2>), [-]: sum r_n l_n^2 and sum r_n |l_n|^2 (Parseval)."""
        if not self.size:
            one = np.ones(np.shape(angular_frequency))
            return one + 0j, one
        lags = self._lags(angular_frequency)
        return lags ** 2 @ self.weights, np.abs(lags) ** 2 @ self.weights

    @functools.cached_property
    def max_relative_error(self) -> float:
        """Largest relative error of <g> and <g^2> against the closed forms, 0 to ``band`` Hz."""
        if not self.size:
            return 0.0
        w = 2.0 * math.pi * np.concatenate(([0.0], np.logspace(-2.0, math.log10(self.band),
                                                               2000)))
        g, g2 = self.transfer(w), self.mean_squares(w)[0]
        exact_g, exact_g2 = self.diffusion.transfer(w), self.diffusion.mean_squares(w)[0]
        return float(max(np.max(np.abs(g / exact_g - 1.0)), np.max(np.abs(g2 / exact_g2 - 1.0))))

    def step(self, signal, state, step):
        """(held sections, new state) for inputs ``signal`` held over ``step`` [s].

        ``signal`` has shape (k,), ``state`` and both results (k, size). Each
        section advances exactly for the held input, as
        :meth:`EddyCurrentDiffusion.step` does (the kept modes' states are
        the same numbers); the held value is the mean of its exact response
        over the step, as :meth:`SectionBank.step` (module docstring).
        """
        u = np.asarray(signal, dtype=float)[:, None]
        if self._step != step:
            self._step = step
            self._decay = np.exp(-step / self.time_constants)
            self._mean = -(self.time_constants / step) * np.expm1(-step / self.time_constants)
        a = self._decay
        new = a * state + (1.0 - a) * u
        return u + (state - u) * self._mean, new


class EddyDiffusionForm(_FilterBankState, StepForm):
    """Field diffusing into a slab or a rod (:class:`gmt.extensions.EddyCurrentDiffusion`).

    H and H_q are carried by the modes of :class:`ModalBank`; eq 5 acts
    locally, on each mode: M_n = (mu' - 1) H_n + mu'' H_q,n. The coil sees the
    section means, B = mu_0 (mu' <H_in> + mu'' <H_in,q>) and M = <M>; the
    strain is the section mean of eq 25, lambda = K_lambda <(M_b + M(x))^2> =
    K_lambda (M_b + <M>)^2 + K_lambda sum_n r_n (M_n - <M>)^2 (module
    docstring), and F = A_r E^H lambda (eq 28). mu is the material's at the
    surface, where B_s = B_m / |<g>|: mu'' from eq 16 (intermediate regime)
    at B_s and mu' from eq 20 at B_s, as the diagnosis does. Memory: the
    sections' states for H and H_q, [A/m].
    """

    cause = "eddy_current_diffusion"
    parameters = (Parameter("time_constant_s", "s", 0.0, math.inf, low_open=False),
                  Parameter("skin_depth_equals_size_at_Hz", "Hz", 0.0, math.inf,
                            high_open=False, optional=True))

    @classmethod
    def validate(cls, values):
        ext.EddyCurrentDiffusion(values["time_constant_s"], cls.form)
        if "skin_depth_equals_size_at_Hz" in values:
            tau = values["time_constant_s"]
            _agrees(cls.cause, "skin_depth_equals_size_at_Hz", values, "Hz",
                    1.0 / (math.pi * tau) if tau > 0.0 else math.inf, "1 / (pi time_constant_s)")

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        self.diffusion = ext.EddyCurrentDiffusion(values["time_constant_s"], self.form)
        g1 = complex(self.diffusion.transfer(point.angular_frequency))
        f, hm = point.frequency, point.field_amplitude
        b_surface = point.flux_density_amplitude / abs(g1)
        mu_i = imaginary_permeability(separate_losses(params, f, hm, b_surface).total, hm, f,
                                      params.rod_volume)
        if not amplitude_permeability(b_surface, hm) > mu_i:
            raise ParameterError(
                f"{self.cause} ({self.form}): time_constant_s = "
                f"{self.diffusion.time_constant:g} s makes mu' imaginary at f = {f:g} Hz: the "
                f"surface flux density B_m / |<g>| = {b_surface:g} T gives B_s / (mu_0 H_m) = "
                f"{amplitude_permeability(b_surface, hm):g}, which must exceed mu'' = {mu_i:g} "
                "(eqs 16, 20)")
        self.point = replace(point, mu_real=real_permeability(b_surface, hm, mu_i),
                             mu_imag=mu_i)
        self.bank = ModalBank(self.diffusion)
        self.filters = np.zeros((2, self.bank.size))

    def magnetics(self, current, quadrature, step, time):
        p, pt = self.params, self.point
        h = p.field_per_ampere * current
        hq = p.field_per_ampere * quadrature
        r = self.bank.weights
        if not self.bank.size:
            return magnetics(p, pt, current, quadrature)
        held, self.filters = self.bank.step((h, hq), self.filters, step)
        m_modes = magnetization(held[0], held[1], pt.mu_real, pt.mu_imag)  # eq 5, per mode
        m = float(r @ m_modes)
        spread = m_modes - m
        lam = (magnetostriction(m, p.bias_magnetization, p.magnetostriction_coefficient)
               + p.magnetostriction_coefficient * float(r @ (spread * spread)))
        b = flux_density(float(r @ held[0]), float(r @ held[1]), pt.mu_real, pt.mu_imag)
        return Magnetics(h, hq, b, m, lam, magnetostrictive_force(lam, p.rod_area,
                                                                  p.youngs_modulus))



class SlabDiffusionForm(EddyDiffusionForm):
    """:class:`EddyDiffusionForm` into a lamination of thickness 2a (tau = mu_0 mu sigma a^2)."""

    form = "slab"


class CylinderDiffusionForm(EddyDiffusionForm):
    """:class:`EddyDiffusionForm` into a solid rod of radius a (tau = mu_0 mu sigma a^2)."""

    form = "cylinder"


def _agrees(cause, name, values, unit, implied, how):
    """ParameterError unless the derived ``values[name]`` agrees with ``implied`` (1e-6)."""
    given = values[name]
    if not math.isclose(given, implied, rel_tol=1e-6):
        raise ParameterError(f"{cause} parameter {name} = {given:g} {unit} disagrees with "
                             f"{how} = {implied:g} {unit}; leave it out (it is derived) or "
                             "give a consistent value")


class DelayForm(StepForm):
    """A pure delay of the displacement sensor (:class:`gmt.extensions.TransportDelay`).

    The sensed displacement at t is y(t - tau), interpolated linearly in a
    history of (t_k, y_k) at the ends of the steps; before t = tau it is the
    rest displacement. At a fixed step h this is the FIFO of
    ``TransportDelay.delay_samples(h)`` samples with the fraction
    interpolated; the history keeps variable steps too. Memory: the history
    (2 values per kept sample; about tau / h samples).
    """

    cause = "transport_delay"
    #: the line holds tau / h samples and is saved with every FMU state
    parameters = (Parameter("delay_s", "s", 0.0, 0.1, low_open=False, high_open=False),)

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        self.delay = ext.TransportDelay(values["delay_s"])
        self.times, self.values_ = [0.0], [math.nan]

    def sensed(self, displacement, time):
        tau = self.delay.delay
        times, ys = self.times, self.values_
        times.append(time)
        ys.append(displacement)
        target = time - tau
        while len(times) > 2 and times[1] <= target:
            del times[0], ys[0]
        if target <= times[0]:
            return ys[0]
        t0, t1 = times[0], times[1]
        if not t1 > t0:  # a step too small to advance the clock
            return ys[1]
        frac = (target - t0) / (t1 - t0)
        return ys[0] + frac * (ys[1] - ys[0])

    def reset(self, rest_displacement):
        self.times, self.values_ = [0.0], [float(rest_displacement)]

    def get_state(self):
        return tuple(v for pair in zip(self.times, self.values_) for v in pair)

    def set_state(self, state):
        if len(state) < 2 or len(state) % 2:
            raise ParameterError(f"{self.cause} state has {len(state)} values; the delay line "
                                 "needs (time, displacement) pairs")
        self.times = [float(v) for v in state[0::2]]
        self.values_ = [float(v) for v in state[1::2]]


class MechanicsForm(StepForm):
    """Eq 27 with re-identified m, c, K (:class:`gmt.extensions.ReidentifiedMechanics`).

    The blocked force keeps Table 2's E^H (as in the diagnosis); the ZOH
    matrices come from :func:`gmt.mechanics.zoh_matrices` with the new m, c, K
    and the rest state is the bias force over the new K.
    """

    cause = "mechanical_resonance"
    form = "one_dof"
    parameters = (Parameter("mass_kg", "kg", 0.0, math.inf),
                  Parameter("damping_N_s_per_m", "N s/m", 0.0, math.inf, low_open=False),
                  Parameter("stiffness_N_per_m", "N/m", 0.0, math.inf))

    @staticmethod
    def validate(values):
        _mechanics(values)

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        mech = _mechanics(values)
        self.mechanics = (mech.mass, mech.damping, mech.stiffness)


def _mechanics(values):
    return ext.ReidentifiedMechanics(values["mass_kg"], values["damping_N_s_per_m"],
                                     values["stiffness_N_per_m"])


class TwoMassForm(StepForm):
    """Rod and output mass on a compliant joint (:class:`gmt.extensions.TwoMassMechanics`).

    The diagnosis' two-mass model with eq 27's c and K (the transducer's
    ``damping`` and ``stiffness``) on the rod m_1, and the output m_2 on the
    joint k_j, c_j. The magnetostrictive force drives the rod; the output is
    what the displacement sensor reads (the diagnosis' y) and where the load
    is, so the external force acts on m_2 and ``displacement``/``velocity``
    are the output's. Stepped by :class:`TwoMassStepper` (the rod's y_1, v_1
    are its memory).
    """

    cause = "mechanical_resonance"
    form = "two_dof"
    parameters = (Parameter("rod_mass_kg", "kg", 0.0, math.inf),
                  Parameter("output_mass_kg", "kg", 0.0, math.inf),
                  Parameter("joint_stiffness_N_per_m", "N/m", 0.0, math.inf),
                  Parameter("joint_damping_N_s_per_m", "N s/m", 0.0, math.inf,
                            low_open=False),
                  Parameter("joint_frequency_Hz", "Hz", 0.0, math.inf, optional=True),
                  Parameter("joint_damping_ratio", "-", 0.0, math.inf, low_open=False,
                            optional=True))

    @staticmethod
    def validate(values):
        m2, kj = values["output_mass_kg"], values["joint_stiffness_N_per_m"]
        if "joint_frequency_Hz" in values:
            _agrees("mechanical_resonance", "joint_frequency_Hz", values, "Hz",
                    math.sqrt(kj / m2) / (2.0 * math.pi),
                    "sqrt(joint_stiffness_N_per_m / output_mass_kg) / (2 pi)")
        if "joint_damping_ratio" in values:
            _agrees("mechanical_resonance", "joint_damping_ratio", values, "",
                    values["joint_damping_N_s_per_m"] / (2.0 * math.sqrt(kj * m2)),
                    "joint_damping_N_s_per_m / (2 sqrt(joint_stiffness_N_per_m "
                    "output_mass_kg))")

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        self.system = ext.TwoMassMechanics(
            values["rod_mass_kg"], values["output_mass_kg"], params.damping, params.stiffness,
            values["joint_stiffness_N_per_m"], values["joint_damping_N_s_per_m"])
        # eq 27's K carries the rest: both masses at the bias force over K
        self.mechanics = (values["rod_mass_kg"] + values["output_mass_kg"], params.damping,
                          params.stiffness)

    @property
    def stepper(self):
        return TwoMassStepper

    def zoh(self, step):
        """(A_d, B_d) of x = [y_1, v_1, y_2, v_2] for F on the rod and F_ext on the output, held."""
        return _two_mass_zoh(self.system, float(step))


@functools.lru_cache(maxsize=64)
def _two_mass_zoh(system, step):
    """ZOH of the two masses with two inputs, by one exponential (Van Loan 1978).

    exp([[A, B], [0, 0]] h) = [[A_d, B_d], [0, I]] with B = [b_F, b_ext]:
    b_F the force on the rod (:meth:`TwoMassMechanics.matrices`) and
    b_ext = [0, 0, 0, -1/m_2] the external force opposing the output's
    elongation. :meth:`TwoMassMechanics.zoh_matrices` is the same with b_F alone.
    """
    from scipy.linalg import expm

    a, b, _ = system.matrices()
    aug = np.zeros((6, 6))
    aug[:4, :4] = a
    aug[:4, 4] = b
    aug[3, 5] = -1.0 / system.output_mass
    e = expm(aug * step)
    return e[:4, :4].copy(), e[:4, 4:].copy()


class DriftForm(StepForm):
    """Strain drifting with the heating dose (:class:`gmt.extensions.LinearDrift`).

    lambda' = lambda_0 + (1 + g u(t)) (lambda - lambda_0) + (o / L) u(t) with
    u(t) = I_m^2 t_th (1 - e^{-t/t_th}), t from the start of the run (module
    docstring); I_m is the operating point's. No memory beyond the elapsed
    time the stepper keeps.
    """

    cause = "thermal_drift"
    parameters = (Parameter("offset_rate_m_per_A2s", "m/(A^2 s)"),
                  Parameter("gain_rate_per_A2s", "1/(A^2 s)"),
                  Parameter("thermal_time_constant_s", "s", 0.0, math.inf, high_open=False))

    @staticmethod
    def validate(values):
        ext.LinearDrift(values["offset_rate_m_per_A2s"], values["gain_rate_per_A2s"],
                        values["thermal_time_constant_s"])

    def __init__(self, values, params, point):
        super().__init__(values, params, point)
        # on the strain: the offset is the rod's free thermal strain, o / L per unit dose
        self.drift = ext.LinearDrift(values["offset_rate_m_per_A2s"] / params.rod_length,
                                     values["gain_rate_per_A2s"],
                                     values["thermal_time_constant_s"])
        self.mean_strain = float(np.real(strain_harmonics(params, point)[0]))

    def magnetics(self, current, quadrature, step, time):
        base = super().magnetics(current, quadrature, step, time)
        p = self.params
        lam = self.mean_strain + float(self.drift.apply(base.strain - self.mean_strain, time,
                                                        self.point.current_amplitude))
        return base._replace(strain=lam, force=magnetostrictive_force(lam, p.rod_area,
                                                                      p.youngs_modulus))


#: (cause, form) -> step form; the first form of a cause is its default. Adding a
#: candidate is one class and one entry here.
FORMS: dict[tuple[str, str], type[StepForm]] = {(form.cause, form.form): form for form in (
    HysteresisForm, SaturationForm, EddyLagForm, SlabDiffusionForm, CylinderDiffusionForm,
    DelayForm, MechanicsForm, TwoMassForm, DriftForm)}


def variant_name(cause: str, form: str = "") -> str:
    """``cause`` for the paper or a cause's first form, else ``cause:form``."""
    first = next((f for c, f in FORMS if c == cause), "")
    return cause if not form or form == first else f"{cause}:{form}"


#: Every variant by name: the FMU's ``model_variant`` values.
VARIANTS: tuple[str, ...] = (PAPER,) + tuple(variant_name(c, f) for c, f in FORMS)


# ================================================================== the stepper


class VariantStepResult(NamedTuple):
    """Outputs of one step of :class:`ExtendedStepper` (state at the end of the step)."""

    magnetics: Magnetics
    displacement: float  #: y at t + h, [m]
    velocity: float  #: dy/dt at t + h, [m/s]
    sensed_displacement: float  #: what the displacement sensor reads at t + h, [m]


class ExtendedStepper(ForwardStepper):
    """:class:`gmt.forward.ForwardStepper` with an extension's step form.

    Same time alignment, quadrature rule (eq 31) and ZOH mechanics as the
    paper's stepper; the form supplies the magnetics, the mechanics' m, c, K
    and the sensed displacement.

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
        The paper's operating point (the form may change mu').
    form : StepForm

    Notes
    -----
    State: the paper stepper's five values (y, v, previous current, previous
    step, branch), then the elapsed time [s], the sensed displacement [m] and
    the form's memory (its length depends on the form; for the delay it
    varies).
    """

    def __init__(self, params: TransducerParameters, point: OperatingPoint, form: StepForm):
        self.form = form
        super().__init__(params, form.point)

    def reset(self):
        super().reset()
        p = self.params
        self.displacement = magnetostrictive_force(
            magnetostriction(0.0, p.bias_magnetization, p.magnetostriction_coefficient),
            p.rod_area, p.youngs_modulus) / self.form.mechanics[2]
        self.elapsed = 0.0
        self.sensed_displacement = self.displacement
        self.form.reset(self.displacement)

    def get_state(self) -> tuple:
        return (super().get_state() + (self.elapsed, self.sensed_displacement)
                + tuple(self._memory()))

    def set_state(self, state) -> None:
        state = tuple(float(s) for s in state)
        if len(state) < 7:
            raise ParameterError(f"state has {len(state)} values; this variant needs at "
                                 "least 7")
        self._restore_memory(state[7:])
        super().set_state(state[:5])
        self.elapsed, self.sensed_displacement = state[5], state[6]

    def _memory(self) -> tuple:
        """Everything after the elapsed time and the sensed displacement in the state."""
        return self.form.get_state()

    def _restore_memory(self, values) -> None:
        """Restore :meth:`_memory` (raising before changing anything if it does not fit)."""
        self.form.set_state(values)

    def _mechanics(self, force, current, step, external_force, held=False) -> None:
        """Eq 27 over the step with the form's m, c, K (ZOH), F and F_ext held."""
        self._advance(force, current, step, external_force, *self.form.mechanics, held)

    def step(self, current: float, step: float, external_force: float = 0.0,
             held: bool = False):
        """Advance by ``step`` [s] with ``current`` [A] and ``external_force`` [N] held
        (``held``: as :meth:`gmt.forward.ForwardStepper.step`)."""
        q = self._quadrature(current, step, external_force, held)
        mag = self.form.magnetics(current, q, step, self.elapsed)
        self._mechanics(mag.force, current, step, external_force, held)
        self.elapsed += step
        self.sensed_displacement = float(self.form.sensed(self.displacement, self.elapsed))
        return VariantStepResult(mag, self.displacement, self.velocity,
                                 self.sensed_displacement)


class TwoMassStepper(ExtendedStepper):
    """:class:`ExtendedStepper` with the rod and the output as two masses (:class:`TwoMassForm`).

    x = [y_1, v_1, y_2, v_2] advances by the exact ZOH of the two-mass model
    for the magnetostrictive force on the rod and the external force on the
    output, both held over the step (:func:`_two_mass_zoh`).
    ``displacement`` and ``velocity`` are the output's y_2, v_2 (the diagnosis'
    y, what the sensor reads and what pushes the load); ``rod_displacement``
    and ``rod_velocity`` are y_1, v_1. At rest both sit at the bias force over K.

    Notes
    -----
    State: as :class:`ExtendedStepper`'s, with (y, v) the output's, then y_1 [m]
    and v_1 [m/s] before the form's memory (none).
    """

    def reset(self):
        super().reset()
        self.rod_displacement, self.rod_velocity = self.displacement, 0.0

    def _memory(self) -> tuple:
        return (self.rod_displacement, self.rod_velocity) + tuple(self.form.get_state())

    def _restore_memory(self, values) -> None:
        if len(values) < 2:
            raise ParameterError(f"{self.form.cause} ({self.form.form}) state has "
                                 f"{len(values) + 7} values; the two masses need at least 9")
        self.form.set_state(values[2:])
        self.rod_displacement, self.rod_velocity = values[0], values[1]

    def _mechanics(self, force, current, step, external_force, held=False) -> None:
        ad, bd = self.form.zoh(step)
        x = np.array((self.rod_displacement, self.rod_velocity, self.displacement,
                      self.velocity))
        x = ad @ x + bd @ np.array((float(force), external_force))
        (self.rod_displacement, self.rod_velocity, self.displacement,
         self.velocity) = (float(v) for v in x)
        self._remember(current, step, held)


def make_stepper(params: TransducerParameters, point: OperatingPoint,
                 variant: ModelVariant | None = None):
    """The paper's :class:`ForwardStepper`, or an :class:`ExtendedStepper` for a variant."""
    if variant is None or variant.is_paper:
        return ForwardStepper(params, point)
    form = variant.step_form(params, point)
    return (form.stepper or ExtendedStepper)(params, point, form)
