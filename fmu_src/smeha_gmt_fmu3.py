"""FMI 3.0 co-simulation slave of the giant magnetostrictive transducer (pythonfmu3 0.3.4).

The FMI 3.0 twin of ``smeha_gmt_fmu.py``: same variables (plus the
independent variable ``time`` FMI 3.0 requires), same life cycle, same error
handling and FMU state; units are declared natively (``register_units`` and
``unit=`` on every Float64), from the same table ``smeha_fmu_interface``.
Types: Real -> Float64, Integer -> Int32, Boolean, String.

Errors never reach pythonfmu3 (an exception there is fmi3Fatal): a bad input
or step size makes ``fmi3DoStep`` return fmi3Discard, leaving the state
untouched; a bad parameter or a missing package makes initialisation log an
error and every later step return **fmi3Error** (pythonfmu3 takes the status
of a ``do_step`` result). Messages go through the FMU logger.
"""
from __future__ import annotations

import os  # frozen in CPython 3.11: safe before prepare()

import smeha_fmu_runtime  # first, before any extension module: see its docstring

smeha_fmu_runtime.prepare(os.path.dirname(os.path.abspath(__file__)))  # this FMU's record

from xml.etree.ElementTree import Element

from pythonfmu3 import (Boolean, DefaultExperiment, Float64, Fmi3Causality, Fmi3Slave,
                        Fmi3Status, Fmi3StepResult, Fmi3Variability, Int32, String, Unit)

import smeha_fmu_interface as iface  # next to this file, in fmu_src/ and in the FMU's resources
import smeha_fmu_slave as slave  # the callbacks both slaves share

# resources/smeha_fmu_gmt: the FMU's own copy, unless a package it needs is missing
gmt, _IMPORT_PROBLEM = slave.load_physics(smeha_fmu_runtime.missing_packages_message())

_TYPES = {"Real": Float64, "Integer": Int32, "Boolean": Boolean, "String": String}
_CAUSALITY = {"input": Fmi3Causality.input, "parameter": Fmi3Causality.parameter,
              "calculatedParameter": Fmi3Causality.calculatedParameter,
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


class SmehaGmt3(slave.TransducerSlave, Fmi3Slave):
    """Giant magnetostrictive transducer with its amplifier and inverse compensator.

    Every callback is :class:`smeha_fmu_slave.TransducerSlave`'s; this class
    names the FMI 3.0 flavour, registers the variables with their units, and
    keeps the independent variable ``time`` (advanced by each step, saved with
    the FMU state).
    """

    MODEL_NAME = iface.MODEL_NAME_FMI3
    STATUS_ERROR, STATUS_WARNING, STATUS_DISCARD = (Fmi3Status.error, Fmi3Status.warning,
                                                    Fmi3Status.discard)
    EXIT_INITIALIZATION = "fmi3ExitInitializationMode"
    GET_STATE, SET_STATE = "fmi3GetFMUState", "fmi3SetFMUState"
    PHYSICS, IMPORT_PROBLEM = gmt, _IMPORT_PROBLEM

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        smeha_fmu_runtime.arm_clean_exit(iface.MODEL_NAME_FMI3)  # exits cleanly: see there
        self.author = iface.AUTHOR
        self.license = iface.LICENSE
        self.description = iface.DESCRIPTION
        self.version = getattr(gmt, "__version__", None)
        self.default_experiment = DefaultExperiment(**iface.DEFAULT_EXPERIMENT)
        self._init_transducer()
        self.time = 0.0
        self.register_units(_units({v.unit for v in iface.VARIABLES if v.kind == "Real"} | {"s"}))
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous,
                                       description="Simulation time", unit="s"))
        self._register(_TYPES, _CAUSALITY, _VARIABILITY, units=True)

    def enter_initialization_mode(self):
        pass

    def _fail_step(self, message: str):
        return Fmi3StepResult(status=Fmi3Status.error)

    def _after_step(self, current_time, step_size):
        self.time = current_time + step_size

    def _extra_state(self) -> dict:
        return {"time": self.time}

    def _restore_extra(self, state: dict) -> None:
        self.time = float(state["time"])
