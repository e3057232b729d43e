"""What every slave of this project does alike, whatever it models.

The transducer's slaves (``smeha_fmu_slave.TransducerSlave``, FMI 2.0 and FMI 3.0), the
hydraulic plant's and the drive signal's (FMI 2.0) put :class:`SlaveBase` before their
pythonfmu(3) base class. It registers a variable table (``smeha_fmu_variables.Variable``
records), fixes parameters after initialisation, reports through the FMU logger, and makes
an *unusable* instance -- a bad parameter, a package missing -- fail every step with a
status no host can miss (:meth:`SlaveBase._refuse_step`; for FMI 2.0,
:func:`fail_step_fmi2`).

Bundled into each FMU's resources under this name and the build's identifier; imports only
the standard library (``ctypes`` when an FMI 2.0 step fails, after the run-time set-up).
"""
from __future__ import annotations

import re

#: A "%" and the blanks before it, written " percent" in every message (:meth:`SlaveBase._report`).
_NO_PERCENT = re.compile(r"\s*%")


class SlaveBase:
    """The callbacks every slave of this project shares: a mixin before the pythonfmu(3) base.

    The slave class names its FMI flavour (status values, the function names its
    messages use), its variable table (:attr:`TABLE`) and what it imported
    (:attr:`IMPORT_PROBLEM`), and says whether its model is built (:meth:`_built`).
    """

    MODEL_NAME = ""
    STATUS_ERROR = STATUS_WARNING = STATUS_DISCARD = None
    EXIT_INITIALIZATION = "fmi2ExitInitializationMode"
    GET_STATE = "fmi2GetFMUstate"
    SET_STATE = "fmi2SetFMUstate"
    IMPORT_PROBLEM = None  # why the slave's physics could not be imported, if it could not
    TABLE = None  # the variable table module: VARIABLES, BY_NAME

    def _init_base(self):
        """Every variable at its initial value; the instance not usable until initialised."""
        for var in self.TABLE.VARIABLES:
            setattr(self, var.name, var.initial_value)
        self._problem = self.IMPORT_PROBLEM or f"not initialised (call {self.EXIT_INITIALIZATION})"
        self._told_stderr = False  # the unusable instance's reason goes to stderr once
        if self.IMPORT_PROBLEM:
            self._report(self.IMPORT_PROBLEM)

    def _register(self, types: dict, causality: dict, variability: dict, units: bool = False,
                  getters: dict | None = None):
        """Register every variable of :attr:`TABLE` with pythonfmu(3)'s classes and enums
        (``types``: FMI type name -> class; ``units``: pass each Real's unit, FMI 3.0;
        ``getters``: variable name -> the function that reads it, for an output computed
        on read rather than held in the attribute of its name)."""
        getters = getters or {}
        for var in self.TABLE.VARIABLES:
            options = {}
            if units and var.kind == "Real":
                options["unit"] = var.unit
            if var.causality == "parameter":
                options["setter"] = self._parameter_setter(var.name)
            elif var.causality == "calculatedParameter":
                options["getter"] = self._calculated_getter(var.name)
            if var.name in getters:
                options["getter"] = getters[var.name]
            self.register_variable(types[var.kind](
                var.name, causality=causality[var.causality],
                variability=variability[var.variability],
                description=var.description, **options))

    def _built(self) -> bool:
        """Whether the model has been built from the parameters (they are then fixed)."""
        raise NotImplementedError

    def _report(self, message: str, status=None):
        # an FMI 2.0 host's logger takes the message as a printf format (fmi2CallbackLogger),
        # where a bare "%" is a conversion (libcosim printed "5 1n frequency" for "5 % in
        # frequency"), and a chain of hosts may format it more than once (fmpy's container
        # FMU formats its inner FMU's message and passes the result on as a format); FMI
        # 3.0's logMessage takes plain text. A message without "%" reads the same in all
        self.log(_NO_PERCENT.sub(" percent", message),
                 self.STATUS_ERROR if status is None else status)

    def _parameter_setter(self, name):
        def setter(value):
            try:
                value = self.TABLE.BY_NAME[name].coerce(value)
                if self._built():
                    # a set to the value in effect changes nothing and is accepted (an SSP
                    # host such as OMSimulator re-applies its parameter connections at
                    # every step); any other value is refused
                    if value != getattr(self, name):
                        self._report(f"{name}: a fixed parameter cannot change after "
                                     f"initialisation; {value!r} ignored (reset first)")
                    return
                setattr(self, name, value)
            except Exception as exc:  # never raise into pythonfmu
                self._report(f"{name} = {value!r} rejected: {exc}")
        return setter

    def _calculated_getter(self, name):
        def getter():
            try:
                return self._calculated_value(name)
            except Exception as exc:  # never raise into pythonfmu
                self._report(f"{name} cannot be calculated: {type(exc).__name__}: {exc}")
                return self.TABLE.BY_NAME[name].initial_value
        return getter

    def _calculated_value(self, name):
        """A calculated parameter's value from the parameters as they are now.

        A host may read calculated parameters from Initialization Mode on, before the
        model is built (FMI 2.0.4, section 4.2.4, calling-sequence table, condition 2:
        the variables of ``<InitialUnknowns>``, which section 2.2.8 makes list every
        ``calculatedParameter``; FMI 3.0.2, section 2.3.3 "State: Initialization Mode":
        ``fmi3Get{VariableType}`` there may trigger computations), and an SSP host routes
        them into another FMU's parameters there. The slave computes them on request
        from the parameter values set so far; once built, its model holds them.
        """
        return getattr(self, name)

    def _refuse_step(self, current_time):
        """An unusable instance's step: log the reason (Error), tell stderr once, fail."""
        import sys

        message = f"doStep at t = {current_time!r} s refused: {self._problem}"
        self._report(message)
        if not self._told_stderr:
            self._told_stderr = True
            sys.stderr.write(f"{self.MODEL_NAME} instance {self.instance_name!r}: {message}\n")
            sys.stderr.flush()
        return self._fail_step(message)

    def _fail_step(self, message: str):
        """What ``do_step`` of an unusable instance returns (or raises): the slave's choice."""
        raise NotImplementedError

    # -- the FMU state: the slave's model is rebuilt from the parameter values it was built
    #    from (``_built_from``) when a state from another parameter set is restored
    def _build(self, values: dict) -> bool:
        """Build the model from parameter values; log and return False on error."""
        raise NotImplementedError

    def _discard_model(self) -> None:
        """No model: the instance as before initialisation."""
        raise NotImplementedError

    def _model_for(self, built_from) -> bool:
        """Make the model the one the parameter values ``built_from`` give (None: no model);
        False when it cannot be built (the reason is logged)."""
        if built_from is None:
            self._discard_model()
            return True
        if not self._built() or (built_from is not self._built_from
                                 and built_from != self._built_from):
            return self._build(built_from)
        return True

    def _saved_state(self, save) -> dict:
        """An FMI get-state: ``save()``, or ``{"invalid": why}`` with the reason logged (the
        set-state that receives it then fails with it)."""
        try:
            return save()
        except Exception as exc:
            self._report(f"{self.GET_STATE} failed: {type(exc).__name__}: {exc}")
            return {"invalid": str(exc)}

    def _restore_state(self, state: dict, restore) -> None:
        """An FMI set-state: refuse an invalid state, make the model the one ``state`` was
        built from (:meth:`_model_for`), then ``restore(state)`` the slave's own parts and
        the pending problem; what fails is logged."""
        try:
            if "invalid" in state:
                raise ValueError(f"the state is invalid: {state['invalid']}")
            if not self._model_for(state["built_from"]):
                return
            restore(state)
            self._problem = state["problem"]
        except Exception as exc:
            self._report(f"{self.SET_STATE} failed: {type(exc).__name__}: {exc}")

    @classmethod
    def _decoded_state(cls, state) -> dict:
        """A serialised FMU state (JSON bytes) as a dict, or ``{"invalid": why}``."""
        import json
        try:
            out = json.loads(bytes(state).decode("utf-8"))
            if not isinstance(out, dict):
                raise ValueError("not a JSON object")
            return out
        except Exception as exc:
            return {"invalid": f"not a serialised {cls.__name__} state: {exc}"}

    @staticmethod
    def _encoded_state(state: dict) -> bytes:
        import json
        try:
            return json.dumps(state).encode("utf-8")
        except Exception as exc:
            return json.dumps({"invalid": f"not serialisable: {exc}"}).encode("utf-8")


#: Log category of the word an FMI 2.0 slave gives the FMU's loader just before it raises in
#: :func:`fail_step_fmi2`: the instance is still usable (``smeha_fmu_loader.c`` then returns
#: fmi2Error for pythonfmu's fmi2Fatal and passes the word on to no host).
RECOVERABLE_CATEGORY = "smehaRecoverable"


def fail_step_fmi2(slave, message: str):
    """An FMI 2.0 (pythonfmu 0.7) slave's failed step: raise, so that the host gets fmi2Fatal.

    pythonfmu 0.7 maps a ``do_step`` result to OK or Discard only, and fmpy takes a
    Discard of a terminated instance as a normal end, so Fatal -- what pythonfmu returns
    when ``do_step`` raises -- is the one status no host can miss. But pythonfmu 0.7
    answers the exception after releasing (Py_DECREF) its references to the slave class,
    the instance and its log queue, and releases the instance and the queue once more when
    the host resets or frees the instance (the class too when it frees it): one release
    per exception more than it owns. An owner-less reference per exception, taken through
    the C API, balances each one, so the three stay alive and later calls, fmi2Reset and
    fmi2FreeInstance are safe (what is left over leaks: a few kB per failure). A Python
    list holding them would not do: its own references would be the ones released, and
    freeing the list at interpreter exit would free them again.
    """
    import ctypes

    incref = ctypes.pythonapi.Py_IncRef  # the C API of the interpreter the FMU runs in
    incref.argtypes = (ctypes.py_object,)
    incref.restype = None
    for obj in (type(slave), slave, slave.log_queue):
        incref(obj)
    slave.log("the instance stays usable: terminate, reset or free it", slave.STATUS_ERROR,
              RECOVERABLE_CATEGORY)
    raise RuntimeError(message)
