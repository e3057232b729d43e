"""gmt: the giant magnetostrictive transducer of the smeha project.

Physics of the source paper ("Modeling and inverse compensation for giant
magnetostrictive transducer applied in smart material electrohydrostatic
actuator"), eqs 1-37 and Figure 9, one module per physical concern:

=====================  ==============================================
module                 equations
=====================  ==============================================
``field``              applied field from current, eq 1
``permeability``       complex permeability, B and M, eqs 3-5, 17-20
``losses``             loss separation and mu'', eqs 6-16
``sensing``            sensing coil, eqs 21-22
``calibration``        B_m at unmeasured points (Table 1)
``magnetostriction``   strain about the bias and force, eqs 25, 28
``mechanics``          mass-spring-damper, eqs 27, 29 (closed forms)
``forward``            composed model, eq 30 (stepper and steady state)
``inverse``            inverse model and compensator, eqs 31-37, Fig. 9
``transducer``         drive chain: amplifier, compensator, eq 30
``extensions``         candidate extensions, one module per effect
                       (periodic form, time-stepped form, SI
                       parameters) and the one registry
``variants``           the model variant: paper, or paper plus one or
                       more extensions, time-stepped
``timedomain``         the loss separation as a field separation in
                       the time domain (any drive), and its inverse
=====================  ==============================================

SI units throughout. This package imports no FMI, file or plotting code.

The names below are loaded on first use (PEP 562 module ``__getattr__``), so
``import gmt`` is cheap: a command that only needs ``gmt.ParameterError`` or
``gmt.parameters`` does not pay for numpy and the modules of the model.
"""
import importlib

__version__ = "0.1.0"

#: Public name -> the submodule that defines it.
_EXPORTS = {
    "DEFAULT_CALIBRATION": "calibration", "TABLE_1": "calibration",
    "FluxDensityCalibration": "calibration",
    "GmtError": "errors", "ParameterError": "errors", "InputError": "errors",
    "RunError": "errors", "ConvergenceError": "errors",
    "ForwardStepper": "forward", "OperatingPoint": "forward", "bias_displacement": "forward",
    "loop_metrics": "forward", "operating_point": "forward", "periodic_response": "forward",
    "simulate": "forward",
    "InverseCompensator": "inverse", "current_roots": "inverse",
    "DriveParameters": "parameters", "Excitation": "parameters",
    "TransducerParameters": "parameters",
    "TimeDomainParameters": "timedomain.parameters",
    "Transducer": "transducer", "TransducerOutput": "transducer", "RodMechanics": "transducer",
    "VARIANTS": "variants", "ModelVariant": "variants",
}
_SUBMODULES = ("calibration", "constants", "errors", "extensions", "field", "forward",
               "inverse", "losses", "magnetostriction", "mechanics", "parameters",
               "permeability", "sensing", "timedomain", "transducer", "variants")

__all__ = [*_EXPORTS, "__version__"]


def __getattr__(name):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_EXPORTS, *_SUBMODULES})
