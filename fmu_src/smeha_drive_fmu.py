"""FMI 2.0 co-simulation slave of the EHA's control signal (pythonfmu 0.7).

u(t) = offset + amplitude cos(2 pi f t) (``smeha_drive_interface``, next to this file);
stepped over [t, t + h] it outputs u(t + h). Standard library only. Bad parameters make
the instance unusable: its every step returns fmi2Fatal (``smeha_fmu_base``).
"""
from __future__ import annotations

import os  # frozen in CPython 3.11: safe before prepare()

import smeha_fmu_runtime  # first, before any extension module: see its docstring

smeha_fmu_runtime.prepare(os.path.dirname(os.path.abspath(__file__)))  # this FMU's record

import math  # noqa: E402

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real  # noqa: E402
from pythonfmu.default_experiment import DefaultExperiment  # noqa: E402
from pythonfmu.enums import Fmi2Status  # noqa: E402

import smeha_drive_interface as table  # noqa: E402  (next to this file)
from smeha_fmu_base import SlaveBase, fail_step_fmi2  # noqa: E402


class SmehaDrive(SlaveBase, Fmi2Slave):
    """The control signal u = offset + amplitude cos(2 pi f t), [V]."""

    author = table.AUTHOR
    license = table.LICENSE
    description = table.DESCRIPTION
    default_experiment = DefaultExperiment(**table.DEFAULT_EXPERIMENT)
    MODEL_NAME = table.MODEL_NAME
    STATUS_ERROR, STATUS_WARNING, STATUS_DISCARD = (Fmi2Status.error, Fmi2Status.warning,
                                                    Fmi2Status.discard)
    TABLE = table

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        smeha_fmu_runtime.arm_clean_exit(table.MODEL_NAME)  # exits cleanly: see there
        self._signal = None  # (offset, amplitude, angular frequency), fixed at initialisation
        self._start_time = 0.0
        self._init_base()
        self._register({"Real": Real},
                       {"parameter": Fmi2Causality.parameter, "output": Fmi2Causality.output},
                       {"fixed": Fmi2Variability.fixed,
                        "continuous": Fmi2Variability.continuous})

    def _built(self) -> bool:
        return self._signal is not None

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = float(start_time)

    def _at(self, time: float) -> float:
        offset, amplitude, omega = self._signal
        return offset + amplitude * math.cos(omega * time)

    def exit_initialization_mode(self):
        values = [float(getattr(self, name)) for name in table.PARAMETERS]
        problem = table.signal_problem(*values)
        if problem:
            self._problem = f"initialisation failed: {problem}"
            self._report(self._problem)
            return
        offset, amplitude, frequency = values
        self._signal = (offset, amplitude, 2.0 * math.pi * frequency)
        self._problem = None
        self.u = self._at(self._start_time)

    def do_step(self, current_time, step_size):
        if self._signal is None:
            return self._refuse_step(current_time)
        self.u = self._at(current_time + step_size)
        return True

    def _fail_step(self, message: str):
        return fail_step_fmi2(self, message)  # fmi2Fatal: see there
