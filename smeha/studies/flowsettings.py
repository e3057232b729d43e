"""The flow study's numeric settings, each declared once (:class:`smeha.settings.Setting`).

:class:`smeha.studies.flow.Case` enforces them, ``smeha simulate``, ``flow`` and
``sweep`` parse and describe them from the same objects. Plain declarations: importing
this module loads no solver, so ``--help`` reads it.

The run-time estimate (:func:`estimated_wall`) lives here too: a run whose estimate
exceeds :data:`LONG_RUN` is announced before it starts.
"""
from __future__ import annotations

from gmt.parameters import COMPENSATOR_PERIOD
from system_models.defaults import (DEFAULT_CYCLES, DEFAULT_STEP, HYDRAULIC_STEP,
                                    MAXIMUM_DURATION, MINIMUM_CYCLES, SKIP_CYCLES,
                                    VALVE_CONTROLLER_PERIOD)

from ..settings import Setting

__all__ = ["FREQUENCY", "LOAD", "CYCLES", "STEP", "DURATION", "AMPLITUDE",
           "COMPENSATOR_PERIOD_S", "CONTROLLER_PERIOD", "HYDRAULIC_STEP_S", "NOISE_UM",
           "SECONDS_PER_STEP", "LONG_RUN", "estimated_wall"]

#: The pumping frequency. Above: gmt.Excitation's limit. Below: 1 Hz, where a pump cycle
#: lasts a second and the default eight cycles take 80,000 steps; the paper pumps at
#: 50-200 Hz, so a smaller value is most likely a period in seconds or kHz typed for Hz.
FREQUENCY = Setting("frequency", "Hz", 1.0, 1000.0, low_open=False,
                    below="the paper pumps at 50-200 Hz; below 1 Hz, was it a period in "
                        "seconds (0.01 s is 100 Hz) or kHz (0.1 kHz is 100 Hz)?")
#: The load on the cylinder: 10 MN either way bounds any load the pump could meet (its
#: stall loads are near 1 kN).
LOAD = Setting("load", "N", -1e7, 1e7, high_open=True)
#: Simulated pumping cycles: the flow check discards the first SKIP_CYCLES compression
#: strokes and averages the whole cycles between at least two more.
CYCLES = Setting("cycles", "cycles", float(MINIMUM_CYCLES), None, low_open=False,
                 default=DEFAULT_CYCLES,
                 below=f"the flow check discards the first {SKIP_CYCLES} compression strokes "
                     "and averages the whole cycles between the strokes that follow")
#: The communication step, [s] (system_models.cosim.CosimSettings).
STEP = Setting("step", "s", 0.0, 1.0, high_open=True, default=DEFAULT_STEP)
#: Simulated time of one run, [s] (system_models.cosim.CosimSettings).
DURATION = Setting("duration", "s", 0.0, MAXIMUM_DURATION)
#: The control signal's amplitude: the coil current's I_m [A] uncompensated, the demand's
#: a [V] compensated (smeha.studies.flow.control_signal).
AMPLITUDE = Setting("amplitude", "A or V", 0.0, 1000.0)
#: The digital compensator's sample period, [s]; 0: a sample every step.
COMPENSATOR_PERIOD_S = Setting("compensator_period", "s", 0.0, 1.0, low_open=False,
                               default=COMPENSATOR_PERIOD)
#: The valve controller's sample period, [s].
CONTROLLER_PERIOD = Setting("controller_period", "s", 0.0, 1.0, high_open=True,
                            default=VALVE_CONTROLLER_PERIOD)
#: The longest hydraulic substep, [s].
HYDRAULIC_STEP_S = Setting("hydraulic_step", "s", 0.0, 1.0, high_open=True,
                           default=HYDRAULIC_STEP)
#: The simulated displacement sensor's noise, standard deviation, [um].
NOISE_UM = Setting("noise_um", "um", 0.0, 1000.0, low_open=False)

#: Wall time of one communication step of the co-simulation through the FMU, [s]: the
#: estimate's rate. 80,000,000 steps took about 40 minutes (30 us a step) on the
#: project's 2-core machine with other jobs running; the direct backend is faster, so the
#: estimate errs long.
SECONDS_PER_STEP = 30e-6
#: Wall time above which a run is announced before it starts, [s].
LONG_RUN = 60.0


def estimated_wall(duration: float, step: float) -> float:
    """The wall time a run of ``duration`` [s] at ``step`` [s] is expected to take, [s]."""
    return duration / step * SECONDS_PER_STEP
