"""FMI 3.0 co-simulation slave of the giant magnetostrictive transducer (pythonfmu3 0.3.4).

The FMI 3.0 twin of ``smeha_gmt_fmu.py``: same variables (plus the
independent variable ``time`` FMI 3.0 requires), same life cycle, same error
handling and FMU state; units are declared natively (``register_units`` and
``unit=`` on every Float64), from the same table ``smeha.fmu_interface``.
Types: Real -> Float64, Integer -> Int32, Boolean, String.

Errors never reach pythonfmu3 (an exception there is fmi3Fatal): a bad input
or step size makes ``fmi3DoStep`` return fmi3Discard, leaving the state
untouched; a bad parameter makes initialisation log an error and every later
step return fmi3Discard. Messages go through the FMU logger.
"""
from __future__ import annotations

import json
from pathlib import Path
from xml.etree.ElementTree import Element

from pythonfmu3 import (Boolean, DefaultExperiment, Float64, Fmi3Causality, Fmi3Slave,
                        Fmi3Status, Fmi3Variability, Int32, String, Unit)

try:  # inside the FMU: resources/smeha_fmu_interface.py
    import smeha_fmu_interface as iface
except ImportError:  # pragma: no cover - source tree
    from smeha import fmu_interface as iface

try:  # gmt needs numpy, scipy and control from the host's Python environment
    gmt = iface.physics()  # resources/smeha_fmu_gmt: the FMU's own copy
    _IMPORT_PROBLEM = None
except Exception as exc:  # reported by every instance instead of crashing the host
    gmt = None
    _IMPORT_PROBLEM = (f"cannot import gmt ({type(exc).__name__}: {exc}); the FMU needs "
                       "numpy, scipy and control importable by the host's Python "
                       "(e.g. PYTHONPATH=<site-packages of an environment with them>)")

_TYPES = {"Real": Float64, "Integer": Int32, "Boolean": Boolean, "String": String}
_CAUSALITY = {"input": Fmi3Causality.input, "parameter": Fmi3Causality.parameter,
              "output": Fmi3Causality.output}
_VARIABILITY = {"fixed": Fmi3Variability.fixed, "continuous": Fmi3Variability.continuous,
                "discrete": Fmi3Variability.discrete}


class _NamedUnit(Unit):
    """A unit declared by name only (no integer SI exponents express it)."""

    def to_xml(self) -> Element:
        return Element(self.tag, {"name": self.name})


def _units(names):
    out = []
    for name in sorted(names):
        exponents = iface.UNITS[name]
        out.append(_NamedUnit(name) if exponents is None else Unit(name, **exponents))
    return out


class SmehaGmt3(Fmi3Slave):
    """Giant magnetostrictive transducer with its amplifier and inverse compensator."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.author = iface.AUTHOR
        self.license = iface.LICENSE
        self.description = iface.DESCRIPTION
        self.version = getattr(gmt, "__version__", None)
        self.default_experiment = DefaultExperiment(**iface.DEFAULT_EXPERIMENT)
        self._transducer = None  # gmt.Transducer, built on leaving initialisation
        self._built_from = None  # parameter values it was built from
        self._problem = _IMPORT_PROBLEM or "not initialised (call fmi3ExitInitializationMode)"
        if _IMPORT_PROBLEM:
            self._report(_IMPORT_PROBLEM)
        self.time = 0.0
        self.register_units(_units({v.unit for v in iface.VARIABLES if v.kind == "Real"} | {"s"}))
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous,
                                       description="Simulation time", unit="s"))
        for var in iface.VARIABLES:
            setattr(self, var.name, var.initial_value)
            options = {}
            if var.kind == "Real":
                options["unit"] = var.unit
            if var.causality == "parameter":
                options["setter"] = self._parameter_setter(var.name)
            self.register_variable(_TYPES[var.kind](
                var.name, causality=_CAUSALITY[var.causality],
                variability=_VARIABILITY[var.variability],
                description=var.description, **options))

    # -- helpers ------------------------------------------------------------------
    def _report(self, message: str, status=Fmi3Status.error):
        self.log(message, status)

    def _parameter_setter(self, name):
        def setter(value):
            try:
                if self._transducer is not None:
                    self._report(f"{name}: a fixed parameter cannot change after "
                                 f"initialisation; {value!r} ignored (reset first)")
                    return
                setattr(self, name, iface.coerce(name, value))
            except Exception as exc:  # never raise into pythonfmu3
                self._report(f"{name} = {value!r} rejected: {exc}")
        return setter

    def _build(self, values: dict) -> bool:
        try:
            self._transducer = iface.make_transducer(values)
        except Exception as exc:
            self._transducer, self._built_from = None, None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)
            return False
        self._built_from = dict(values)
        self._problem = None
        return True

    def _rest_outputs(self):
        for name in iface.OUTPUTS:
            setattr(self, name, iface.BY_NAME[name].initial_value)
        forward = self._transducer.forward
        self.displacement, self.velocity = float(forward.displacement), float(forward.velocity)

    # -- FMI callbacks ----------------------------------------------------------------
    def enter_initialization_mode(self):
        pass

    def exit_initialization_mode(self):
        try:
            if self._build(iface.parameter_values(self)):
                self._rest_outputs()
                bundled = Path(self.resources or ".").resolve()
                used = Path(gmt.__file__).resolve()
                if bundled not in used.parents:
                    self._report(f"gmt is imported from {used.parent}, not from the FMU's "
                                 f"resources: another FMU loaded smeha_fmu_gmt first",
                                 Fmi3Status.warning)
        except Exception as exc:
            self._transducer = None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)

    def do_step(self, current_time, step_size):
        transducer = self._transducer
        if transducer is None:
            self._report(f"doStep at t = {current_time!r} s refused: {self._problem}",
                         Fmi3Status.discard)
            return False
        saved = transducer.get_state()
        try:
            out = transducer.step(self.u, step_size, self.external_force)
            reals, self.saturated, self.saturation_count = iface.output_values(out)
        except Exception as exc:
            try:
                transducer.set_state(saved)
            except Exception:  # pragma: no cover - defensive
                self._transducer, self._problem = None, "state lost after a failed step"
            self._report(f"doStep at t = {current_time!r} s, step {step_size!r} s discarded: "
                         f"{type(exc).__name__}: {exc}", Fmi3Status.discard)
            return False
        (self.current, self.displacement, self.velocity, self.field, self.flux_density,
         self.magnetization, self.strain, self.force) = reals
        self.time = current_time + step_size
        return True

    # -- FMU state ----------------------------------------------------------------------
    def _get_fmu_state(self):
        try:
            transducer = self._transducer
            return {
                "variables": {v.name: getattr(self, v.name) for v in iface.VARIABLES},
                "time": self.time,
                "built_from": self._built_from,
                "transducer": list(transducer.get_state()) if transducer is not None else None,
                "problem": self._problem,
            }
        except Exception as exc:
            self._report(f"fmi3GetFMUState failed: {type(exc).__name__}: {exc}")
            return {"invalid": str(exc)}

    def _set_fmu_state(self, state):
        try:
            if "invalid" in state:
                raise ValueError(f"the state is invalid: {state['invalid']}")
            built_from = state["built_from"]
            if built_from is None:
                self._transducer, self._built_from = None, None
            elif self._transducer is None or built_from != self._built_from:
                if not self._build(built_from):
                    return
            if self._transducer is not None:
                self._transducer.set_state(state["transducer"])
            for name, value in state["variables"].items():
                setattr(self, name, iface.coerce(name, value))
            self.time = float(state["time"])
            self._problem = state["problem"]
        except Exception as exc:
            self._report(f"fmi3SetFMUState failed: {type(exc).__name__}: {exc}")

    @staticmethod
    def _fmu_state_to_bytes(state):
        try:
            return json.dumps(state).encode("utf-8")
        except Exception as exc:
            return json.dumps({"invalid": f"not serialisable: {exc}"}).encode("utf-8")

    @staticmethod
    def _fmu_state_from_bytes(state):
        try:
            out = json.loads(bytes(state).decode("utf-8"))
            if not isinstance(out, dict):
                raise ValueError("not a JSON object")
            return out
        except Exception as exc:
            return {"invalid": f"not a serialised SmehaGmt3 state: {exc}"}
