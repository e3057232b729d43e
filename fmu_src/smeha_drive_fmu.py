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
                        "continuous": Fmi2Variability.continuous},
                       getters={"u": self._output_u})

    def _built(self) -> bool:
        return self._signal is not None

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._start_time = float(start_time)

    @staticmethod
    def _at(signal, time: float) -> float:
        """u at ``time`` [s] of ``signal`` = (offset [V], amplitude [V], omega [rad/s])."""
        offset, amplitude, omega = signal
        return offset + amplitude * math.cos(omega * time)

    def _signal_from_parameters(self):
        """(offset, amplitude, omega) from the parameters as they are now, and the problem
        that makes them no signal (None when they make one)."""
        values = [float(getattr(self, name)) for name in table.PARAMETERS]
        offset, amplitude, frequency = values
        return (offset, amplitude, 2.0 * math.pi * frequency), table.signal_problem(*values)

    def _output_u(self) -> float:
        """u as a host reads it. Built, the value at the end of the last step (at the start
        time before the first). In Initialization Mode, u at the start time from the
        parameters set so far: u is an initial unknown there (an output of initial
        "calculated", FMI 2.0.4 sections 2.2.8 and 4.2.4), and a master that connects its
        units in that mode (fmpy's container FMU) hands on what it reads, so the transducer's
        first step sees u(t0), not 0."""
        if self._signal is None:
            try:
                signal, problem = self._signal_from_parameters()
                if problem is None:
                    return self._at(signal, self._start_time)
            except Exception:  # never raise into pythonfmu; the step reports bad parameters
                pass
        return self.u

    def exit_initialization_mode(self):
        signal, problem = self._signal_from_parameters()
        if problem:
            self._problem = f"initialisation failed: {problem}"
            self._report(self._problem)
            return
        self._signal = signal
        self._problem = None
        self.u = self._at(signal, self._start_time)

    def do_step(self, current_time, step_size):
        if self._signal is None:
            return self._refuse_step(current_time)
        self.u = self._at(self._signal, current_time + step_size)
        return True

    def _fail_step(self, message: str):
        return fail_step_fmi2(self, message)  # fmi2Fatal: see there
