"""The callbacks both FMU slaves share: build gmt's transducer, step it, save and restore it.

``smeha_gmt_fmu.py`` (FMI 2.0) and ``smeha_gmt_fmu3.py`` (FMI 3.0) put
:class:`TransducerSlave` before their pythonfmu base class and register the
variables of ``smeha_fmu_interface``; this module holds everything they do alike:
building :class:`gmt.Transducer` from the parameters (:func:`make_transducer`),
the outputs of a step, the FMU state, and what an instance does when it cannot
run (a bad parameter, a package missing). No physics here: gmt computes.

Bundled in the FMU as ``resources/smeha_fmu_slave.py`` (a name unique to this
project); imports nothing from ``smeha`` and gmt only through
``smeha_fmu_interface.physics`` (inside an FMU, the bundled copy).
"""
from __future__ import annotations

import operator

import smeha_fmu_interface
from smeha_fmu_base import SlaveBase
from smeha_fmu_interface import (BY_NAME, DRIVE_PARAMETERS, EXCITATION_PARAMETERS,
                                 INVERSE_MODELS, MECHANICS, MODEL_VARIANTS, OUTPUTS,
                                 REAL_OUTPUTS, TIME_DOMAIN_PARAMETERS, TRANSDUCER_PARAMETERS,
                                 VARIABLE_NAMES, coerce, parameter_values, physics)

#: One C-level getter of every variable's value, in VARIABLES order: a saved FMU state
#: holds the values as a tuple in this order (a co-simulation master saves and restores
#: the state at every step, and a dict of ~50 getattrs was most of it)
_all_values = operator.attrgetter(*VARIABLE_NAMES)


def make_transducer(values: dict):
    """Build the ``gmt.Transducer`` for a set of parameter values.

    Parameters
    ----------
    values : dict
        Parameter name -> value, as :func:`parameter_values` returns.

    Raises
    ------
    gmt.ParameterError
        A value outside the range gmt accepts, or an unknown ``model_variant``.
    """
    gmt = physics()  # inside an FMU: the bundled copy (resources/smeha_fmu_gmt)

    variant = model_variant(gmt, values["model_variant"], values["variant_parameters"])
    params = gmt.TransducerParameters(**{n: values[n] for n in TRANSDUCER_PARAMETERS})
    excitation = gmt.Excitation(**{n: values[n] for n in EXCITATION_PARAMETERS})
    drive = gmt.DriveParameters(**{n: values[n] for n in DRIVE_PARAMETERS})
    td = gmt.TimeDomainParameters(
        **{n: values[n] for n in TIME_DOMAIN_PARAMETERS})
    inverse = values["inverse_model"]
    if inverse not in INVERSE_MODELS:
        raise gmt.ParameterError(f"inverse_model = {inverse!r} is not one of {INVERSE_MODELS}")
    return gmt.Transducer(params, excitation, drive, variant=variant,
                          magnetics=values["magnetics"],
                          inverse=None if inverse == "same" else inverse, time_domain=td)


def model_variant(gmt, name: str, parameters: str):
    """The ``gmt.ModelVariant`` of the ``model_variant`` and ``variant_parameters`` strings.

    Raises
    ------
    gmt.ParameterError
        An unknown variant, parameters that are not a JSON object, or a
        missing, unknown or out-of-range parameter; the message names
        ``model_variant`` or ``variant_parameters`` and the offending key.
    """
    import json

    if name not in MODEL_VARIANTS:  # a combination: members of MODEL_VARIANTS joined by "+"
        try:
            gmt.extensions.parse_name(name)
        except gmt.ParameterError as exc:
            raise gmt.ParameterError(f"model_variant = {name!r} is not one of {MODEL_VARIANTS} "
                                     f"nor a combination of them joined by '+' ({exc})") from None
    text = parameters.strip() or "{}"
    try:
        values = json.loads(text)
    except ValueError as exc:
        raise gmt.ParameterError(f"variant_parameters = {text!r} is not valid JSON "
                                 f"({exc}); give a JSON object such as "
                                 '{"delay_s": 0.0005}') from None
    if not isinstance(values, dict):
        raise gmt.ParameterError(f"variant_parameters = {text!r} is not a JSON object")
    try:
        return gmt.ModelVariant.from_name(name, values)
    except gmt.ParameterError as exc:
        raise gmt.ParameterError(f"variant_parameters = {text!r} for model_variant "
                                 f"{name!r}: {exc}") from None


def output_values(out, point) -> tuple:
    """Real outputs (in :data:`REAL_OUTPUTS` order), ``saturated``, ``saturation_count`` and
    ``outside_design_point``.

    Parameters
    ----------
    out : gmt.TransducerOutput
    point : gmt.OperatingPoint
        The operating point the transducer's model runs at now.
    """
    m = out.magnetics
    reals = (out.current, out.displacement, out.velocity, out.sensed_displacement, m.field,
             m.flux_density, m.magnetization, m.strain, m.force, point.frequency,
             point.current_amplitude)
    return (tuple(float(x) for x in reals), bool(out.saturated), int(out.saturation_count),
            bool(out.outside_design_point))


def load_physics(problem: str | None = None):
    """(gmt module, None), or (None, the problem) when it cannot be imported.

    Parameters
    ----------
    problem : str, optional
        A reason known beforehand (``smeha_fmu_runtime.missing_packages_message``):
        gmt is then not imported. Every instance of the slave reports the problem
        instead of crashing the host.
    """
    if problem:
        return None, problem
    try:
        return physics(), None
    except Exception as exc:
        return None, (f"cannot import gmt ({type(exc).__name__}: {exc}); the FMU needs numpy "
                      "importable by the Python of the host process")


class TransducerSlave(SlaveBase):
    """The callbacks both slaves share: a mixin placed before the pythonfmu(3) base.

    The slave class sets the FMI flavour (status values, function names for
    messages, its physics module) and registers its variables; this class
    builds :class:`gmt.Transducer` on leaving initialisation, steps it, and
    saves and restores the FMU state. Exceptions do not reach pythonfmu
    uninvited: each callback catches them and logs through the FMU logger.
    A step with a bad input returns Discard with the state rolled back (the
    host may retry). An *unusable* instance -- a bad parameter, a package
    missing -- cannot return Error from initialisation (pythonfmu turns every
    exception there into Fatal), so its first and every later ``doStep``
    fails with what the slave's :meth:`_fail_step` returns, the strongest
    status the FMI flavour can give, and the reason is also written once to
    the process's stderr (a host may run without FMU logging;
    :class:`smeha_fmu_base.SlaveBase`). A slave with
    more state than the variables (FMI 3.0's ``time``) extends
    :meth:`_after_step`, :meth:`_extra_state` and :meth:`_restore_extra`.
    """

    PHYSICS = None  # the gmt module the slave imported
    TABLE = smeha_fmu_interface

    def _init_transducer(self):
        """The variables at their initial values; no transducer until initialisation."""
        self._transducer = None  # gmt.Transducer, built on leaving initialisation
        self._built_from = None  # parameter values it was built from
        self._warned_design_point = set()  # the design-point warnings logged (once each)
        self._preview = None  # (values, gmt.Transducer) built to answer calculated parameters
        self._init_base()

    def _built(self) -> bool:
        return self._transducer is not None

    def _discard_model(self) -> None:
        self._transducer, self._built_from = None, None

    def _calculated_value(self, name):
        if self._transducer is not None:
            return getattr(self, name)
        values = parameter_values(self)
        if self._preview is None or self._preview[0] != values:
            self._preview = (values, make_transducer(values))  # not yet stepped: reusable
        # gmt.RodMechanics holds them in MECHANICS order (interface.check_against_gmt)
        return float(self._preview[1].rod_mechanics()[MECHANICS.index(name)])

    def _build(self, values: dict) -> bool:
        """Build the gmt objects from parameter values; log and return False on error."""
        try:
            preview, self._preview = self._preview, None
            self._transducer = (preview[1] if preview is not None and preview[0] == values
                                else make_transducer(values))
        except Exception as exc:
            self._transducer, self._built_from = None, None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)
            return False
        self._built_from = dict(values)
        self._problem = None
        return True

    def _rest_outputs(self):
        for name in OUTPUTS:
            setattr(self, name, BY_NAME[name].initial_value)
        forward = self._transducer.forward
        self.displacement, self.velocity = float(forward.displacement), float(forward.velocity)
        self.sensed_displacement = float(self._transducer.sensed_displacement)
        point = self._transducer.point
        self.operating_frequency = float(point.frequency)
        self.operating_current_amplitude = float(point.current_amplitude)
        for name, value in zip(MECHANICS, self._transducer.rod_mechanics()):
            setattr(self, name, float(value))

    def exit_initialization_mode(self):
        from pathlib import Path
        try:
            if self._build(parameter_values(self)):
                self._rest_outputs()
                used = Path(self.PHYSICS.__file__).resolve().parent
                bundled = Path(self.resources or ".").resolve() / used.name
                if used != bundled and not _same_sources(used, bundled):
                    self._report(f"gmt is imported from {used}, not from the FMU's "
                                 f"resources, and differs from this FMU's: another FMU "
                                 f"of its build, whose files differ, loaded {used.name} "
                                 "first", self.STATUS_WARNING)
        except Exception as exc:
            self._transducer = None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)

    def do_step(self, current_time, step_size):
        transducer = self._transducer
        if transducer is None:
            return self._refuse_step(current_time)
        saved = transducer.get_state()
        try:
            out = transducer.step(self.u, step_size, self.external_force)
            reals, self.saturated, self.saturation_count, self.outside_design_point = (
                output_values(out, transducer.point))
        except Exception as exc:
            try:
                transducer.set_state(saved)
            except Exception:  # pragma: no cover - defensive
                self._transducer, self._problem = None, "state lost after a failed step"
            self._report(f"doStep at t = {current_time!r} s, step {step_size!r} s discarded: "
                         f"{type(exc).__name__}: {exc}", self.STATUS_DISCARD)
            return False
        for name, value in zip(REAL_OUTPUTS, reals):
            setattr(self, name, value)
        if self.outside_design_point:
            # once per instance, and once more for the first sample's provisional verdict
            # (a drive not at its peak at the start), which a sinusoid's second sample clears
            kind = "start" if transducer.monitor.provisional else "drive"
            if kind not in self._warned_design_point:
                self._warned_design_point.add(kind)
                self._report(transducer.monitor.describe(), self.STATUS_WARNING)
        self._after_step(current_time, step_size)
        return True

    def _after_step(self, current_time, step_size):
        """Hook after a successful step (FMI 3.0 advances its ``time``)."""

    def _extra_state(self) -> dict:
        """State beyond the variables, the parameters and the transducer (FMI 3.0: time)."""
        return {}

    def _restore_extra(self, state: dict) -> None:
        """Restore what :meth:`_extra_state` saved."""

    def _get_fmu_state(self):
        return self._saved_state(self._state)

    def _state(self) -> dict:
        transducer = self._transducer
        state = {
            "values": _all_values(self),
            "built_from": self._built_from,
            "transducer": list(transducer.get_state()) if transducer is not None else None,
            "problem": self._problem,
            # values are already of their variables' types (not so after a JSON
            # round trip, which _fmu_state_from_bytes marks False)
            "typed": True,
        }
        state.update(self._extra_state())
        return state

    def _set_fmu_state(self, state):
        self._restore_state(state, self._restore)

    def _restore(self, state: dict) -> None:
        if self._transducer is not None:
            self._transducer.set_state(state["transducer"])
        if state.get("typed"):
            # only what changed since (inputs, outputs): the rest already holds these values
            for name, now, value in zip(VARIABLE_NAMES, _all_values(self), state["values"]):
                if now is not value and now != value:
                    setattr(self, name, value)
        else:
            for name, value in state["variables"].items():
                setattr(self, name, coerce(name, value))
        self._restore_extra(state)

    @staticmethod
    def _fmu_state_to_bytes(state):
        # "typed" describes the in-memory copy, not the state: not serialised; the values
        # are written by name
        out = {k: v for k, v in state.items() if k not in ("typed", "values")}
        if "values" in state:
            out["variables"] = dict(zip(VARIABLE_NAMES, state["values"]))
        return SlaveBase._encoded_state(out)

    @classmethod
    def _fmu_state_from_bytes(cls, state):
        out = cls._decoded_state(state)
        if "invalid" not in out:
            out["typed"] = False  # coerce each value again on restore
        return out


def _same_sources(a, b) -> bool:
    """Whether packages ``a`` and ``b`` (folders) hold the same Python sources: the same FMU
    loaded twice (two extractions) shares its physics harmlessly."""
    def sources(root):
        return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*.py"))}
    try:
        return sources(a) == sources(b)
    except OSError:
        return False
