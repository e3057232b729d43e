"""gmt: the giant magnetostrictive transducer of the smeha project.

Physics of the source paper ("Modeling and inverse compensation for giant
magnetostrictive transducer applied in smart material electrohydrostatic
actuator"), eqs 1-37 and Figure 9, one module per physical concern:

=====================  ==============================================
module                 equations
=====================  ==============================================
``field``              applied field from current, eqs 1-2
``permeability``       complex permeability, B and M, eqs 3-5, 17-20
``losses``             loss separation and mu'', eqs 6-16
``sensing``            sensing coil, eqs 21-22
``calibration``        B_m at unmeasured points (Table 1)
``magnetostriction``   strain about the bias and force, eqs 23-26, 28
``mechanics``          mass-spring-damper, eqs 27, 29 (python-control)
``forward``            composed model, eq 30 (stepper and steady state)
``inverse``            inverse model and compensator, eqs 31-37, Fig. 9
``transducer``         drive chain: amplifier, compensator, eq 30
``extensions``         candidate extensions of the model (issue #5)
``variants``           the model variant: paper, or paper plus one
                       extension, time-stepped
=====================  ==============================================

SI units throughout. This package imports no FMI, file or plotting code.
"""
from .calibration import DEFAULT_CALIBRATION, TABLE_1, FluxDensityCalibration
from .errors import GmtError, ParameterError
from .forward import (ForwardStepper, OperatingPoint, bias_displacement, loop_metrics,
                      operating_point, periodic_response, simulate)
from .inverse import InverseCompensator, current_roots
from .parameters import DriveParameters, Excitation, TransducerParameters
from .transducer import Transducer, TransducerOutput
from .variants import VARIANTS, ModelVariant

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_CALIBRATION", "TABLE_1", "FluxDensityCalibration", "GmtError",
    "ParameterError", "ForwardStepper", "OperatingPoint", "bias_displacement",
    "loop_metrics", "operating_point", "periodic_response", "simulate",
    "InverseCompensator", "current_roots", "DriveParameters", "Excitation",
    "TransducerParameters", "Transducer", "TransducerOutput", "ModelVariant", "VARIANTS",
    "__version__",
]
