"""labsim: an independent generator of lab-style measurements of the paper's transducer.

It implements the paper's model (eqs 1-30, Tables 1-2) as a continuous-time system, six
physical effects the model leaves out (each in two or more formulations from different
literature; two more effects outside the six, for pairs with an unknown effect),
and the way a lab records the signals (sample clock, anti-alias filter, noise, ADC). It shares no code or numerics with the project's packages;
see README.md in this folder for every formulation and its source.

>>> import labsim
>>> ds = labsim.make_dataset({"transport_delay": 1.0}, seed=0, frequencies=[50.0],
...                          amplitudes=[1.0], samples_per_cycle=100, cycles=2)
>>> [r.label for r in ds.runs], ds.runs[0].time.size
(['50Hz_1A'], 200)
"""
from .constants import LabsimError, Transducer
from .dataset import DEFAULT_AMPLITUDES, DEFAULT_FREQUENCIES, Dataset, Run, make_dataset
from .effects import EFFECTS, FORMULATIONS
from .outside import OUTSIDE_EFFECTS

__all__ = [
    "EFFECTS",
    "FORMULATIONS",
    "DEFAULT_AMPLITUDES",
    "DEFAULT_FREQUENCIES",
    "Dataset",
    "LabsimError",
    "OUTSIDE_EFFECTS",
    "Run",
    "Transducer",
    "make_dataset",
]
