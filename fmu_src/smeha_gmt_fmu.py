"""FMI 2.0 co-simulation slave of the giant magnetostrictive transducer (pythonfmu 0.7).

A thin slave: it registers the variables of ``smeha_fmu_interface`` (the
file next to this one), copies values in and out, and delegates every step
to :class:`gmt.Transducer`. No physics here.

Life cycle
----------
* Parameters are fixed: they are read when the host leaves initialisation mode
  (``fmi2ExitInitializationMode``), which builds the gmt objects. The calculated
  parameters (the rod's mechanics) are computed from the parameters set so far
  whenever a host reads them in Initialization Mode
  (:meth:`smeha_fmu_base.SlaveBase._calculated_value`). ``fmi2Reset``
  re-runs the constructor (pythonfmu), so the host initialises again.
* ``fmi2DoStep(t, h)`` holds ``u`` and ``external_force`` over [t, t+h) and
  returns the outputs at t+h, as :meth:`gmt.Transducer.step` does.
* Errors are caught and logged through the FMU logger. A bad input or step
  size makes that step return fmi2Discard and leaves the state untouched. A
  bad parameter or a missing package makes the instance unusable:
  initialisation logs an error, and its every ``fmi2DoStep`` then raises into
  pythonfmu, which returns **fmi2Fatal**: pythonfmu 0.7 maps a ``do_step``
  result to OK or Discard only, and fmpy takes a Discard of a terminated
  instance as a normal end, so Fatal is the one status no host can miss
  (:func:`smeha_fmu_base.fail_step_fmi2` balances the references pythonfmu releases
  after an exception, so the host may still terminate, reset and free the
  instance).
* The FMU state (``fmi2GetFMUstate`` / serialisation) holds every variable,
  the parameter set the gmt objects were built from and
  :meth:`gmt.Transducer.get_state`, as JSON.
"""
from __future__ import annotations

import os  # frozen in CPython 3.11: safe before prepare()

import smeha_fmu_runtime  # first, before any extension module: see its docstring

smeha_fmu_runtime.prepare(os.path.dirname(os.path.abspath(__file__)))  # this FMU's record

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

import smeha_fmu_interface as iface  # next to this file, in fmu_src/ and in the FMU's resources
import smeha_fmu_slave as slave  # the callbacks both slaves share
from smeha_fmu_base import fail_step_fmi2

# resources/smeha_fmu_gmt: the FMU's own copy, unless a package it needs is missing
gmt, _IMPORT_PROBLEM = slave.load_physics(smeha_fmu_runtime.missing_packages_message())

_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
_CAUSALITY = {"input": Fmi2Causality.input, "parameter": Fmi2Causality.parameter,
              "calculatedParameter": Fmi2Causality.calculatedParameter,
              "output": Fmi2Causality.output}
_VARIABILITY = {"fixed": Fmi2Variability.fixed, "continuous": Fmi2Variability.continuous,
                "discrete": Fmi2Variability.discrete}


class SmehaGmt(slave.TransducerSlave, Fmi2Slave):
    """Giant magnetostrictive transducer with its amplifier and inverse compensator.

    Every callback is :class:`smeha_fmu_slave.TransducerSlave`'s; this class
    names the FMI 2.0 flavour and registers the variables.
    """

    author = iface.AUTHOR
    license = iface.LICENSE
    description = iface.DESCRIPTION
    version = getattr(gmt, "__version__", None)
    default_experiment = DefaultExperiment(**iface.DEFAULT_EXPERIMENT)
    MODEL_NAME = iface.MODEL_NAME_FMI2
    STATUS_ERROR, STATUS_WARNING, STATUS_DISCARD = (Fmi2Status.error, Fmi2Status.warning,
                                                    Fmi2Status.discard)
    PHYSICS, IMPORT_PROBLEM = gmt, _IMPORT_PROBLEM

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        smeha_fmu_runtime.arm_clean_exit(iface.MODEL_NAME_FMI2)  # exits cleanly: see there
        self._init_transducer()
        self._register(_TYPES, _CAUSALITY, _VARIABILITY)

    def _fail_step(self, message: str):
        return fail_step_fmi2(self, message)  # fmi2Fatal: see there
