"""Model variants: the paper's model, or the paper's plus extensions, time-stepped.

``smeha diagnose`` names the physical effect(s) the paper's model (eq 30)
misses and fits the extensions of :mod:`gmt.extensions` that add them, in
their periodic (steady-state) forms. This module makes that extended model a
product: a :class:`ModelVariant` (the causes, forms and SI parameters, as the
diagnosis reports them) given to :class:`gmt.Transducer` time-steps the
extended model sample by sample, for the FMU and the system study.

Every extension of :data:`gmt.extensions.REGISTRY` has a time-stepped form
(the class itself, instantiated with its SI parameters; module of its
effect). Run long enough under a sinusoidal current at the operating point,
each reaches the periodic steady state the diagnosis evaluates for it
(:func:`gmt.extensions.steady.steady_state` at the same step);
``tests/test_variants.py`` checks this for every form and for combinations,
and states the tolerances.

A variant with several extensions (:meth:`ModelVariant.combine`) chains them
in the order the model passes through its stages (:data:`gmt.extensions.STAGES`):
the field inside the rod (eddy currents), the magnetisation (hysteresis, then
saturation), the strain (thermal drift), the mechanics, the sensor (delay).
Each stage hands the next what the model's signals are after it; the
magnetisation stage keeps its describing-function split on the periodic
magnetisation the stages before it give (:mod:`gmt.extensions.magnetic`).
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from . import extensions as ext
from .constants import MU_0
from .errors import ParameterError
from .forward import ForwardStepper, Magnetics, OperatingPoint, magnetics
from .magnetostriction import magnetostriction, magnetostrictive_force
from .parameters import TransducerParameters

#: Name of the paper's model (no extension).
PAPER = ext.PAPER
#: Every single variant by name: the FMU's ``model_variant`` values (and their
#: combinations joined by "+").
VARIANTS = ext.VARIANTS


def variant_name(cause: str, form: str = "") -> str:
    """``cause`` for the paper or a cause's first form, else ``cause:form``."""
    return ext.variant_name(cause, form)


# ================================================================== the variant


@dataclass(frozen=True, eq=False)
class ModelVariant:
    """The paper's model (``cause = "paper"``), the paper's plus one extension, or several.

    Attributes
    ----------
    cause : str
        ``"paper"`` or one of the causes ``smeha diagnose`` names
        (:data:`gmt.extensions.CAUSES`); for a combination, its first member's.
    parameters : mapping
        The extension's parameters in SI, keyed as the candidate's
        ``parameters`` of ``smeha diagnose --json`` (e.g. ``{"delay_s": 5e-4}``);
        empty for the paper. Stored read-only; lists become tuples. For a
        combination, the first member's.
    form : str
        The formulation, for a cause the diagnosis models in several ways
        (:data:`gmt.extensions.FORMS`); "" takes the cause's first, and is
        replaced by its name. Another value is refused, naming the cause's forms.
    components : tuple of ModelVariant
        For a combination (:meth:`combine`), its single members in stage order;
        empty otherwise (:attr:`members` gives the members in both cases).

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
    >>> v = ModelVariant.combine(ModelVariant("transport_delay", {"delay_s": 5e-4}),
    ...     ModelVariant("magnetization_saturation", {"saturation_magnetization_A_per_m": 4e5}))
    >>> v.name
    'magnetization_saturation+transport_delay'
    """

    cause: str = PAPER
    parameters: Mapping = field(default_factory=dict)
    form: str = ""
    components: tuple = ()

    def __post_init__(self):
        if self.components:
            self._init_combination()
            return
        if self.cause != PAPER and self.cause not in ext.CAUSES:
            raise ParameterError(f"cause = {self.cause!r} is not one of "
                                 f"{(PAPER,) + ext.CAUSES}")
        if not isinstance(self.parameters, Mapping):
            raise ParameterError(f"parameters = {self.parameters!r} must be a mapping of "
                                 "parameter name to value")
        if self.cause == PAPER:
            object.__setattr__(self, "form", "")
            spec = ()
        else:
            cls = ext.lookup(self.cause, self.form)
            object.__setattr__(self, "form", cls.form)
            spec = cls.parameters
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
            ext.lookup(self.cause, self.form).validate(clean)

    def _init_combination(self):
        members = []
        for c in self.components:
            if not isinstance(c, ModelVariant):
                raise ParameterError(f"components = {self.components!r}: each must be a "
                                     "gmt.ModelVariant")
            members += [m for m in c.members if not m.is_paper]
        classes = ext.ordered([ext.lookup(m.cause, m.form) for m in members])
        members.sort(key=lambda m: classes.index(ext.lookup(m.cause, m.form)))
        if len(members) == 1:
            first = members[0]
            members = []
        else:
            first = members[0] if members else ModelVariant()
        object.__setattr__(self, "components", tuple(members))
        object.__setattr__(self, "cause", first.cause)
        object.__setattr__(self, "form", first.form)
        object.__setattr__(self, "parameters", first.parameters)

    @classmethod
    def combine(cls, *variants) -> "ModelVariant":
        """The variant of several extensions together (each a single or combined variant).

        Raises
        ------
        ParameterError
            Two forms of one cause, or two extensions at one stage
            (:func:`gmt.extensions.ordered`).
        """
        return cls(components=tuple(variants))

    @property
    def members(self) -> tuple:
        """The single variants this one is made of (itself for a single variant)."""
        return self.components or (self,)

    # -- identity: equal and hashable by value, picklable (the read-only mapping is not)
    def _key(self):
        return tuple((m.cause, m.form, tuple(sorted(m.parameters.items())))
                     for m in self.members)

    def __eq__(self, other):
        return isinstance(other, ModelVariant) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def __reduce__(self):
        if self.components:
            return (_combined, tuple(self.components))
        return (ModelVariant, (self.cause, dict(self.parameters), self.form))

    def __repr__(self):
        if self.components:
            return "ModelVariant.combine(" + ", ".join(map(repr, self.components)) + ")"
        form = f", form={self.form!r}" if self.form else ""
        return f"ModelVariant({self.cause!r}, {dict(self.parameters)!r}{form})"

    @property
    def is_paper(self) -> bool:
        """True for the paper's model alone."""
        return self.cause == PAPER

    @property
    def causes(self) -> tuple:
        """The causes of the members, in stage order (empty for the paper)."""
        return tuple(m.cause for m in self.members if not m.is_paper)

    @property
    def name(self) -> str:
        """The variant's name: a name of :data:`VARIANTS`, or several joined by "+"."""
        if self.components:
            return "+".join(m.name for m in self.components)
        return variant_name(self.cause, self.form)

    def as_dict(self) -> dict:
        """``{"cause", ["form",] "parameters"}``, or ``{"components": [...]}``, JSON-able."""
        if self.components:
            return {"components": [m.as_dict() for m in self.components]}
        out = {"cause": self.cause}
        if self.form:
            out["form"] = self.form
        out["parameters"] = {k: (list(v) if isinstance(v, tuple) else v)
                             for k, v in self.parameters.items()}
        return out

    def variant_parameters(self) -> dict:
        """The FMU's ``variant_parameters`` object: the parameters, or per member by name."""
        if self.components:
            return {m.name: m.as_dict()["parameters"] for m in self.components}
        return self.as_dict().get("parameters", {})

    def describe(self) -> str:
        """One line: the variant and its parameters (SI)."""
        if self.is_paper:
            return "paper (eq 30, no extension)"
        if self.components:
            return " + ".join(m.describe() for m in self.components)

        def fmt(v):
            return ("[" + ", ".join(f"{x:.4g}" for x in v) + "]" if isinstance(v, tuple)
                    else f"{v:.4g}")
        return f"{self.name} (" + ", ".join(f"{k} = {fmt(v)}"
                                            for k, v in self.parameters.items()) + ")"

    # -- constructors ------------------------------------------------------------
    @classmethod
    def from_name(cls, name: str, parameters: Mapping | None = None) -> "ModelVariant":
        """From a variant name (``cause``, ``cause:form`` or several joined by "+") and
        the parameters (for a combination: an object keyed by the members' names)."""
        classes = ext.parse_name(name)
        parameters = dict(parameters or {})
        if len(classes) <= 1:
            if not classes:
                return cls(PAPER, parameters)
            return cls(classes[0].cause, parameters, classes[0].form)
        names = [variant_name(c.cause, c.form) for c in classes]
        unknown = [k for k in parameters if k not in names]
        missing = [n for n in names if n not in parameters]
        if unknown or missing:
            raise ParameterError(f"variant_parameters of the combination {name!r} must be an "
                                 f"object keyed by its members {names} (each the member's "
                                 f"parameters); unknown {unknown}, missing {missing}")
        return cls.combine(*(cls(c.cause, parameters[n], c.form)
                             for c, n in zip(classes, names)))

    @classmethod
    def from_dict(cls, data: Mapping) -> "ModelVariant":
        """From ``{"cause", ["form",] "parameters"}`` or ``{"components": [...]}``.

        ``"none"`` is the paper's model; other top-level keys (``"provenance"``,
        notes) are ignored. A whole diagnosis (``smeha diagnose --json``) is read
        by ``smeha.diagnose.variant_from_diagnosis``, not here.
        """
        if not isinstance(data, Mapping):
            raise ParameterError("a model variant is a JSON object with 'cause' and "
                                 "'parameters' (or 'components')")
        if "candidates" in data:
            raise ParameterError("this is a whole diagnosis (it has 'candidates'); read it "
                                 "with smeha.diagnose.variant_from_diagnosis (smeha flow "
                                 "--variant does)")
        if "components" in data:
            comps = data["components"]
            if not isinstance(comps, (list, tuple)) or not comps:
                raise ParameterError("'components' must be a non-empty list of "
                                     "{cause, form, parameters} objects")
            return cls.combine(*(cls.from_dict(c) for c in comps))
        if "cause" not in data:
            raise ParameterError("a model variant is a JSON object with 'cause' (and "
                                 "'parameters'), or 'components'")
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

    def extension_classes(self) -> tuple:
        """The members' extension classes, in stage order."""
        return tuple(ext.lookup(m.cause, m.form) for m in self.members if not m.is_paper)

    def steady_components(self) -> tuple:
        """(extension class, SI parameters) of each member, for
        :func:`gmt.extensions.steady.steady_state`."""
        return tuple((ext.lookup(m.cause, m.form), dict(m.parameters))
                     for m in self.members if not m.is_paper)


def _combined(*components):
    return ModelVariant.combine(*components)


# ================================================================== the chain of forms


class Chain:
    """The time-stepped forms of a variant's members, chained in stage order.

    Built with the operating point; the field stage (an eddy form) may change
    the point's mu', and every later stage sees the point and the periodic
    magnetisation the stages before it leave (module docstring).

    Attributes
    ----------
    forms : list of Extension
        The members' time-stepped forms, in stage order.
    point : OperatingPoint
        The operating point after the field stage.
    mechanics : tuple
        (m, c, K) of eq 27 for the rest state and the ZOH (the mechanics form's).
    """

    def __init__(self, variant: ModelVariant, params: TransducerParameters,
                 point: OperatingPoint):
        self.params = params
        self.forms = []
        components = variant.steady_components()
        point = self.paper_point(components, params, point)
        hm = point.field_amplitude
        m1 = complex(point.mu_real - 1.0, -point.mu_imag) * hm

        def upstream(theta, _m1=m1):
            return np.real(_m1 * np.exp(1j * np.asarray(theta)))

        self.field = self.mechanical = self.sensor = None
        self.adjusting = []
        for cls, values in components:
            form = cls(values, params, point, upstream)
            if cls.stage == "magnetization":  # switching on the field stage's field
                form.field_stage = self.field
            self.forms.append(form)
            if cls.stage == "field":
                point = form.point
                self.field = form
            elif cls.stage in ("magnetization", "strain"):
                self.adjusting.append(form)
            elif cls.stage == "mechanics":
                self.mechanical = form
            else:
                self.sensor = form
            upstream = _chained(form, upstream)
        self.point = point
        self.mechanics = (self.mechanical.mechanics if self.mechanical is not None
                          else (params.mass, params.damping, params.stiffness))
        sizes = [f.state_size for f in self.forms]
        if any(s is None for s in sizes[:-1]):
            raise ParameterError("only the last stage's memory may vary in size")

    @staticmethod
    def paper_point(components, params, point):
        """The operating point with the paper part's mu when another stage changes it.

        With an eddy-current field stage (mean field g H) or a magnetisation-stage
        extension (which changes M, its fundamental too), the coil's B_m belongs
        to the whole; the paper's part keeps eqs 16 and 20 at its own flux
        density (:func:`gmt.extensions.paperpart.paper_permeability`, as the
        periodic forms). Otherwise the point is returned as it is.
        """
        from .extensions._base import Steady
        from .extensions.paperpart import paper_permeability
        from .extensions.steady import stage_adder, switching_gain

        field = [(c, v) for c, v in components if c.stage == "field"]
        magnetic = [(c, v) for c, v in components if c.stage == "magnetization"]
        if not field and not magnetic:
            return point
        w = point.angular_frequency
        cls, values = field[0] if field else (None, None)
        gain = complex(np.ravel(cls.field_gain(values, w))[0]) if cls else 1.0
        # unshielded vacuum flux the coil sees adds to B (MagnetizationDiffusionForm)
        vacuum = complex(np.ravel(cls.vacuum_share(values, w))[0]) if cls else 0.0
        factor = float(np.ravel(cls.loss_flux_factor(values, w))[0]) if cls else 1.0
        loss = (params.hysteresis_coefficient, params.steinmetz_exponent,
                params.eddy_coefficient, params.excess_coefficient)
        hm = point.field_amplitude
        steady = Steady(params, np.array([point.frequency]), np.array([w]),
                        np.array([point.current_amplitude]), np.array([hm]),
                        np.array([point.flux_density_amplitude]), loss, None,
                        switching_gain(components, np.array([w])))
        modulus = point.flux_density_amplitude / (MU_0 * hm)
        mu = complex(np.ravel(paper_permeability(loss, point.frequency, hm, modulus, gain,
                                                 stage_adder(magnetic, steady), factor,
                                                 vacuum))[0])
        if not -mu.imag < 0.999 * abs(mu):
            raise ParameterError(
                f"{' + '.join(variant_name(c.cause, c.form) for c, _ in components)}: mu'' of "
                f"eq 16 reaches |mu| at f = {point.frequency:g} Hz, so eq 20 has no real mu' "
                "(the extensions' parameters leave the measured B_m out of reach)")
        return replace(point, mu_real=mu.real, mu_imag=-mu.imag)

    def magnetics(self, current, quadrature, step, time) -> Magnetics:
        """H, H_q, B, M, lambda, F held over the step after the field, magnetisation and
        strain stages."""
        if self.field is not None:
            mag = self.field.magnetics(current, quadrature, step, time)
        else:
            mag = magnetics(self.params, self.point, current, quadrature)
        for form in self.adjusting:
            mag = form.adjust(mag, step, time)
        return mag

    def sensed(self, displacement, time) -> float:
        return displacement if self.sensor is None else self.sensor.sensed(displacement, time)

    def reset(self, rest_displacement) -> None:
        for form in self.forms:
            form.reset(rest_displacement)

    def get_state(self) -> tuple:
        out = ()
        for form in self.forms:
            out += tuple(form.get_state())
        return out

    def set_state(self, state) -> None:
        """Restore :meth:`get_state`; raises before changing anything if it does not fit."""
        state = tuple(state)
        fixed = [f.state_size for f in self.forms]
        need = sum(s for s in fixed if s is not None)
        variable = any(s is None for s in fixed)
        if len(state) < need or (not variable and len(state) != need):
            names = " + ".join(variant_name(f.cause, f.form) for f in self.forms)
            raise ParameterError(f"{names} state has {len(state)} values; its memory needs "
                                 f"{need}" + (" or more" if variable else ""))
        saved = [f.get_state() for f in self.forms]
        k = 0
        try:
            for form, size in zip(self.forms, fixed):
                part = state[k:] if size is None else state[k:k + size]
                form.set_state(part)
                k += len(part)
        except ParameterError:
            for form, old in zip(self.forms, saved):
                form.set_state(old)
            raise


def _chained(form, upstream):
    return lambda theta: form.waveform(theta, upstream)


# ================================================================== the stepper


class VariantStepResult(NamedTuple):
    """Outputs of one step of :class:`ExtendedStepper` (state at the end of the step)."""

    magnetics: Magnetics
    displacement: float  #: y at t + h, [m]
    velocity: float  #: dy/dt at t + h, [m/s]
    sensed_displacement: float  #: what the displacement sensor reads at t + h, [m]


class ExtendedStepper(ForwardStepper):
    """:class:`gmt.forward.ForwardStepper` with a variant's chain of time-stepped forms.

    Same time alignment, quadrature rule (eq 31) and ZOH mechanics as the
    paper's stepper; the chain supplies the magnetics, the mechanics and the
    sensed displacement.

    Parameters
    ----------
    params : TransducerParameters
    point : OperatingPoint
        The paper's operating point (an eddy form may change mu').
    variant : ModelVariant

    Notes
    -----
    State: the paper stepper's five values (y, v, previous current, previous
    step, branch), then the elapsed time [s], the sensed displacement [m] and
    the members' memory in stage order (its length depends on the members;
    for the delay it varies). With two masses (``displacement`` and
    ``velocity`` are the output's) the rod's y_1, v_1 are the two-mass form's
    memory.
    """

    def __init__(self, params: TransducerParameters, point: OperatingPoint,
                 variant: ModelVariant):
        self.variant = variant
        self.chain = Chain(variant, params, point)
        super().__init__(params, self.chain.point)

    @property
    def form(self):
        """The single member's time-stepped form (the first for a combination)."""
        return self.chain.forms[0]

    @property
    def rod_displacement(self):
        """y_1 of the two-mass form (the rod), [m]; the displacement otherwise."""
        mech = self.chain.mechanical
        return getattr(mech, "rod_displacement", self.displacement)

    def reset(self):
        super().reset()
        p = self.params
        self.displacement = magnetostrictive_force(
            magnetostriction(0.0, p.bias_magnetization, p.magnetostriction_coefficient),
            p.rod_area, p.youngs_modulus) / self.chain.mechanics[2]
        self.elapsed = 0.0
        self.sensed_displacement = self.displacement
        self.chain.reset(self.displacement)

    def get_state(self) -> tuple:
        return (super().get_state() + (self.elapsed, self.sensed_displacement)
                + self.chain.get_state())

    def set_state(self, state) -> None:
        state = tuple(float(s) for s in state)
        if len(state) < 7:
            raise ParameterError(f"state has {len(state)} values; this variant needs at "
                                 "least 7")
        self.chain.set_state(state[7:])
        super().set_state(state[:5])
        self.elapsed, self.sensed_displacement = state[5], state[6]

    def step(self, current: float, step: float, external_force: float = 0.0,
             held: bool = False):
        """Advance by ``step`` [s] with ``current`` [A] and ``external_force`` [N] held
        (``held``: as :meth:`gmt.forward.ForwardStepper.step`)."""
        q = self._quadrature(current, step, external_force, held)
        mag = self.chain.magnetics(current, q, step, self.elapsed)
        mech = self.chain.mechanical
        if mech is not None and hasattr(mech, "advance"):
            mech.advance(self, mag.force, current, step, external_force)
            self._remember(current, step, held)
        else:
            self._advance(mag.force, current, step, external_force, *self.chain.mechanics,
                          held)
        self.elapsed += step
        self.sensed_displacement = float(self.chain.sensed(self.displacement, self.elapsed))
        return VariantStepResult(mag, self.displacement, self.velocity,
                                 self.sensed_displacement)


def make_stepper(params: TransducerParameters, point: OperatingPoint,
                 variant: ModelVariant | None = None):
    """The paper's :class:`ForwardStepper`, or an :class:`ExtendedStepper` for a variant."""
    if variant is None or variant.is_paper:
        return ForwardStepper(params, point)
    return ExtendedStepper(params, point, variant)
