"""labsim datasets as the runs smeha reads (the diagnosis tests and the detection study).

labsim (tests/labsim/, its README) is the independent lab-data generator; only its public
API is used here. A dataset's runs become :class:`smeha.measured.Run` objects in memory,
as :func:`smeha.measured.read_measurements` would give them from ``Dataset.write_csv``
(SI, the run's label as its name); the truth stays in ``Dataset.truth``.
"""
from __future__ import annotations

import labsim

from smeha.measured import Run

#: labsim's textbook forms of the paper's two effects (its README): the Preisach density of
#: random relays and eddy diffusion, as the textbook-form studies and benchmarks use them.
TEXTBOOK_FORMULATIONS = {"rate_independent_hysteresis": "preisach_random",
                         "eddy_current_diffusion": "diffusion_random"}


def smeha_runs(ds) -> list[Run]:
    """The runs of a labsim dataset as smeha runs (no truth attached)."""
    return [Run(name=r.label, frequency=float(r.frequency), time=r.time, current=r.current,
                displacement=r.displacement, sense_voltage=r.sense_voltage,
                source=f"labsim(seed={ds.truth['seed']})")
            for r in ds.runs]


def runs(effects=None, seed=0, **kwargs) -> list[Run]:
    """``labsim.make_dataset(effects, seed, **kwargs)`` as smeha runs."""
    return smeha_runs(labsim.make_dataset(effects, seed=seed, **kwargs))
