"""FMI 2.0 co-simulation slave of the EHA's hydraulic plant (pythonfmu 0.7).

A thin slave: it registers the variables of ``smeha_plant_interface`` (next to this file),
copies values in and out and delegates every step to ``smeha_plant_model.PlantModel``,
which steps ``system_models``' plant (bundled as ``smeha_plant_system_models``). No
physics here.

Life cycle
----------
* Parameters are fixed: they are read when the host leaves initialisation mode, which
  builds the plant. ``fmi2Reset`` re-runs the constructor (pythonfmu).
* ``fmi2DoStep(t, h)`` takes the inputs ``force`` and ``u`` (``PlantModel.step``) and
  returns the outputs at t + h.
* A bad input or a failed integration makes that step return fmi2Discard with the state
  untouched. A bad parameter or a missing package makes the instance unusable: its every
  ``fmi2DoStep`` returns fmi2Fatal (``smeha_fmu_base``).
* The FMU state holds every variable, the parameter values the plant was built from and
  ``PlantModel.get_state``, serialised as JSON.
"""
from __future__ import annotations

import os  # frozen in CPython 3.11: safe before prepare()

import smeha_fmu_runtime  # first, before any extension module: see its docstring

smeha_fmu_runtime.prepare(os.path.dirname(os.path.abspath(__file__)))  # this FMU's record

from pythonfmu import (Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability,  # noqa: E402
                       Integer, Real)
from pythonfmu.default_experiment import DefaultExperiment  # noqa: E402
from pythonfmu.enums import Fmi2Status  # noqa: E402

from smeha_fmu_base import SlaveBase, fail_step_fmi2  # noqa: E402

try:  # the table takes its start values from system_models (numpy, numba)
    import smeha_plant_interface as table  # noqa: E402  (next to this file)
except ImportError as exc:  # no instance can be made: say why, as loudly as an import can
    raise ImportError(smeha_fmu_runtime.missing_packages_message() or str(exc)) from exc


def _load():
    """(PlantModel class, None), or (None, why it cannot be imported)."""
    problem = smeha_fmu_runtime.missing_packages_message()
    if problem:
        return None, problem
    try:
        import importlib

        from smeha_plant_model import PlantModel
        # the compiled kernel: numba, loading the build's compilation from the FMU's cache
        importlib.import_module(f"{table.physics().__name__}.kernel")
        return PlantModel, None
    except Exception as exc:
        return None, (f"cannot import the plant ({type(exc).__name__}: {exc}); the FMU needs "
                      f"{', '.join(table.REQUIRED_PACKAGES)} importable by the Python of the "
                      "host process")


_MODEL, _IMPORT_PROBLEM = _load()

_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean}
_CAUSALITY = {"input": Fmi2Causality.input, "parameter": Fmi2Causality.parameter,
              "output": Fmi2Causality.output}
_VARIABILITY = {"fixed": Fmi2Variability.fixed, "continuous": Fmi2Variability.continuous,
                "discrete": Fmi2Variability.discrete}


class SmehaPlant(SlaveBase, Fmi2Slave):
    """Pump chamber with the rod, four active valves and their controller, cylinder,
    accumulator (``system_models``), driven by the magnetostrictive force."""

    author = table.AUTHOR
    license = table.LICENSE
    description = table.DESCRIPTION
    default_experiment = DefaultExperiment(**table.DEFAULT_EXPERIMENT)
    MODEL_NAME = table.MODEL_NAME
    STATUS_ERROR, STATUS_WARNING, STATUS_DISCARD = (Fmi2Status.error, Fmi2Status.warning,
                                                    Fmi2Status.discard)
    IMPORT_PROBLEM = _IMPORT_PROBLEM
    TABLE = table

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        smeha_fmu_runtime.arm_clean_exit(table.MODEL_NAME)  # exits cleanly: see there
        self._model = None  # PlantModel, built on leaving initialisation
        self._built_from = None  # the parameter values it was built from
        self._init_base()
        self._register(_TYPES, _CAUSALITY, _VARIABILITY)

    def _built(self) -> bool:
        return self._model is not None

    def _discard_model(self) -> None:
        self._model, self._built_from = None, None

    def _parameters(self) -> dict:
        return {name: table.coerce(name, getattr(self, name)) for name in table.PARAMETERS}

    def _build(self, values: dict) -> bool:
        """Build the plant from parameter values; log and return False on error."""
        try:
            self._model = _MODEL(values)
        except Exception as exc:
            self._model, self._built_from = None, None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)
            return False
        self._built_from, self._problem = dict(values), None
        return True

    def _copy_outputs(self):
        for name, value in self._model.outputs().items():
            setattr(self, name, value)

    def exit_initialization_mode(self):
        if self.IMPORT_PROBLEM:
            return
        try:
            if self._build(self._parameters()):
                self._copy_outputs()
        except Exception as exc:
            self._model = None
            self._problem = f"initialisation failed: {type(exc).__name__}: {exc}"
            self._report(self._problem)

    def do_step(self, current_time, step_size):
        if self._model is None:
            return self._refuse_step(current_time)
        try:
            self._model.step(current_time, step_size, self.force, self.u)
        except Exception as exc:
            self._report(f"doStep at t = {current_time!r} s, step {step_size!r} s discarded: "
                         f"{type(exc).__name__}: {exc}", self.STATUS_DISCARD)
            return False
        self._copy_outputs()
        return True

    def _fail_step(self, message: str):
        return fail_step_fmi2(self, message)  # fmi2Fatal: see there

    def _get_fmu_state(self):
        return self._saved_state(self._state)

    def _state(self) -> dict:
        return {"variables": {name: getattr(self, name) for name in table.VARIABLE_NAMES},
                "built_from": self._built_from, "problem": self._problem,
                "model": None if self._model is None else self._model.get_state()}

    def _set_fmu_state(self, state):
        self._restore_state(state, self._restore)

    def _restore(self, state: dict) -> None:
        if self._model is not None:
            self._model.set_state(state["model"])
        for name, value in state["variables"].items():
            setattr(self, name, table.coerce(name, value))

    @staticmethod
    def _fmu_state_to_bytes(state):
        return SlaveBase._encoded_state(state)

    @classmethod
    def _fmu_state_from_bytes(cls, state):
        return cls._decoded_state(state)
