"""FMI 2.0 co-simulation slave of the giant magnetostrictive transducer (pythonfmu 0.7).

A thin slave: it registers the variables of ``smeha_fmu_interface`` (the
file next to this one), copies values in and out, and delegates every step
to :class:`gmt.Transducer`. No physics here.

Life cycle
----------
* Parameters are fixed: they are read when the host leaves initialisation mode
  (``fmi2ExitInitializationMode``), which builds the gmt objects. ``fmi2Reset``
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
  (:meth:`SmehaGmt._fail_step` balances the references pythonfmu releases
  after an exception, so the host may still terminate, reset and free the
  instance).
* The FMU state (``fmi2GetFMUstate`` / serialisation) holds every variable,
  the parameter set the gmt objects were built from and
  :meth:`gmt.Transducer.get_state`, as JSON.
"""
from __future__ import annotations

import smeha_fmu_runtime  # first, before any extension module: see its docstring

smeha_fmu_runtime.prepare()

import ctypes  # noqa: E402  (an extension module: after prepare())

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

import smeha_fmu_interface as iface  # next to this file, in fmu_src/ and in the FMU's resources
import smeha_fmu_slave as slave  # the callbacks both slaves share

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
        for var in iface.VARIABLES:
            setattr(self, var.name, var.initial_value)
            options = {}
            if var.causality == "parameter":
                options["setter"] = self._parameter_setter(var.name)
            self.register_variable(_TYPES[var.kind](
                var.name, causality=_CAUSALITY[var.causality],
                variability=_VARIABILITY[var.variability],
                description=var.description, **options))

    def _fail_step(self, message: str):
        # pythonfmu 0.7 answers an exception from do_step with fmi2Fatal after releasing
        # (Py_DECREF) its references to the slave class, the instance and its log queue,
        # and releases the instance and the queue once more when the host resets or frees
        # the instance (the class too when it frees it): one release per exception more
        # than it owns. An owner-less reference per exception, taken through the C API,
        # balances each one, so the three stay alive and later calls, fmi2Reset and
        # fmi2FreeInstance are safe (what is left over leaks: a few kB per failure).
        # A Python list holding them would not do: its own references would be the ones
        # released, and freeing the list at interpreter exit would free them again.
        for obj in (type(self), self, self.log_queue):
            _INCREF(obj)
        raise RuntimeError(message)


#: Py_IncRef of the C API (ctypes.pythonapi: the interpreter the FMU runs in).
_INCREF = ctypes.pythonapi.Py_IncRef
_INCREF.argtypes = (ctypes.py_object,)
_INCREF.restype = None
