"""One case of the flow study as a typed result (:class:`FlowRow`).

:func:`smeha.studies.flow.run_case` returns a :class:`FlowRow`: a frozen dataclass of
named, unit-suffixed figures with :meth:`FlowRow.as_dict` for JSON and tables (as
:class:`smeha.diagnose.Diagnosis` has). It also reads as a mapping (``row["dy_um"]``,
``row.get("note")``), the form the study's rows had, so that tables, sweeps and scripts
written against that keep working.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields

__all__ = ["FlowRow"]


@dataclass(frozen=True)
class FlowRow(Mapping):
    """The figures of one co-simulated case (SI; each name ends in its unit)."""

    frequency_Hz: float
    mode: str  #: "uncompensated" or "compensated"
    model: str  #: "paper" or the model variant's cause
    circuit: str
    load_N: float
    flow_sim_m3_s: float  #: mean cylinder flow over whole cycles (the flow check)
    flow_eq_m3_s: float  #: f A_d dy, eq 40/41 with this run's dy
    flow_ratio: float  #: flow_sim / flow_eq
    dy_um: float  #: the rod between the valve switching instants of this run
    flow_sim_L_min: float
    flow_paper_m3_s: float | None  #: f A_d dy from Table 3's measured dy (None off its rows)
    dy_paper_um: float | None
    dy_free_um: float  #: the transducer alone, no oil (smeha.studies.flow.free_dy)
    flow_free_m3_s: float
    delivered_fraction: float  #: flow_sim over f A_d dy_free
    control_amplitude_V: float | None  #: a of the compensated drive (None uncompensated)
    load_pressure_Pa: float  #: mean p_B - p_S over the run's second half
    p_pump_min_Pa: float
    p_pump_max_Pa: float
    p_min_Pa: float  #: lowest pressure of the chamber and the cavities
    p_min_volume: str
    volume_imbalance_m3: float
    volume_pumped_m3: float
    cycles_averaged: int
    flow_drift_per_cycle: float  #: the cycles' flows' trend (FlowCheck.drift)
    settled: bool
    step_s: float
    coupling: str
    backend: str
    wall_s: float
    flow_reversed: bool = False
    cavitation: bool = False
    note: str | None = None  #: why the row is flagged (flow_reversed, cavitation)
    #: a model variant's row: why its transducer may not be the one the circuit meets
    #: (smeha.studies.variantcheck.mark_rows), and those reasons in one sentence
    variant_marks: tuple = ()
    variant_note: str | None = None
    #: the transducer's magnetics and the drive's shape (smeha.studies.flow.Case)
    magnetics: str = "paper"
    waveform: str = "sine"

    def as_dict(self) -> dict:
        """The figures as a plain dict (JSON); ``note`` only when the row is flagged."""
        d = asdict(self)
        for optional in ("note", "variant_note"):
            if d[optional] is None:
                del d[optional]
        if self.model == "paper":
            del d["variant_marks"]
        else:
            d["variant_marks"] = list(self.variant_marks)
        return d

    # -- the mapping the rows were ------------------------------------------------------
    def __getitem__(self, key):
        if key in _NAMES and key in self.as_dict():
            return getattr(self, key)
        raise KeyError(key)

    def __iter__(self):
        return iter(self.as_dict())

    def __len__(self) -> int:
        return len(self.as_dict())


_NAMES = frozenset(f.name for f in fields(FlowRow))
