"""Extensions of the paper's model, one module per effect, and their one registry.

The paper's model (eq 30) describes the rod by one complex permeability per
sinusoidal operating point (eqs 3-5, 16-20), eq 25 for the strain and one
mass-spring-damper (eq 27). Each extension adds one physical effect the paper
leaves out, in one formulation ("form"). Each is a class in the module of its
effect (:mod:`gmt.extensions._base` says what it holds: SI parameter spec,
the diagnosis' unknowns, periodic form, time-stepped form):

=============================  ===========  =============================================
cause (form)                   module       formulation
=============================  ===========  =============================================
rate_independent_hysteresis    hysteresis   Prandtl-Ishlinskii operator of H
rate_independent_hysteresis    preisach     classical Preisach model, a general
(preisach)                                  nonnegative density of relays over
                                            (coercive, interaction) field
magnetization_saturation       saturation   tanh law of M_b + M about the bias
eddy_current_diffusion (lag)   eddy         H_in = (1 + j w tau)^-alpha H
eddy_current_diffusion (slab,  diffusion    exact 1-D diffusion into a lamination or a
cylinder)                                   solid rod, the profile across the section
eddy_current_diffusion         diffusion    the same acting on the magnetisation, the
(slab_magnetization,                        coil seeing an unshielded share of the
cylinder_magnetization)                     vacuum flux (rod's M lags, air flux in the coil)
transport_delay                delay        e^{-j k w tau} on the sensed y
mechanical_resonance (one_dof) resonance    eq 27 with re-identified m, c, K
mechanical_resonance (two_dof) resonance    rod and output mass on a compliant joint
thermal_drift                  drift        offset and gain of y with the heating dose
=============================  ===========  =============================================

:data:`REGISTRY` is the one list of them: :mod:`smeha.diagnose` fits their
periodic forms (:func:`gmt.extensions.steady.steady_state`),
:class:`gmt.ModelVariant` and the FMU's ``model_variant`` step their
time-stepped forms. Adding an extension is one class in its effect's module
and one entry in :data:`EXTENSIONS`.

Extensions combine when they act at different stages of the model
(:data:`STAGES`); hysteresis and saturation both act on the magnetisation
and may also combine. A combination is named by its members' variant names
joined by ``+`` in stage order (:func:`combination_name`).
"""
from __future__ import annotations

from ..errors import ParameterError
from ._base import (GROWS_WITH_DRIVE, HIGHER_HARMONICS, STAGES, Extension, FieldState,
                    FitSpec, Parameter, harmonic_remainder)
from .delay import DelayForm, TransportDelay
from .diffusion import (DIFFUSION_GEOMETRIES, CylinderDiffusionForm,
                        CylinderMagnetizationForm, EddyCurrentDiffusion, ModalBank,
                        SlabDiffusionForm, SlabMagnetizationForm)
from .drift import DriftForm, LinearDrift
from .eddy import EddyCurrentLag, EddyLagForm, SectionBank, eddy_calibrated_permeability
from .hysteresis import PLAY_GRID, HysteresisForm, PrandtlIshlinskii, play_thresholds
from .preisach import PreisachForm
from .resonance import MechanicsForm, ReidentifiedMechanics, TwoMassForm, TwoMassMechanics
from .saturation import SaturationForm, SoftSaturation

#: Every extension, in the order the diagnosis lists its candidates; the first form of
#: a cause is its default.
EXTENSIONS = (HysteresisForm, PreisachForm, SaturationForm, EddyLagForm, SlabDiffusionForm,
              CylinderDiffusionForm, SlabMagnetizationForm, CylinderMagnetizationForm, DelayForm,
              MechanicsForm, TwoMassForm, DriftForm)

#: (cause, form) -> extension class; the one registry (module docstring).
REGISTRY: dict = {(e.cause, e.form): e for e in EXTENSIONS}

#: The causes, in the order of their first extension in EXTENSIONS.
CAUSES = tuple(dict.fromkeys(e.cause for e in EXTENSIONS))

#: The forms of the causes that have several (the first is the default).
FORMS = {c: tuple(e.form for e in EXTENSIONS if e.cause == c) for c in CAUSES
         if sum(e.cause == c for e in EXTENSIONS) > 1}

#: Name of the paper's model (no extension).
PAPER = "paper"


def forms_of(cause) -> tuple:
    """The forms of ``cause`` ("" for a cause with one), default first."""
    return tuple(e.form for e in EXTENSIONS if e.cause == cause)


def lookup(cause, form="") -> type:
    """The extension class of ``cause`` and ``form`` ("" is the cause's first form).

    Raises
    ------
    ParameterError
        An unknown cause or form, naming the allowed ones.
    """
    forms = forms_of(cause)
    if not forms:
        raise ParameterError(f"cause = {cause!r} is not one of {(PAPER,) + CAUSES}")
    if not form:
        return REGISTRY[cause, forms[0]]
    if form not in forms:
        allowed = (f"the allowed forms are {list(forms)}" if forms != ("",) else
                   "it has one form (leave form empty)")
        raise ParameterError(f"form = {form!r} is not a form of {cause!r}: {allowed} "
                             "(gmt.extensions.REGISTRY)")
    return REGISTRY[cause, form]


def variant_name(cause, form="") -> str:
    """``cause`` for the paper or a cause's first form, else ``cause:form``."""
    forms = forms_of(cause)
    return cause if not form or not forms or form == forms[0] else f"{cause}:{form}"


#: Every single variant by name: the values the FMU's ``model_variant`` lists (a
#: combination joins these with "+", :func:`combination_name`).
VARIANTS: tuple = (PAPER,) + tuple(variant_name(e.cause, e.form) for e in EXTENSIONS)


def ordered(classes) -> tuple:
    """The extension classes in the order the model passes through them (stage, registry).

    Raises
    ------
    ParameterError
        Two forms of one cause, or two extensions at a stage that takes one
        (every stage but the magnetisation's).
    """
    classes = list(classes)
    causes = [c.cause for c in classes]
    twice = sorted({c for c in causes if causes.count(c) > 1})
    if twice:
        raise ParameterError(f"a combination takes one form of each cause; {twice} appear "
                             "more than once")
    for stage in STAGES:
        at = [c for c in classes if c.stage == stage]
        if len(at) > 1 and stage != "magnetization":
            raise ParameterError(
                f"{' and '.join(variant_name(c.cause, c.form) for c in at)} both act on the "
                f"{stage} stage; a combination takes one extension a stage (the magnetisation "
                "stage excepted)")
    return tuple(sorted(classes, key=lambda c: (STAGES.index(c.stage), _rank(c))))


def _rank(cls) -> int:
    """The registry's index of ``cls``, or of the registered form it refines (a finer
    discretisation of that form, ``Extension.finer``)."""
    return next(EXTENSIONS.index(c) for c in cls.__mro__ if c in EXTENSIONS)


def combination_name(classes) -> str:
    """The variant name of a combination: its members' names joined by "+" in stage order."""
    return "+".join(variant_name(c.cause, c.form) for c in ordered(classes)) or PAPER


def parse_name(name) -> tuple:
    """The extension classes of a variant name (``paper``, a name of :data:`VARIANTS`, or
    several joined by "+"), in stage order.

    Raises
    ------
    ParameterError
        An unknown name, naming the allowed ones, or an impossible combination.
    """
    if not isinstance(name, str):
        raise ParameterError(f"model variant {name!r} is not a string")
    if name == PAPER:
        return ()
    out = []
    for part in name.split("+"):
        if part not in VARIANTS or part == PAPER:
            raise ParameterError(f"model variant {name!r}: {part!r} is not one of "
                                 f"{VARIANTS} (a combination joins them with '+')")
        cause, _, form = part.partition(":")
        out.append(lookup(cause, form))
    return ordered(out)


__all__ = [
    "GROWS_WITH_DRIVE", "HIGHER_HARMONICS", "STAGES", "Extension", "FieldState", "FitSpec",
    "Parameter", "harmonic_remainder",
    "DelayForm", "TransportDelay", "DIFFUSION_GEOMETRIES", "CylinderDiffusionForm",
    "EddyCurrentDiffusion", "ModalBank", "SlabDiffusionForm", "SlabMagnetizationForm",
    "CylinderMagnetizationForm", "DriftForm", "LinearDrift",
    "EddyCurrentLag", "EddyLagForm", "SectionBank", "eddy_calibrated_permeability",
    "PLAY_GRID", "play_thresholds", "HysteresisForm", "PreisachForm", "PrandtlIshlinskii",
    "MechanicsForm",
    "ReidentifiedMechanics", "TwoMassForm", "TwoMassMechanics", "SaturationForm",
    "SoftSaturation", "EXTENSIONS", "REGISTRY", "CAUSES", "FORMS", "PAPER", "forms_of",
    "lookup", "variant_name", "VARIANTS", "ordered", "combination_name", "parse_name",
]
