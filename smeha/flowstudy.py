"""The flow study: the EHA's cylinder flow by co-simulation against eqs 40/41.

Each case runs the transducer FMU (or, for comparison, gmt in-process) with
the hydraulic circuit (:mod:`system_models`) and checks the mean cylinder flow
against f A_d dy (:mod:`system_models.flowcheck`).

Control signals: uncompensated, u = (I_m / K_a) cos(2 pi f t), so the coil
current is i = I_m cos(2 pi f t) and the valves switch at i = -+I_m (eq 40);
compensated, u = a + a cos(2 pi f t), the valves switch at u = 0 and u = 2a
(eq 41), with a the paper's control amplitudes (2.2, 1.9, 1.7, 1.5 V at 50,
70, 80, 100 Hz; interpolated linearly between) or, outside 50-100 Hz, 95 % of
the half-stroke the transducer reaches at that frequency.

Model variants: a case with ``variant`` (a :class:`gmt.ModelVariant`, e.g. the
extension ``smeha diagnose`` names) runs the transducer with that extension
added -- through the FMU's ``model_variant`` and ``variant_parameters``, or
``gmt.Transducer(variant=...)`` in-process -- so the flow with the paper's
model and with the extended model can be compared (:func:`format_comparison`,
``smeha flow --variant FILE``). The compensator stays the paper's inverse
model in both.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

import gmt
from system_models import presets
from system_models.cosim import (CosimSettings, DirectTransducer, FmuTransducer, cosimulate,
                                 volume_balance)
from system_models.flowcheck import flow_check

MODES = ("uncompensated", "compensated")

#: Paper, inverse-compensation section: control amplitude a [V] of
#: u = a + a cos(2 pi f t) at each frequency [Hz].
PAPER_CONTROL_AMPLITUDE = {50.0: 2.2, 70.0: 1.9, 80.0: 1.7, 100.0: 1.5}

#: Paper, Table 3: dy [um] between the valve switching instants,
#: uncompensated y(i=1) - y(i=-1) and compensated y(u=u_m) - y(u=0).
PAPER_DY_UM = {50.0: (42.0 - 1.8, 46.0), 70.0: (38.0 - 3.0, 42.0),
               80.0: (36.0 - 4.0, 40.0), 100.0: (31.2 - 4.6, 35.2)}

#: Current amplitude I_m of the study, [A] (the paper's 1 A).
CURRENT_AMPLITUDE = 1.0


def control_amplitude(frequency: float, params: gmt.TransducerParameters | None = None,
                      drive: gmt.DriveParameters | None = None) -> float:
    """a [V] of the compensated control signal u = a + a cos(2 pi f t) (module docstring)."""
    f = float(frequency)
    table = sorted(PAPER_CONTROL_AMPLITUDE.items())
    if table[0][0] <= f <= table[-1][0]:
        fs, amps = zip(*table)
        return float(np.interp(f, fs, amps))
    params = params or gmt.TransducerParameters()
    drive = drive or gmt.DriveParameters()
    point = gmt.operating_point(params, gmt.Excitation(f, CURRENT_AMPLITUDE))
    low, high = gmt.inverse.stroke(params, point)
    return 0.95 * (high - low) / (2.0 * drive.displacement_per_volt)


def control_signal(mode: str, frequency: float, amplitude: float | None = None):
    """u(t) [V] for a mode; returns (callable, a or None)."""
    w = 2.0 * math.pi * frequency
    if mode == "uncompensated":
        return (lambda t: CURRENT_AMPLITUDE * math.cos(w * t)), None
    if mode == "compensated":
        a = control_amplitude(frequency) if amplitude is None else amplitude
        return (lambda t: a + a * math.cos(w * t)), a
    raise gmt.ParameterError(f"mode = {mode!r} is not one of {MODES}")


@dataclass(frozen=True)
class Case:
    """One co-simulation of the study."""

    frequency: float
    mode: str
    ideal: bool = False
    load: float | None = None  # [N]; None: 0 ideal, REALISTIC_LOAD otherwise
    step: float = 20e-6  # communication step [s]
    cycles: float = 8.0  # simulated time in pumping cycles
    backend: str = "fmu"  # "fmu" or "direct"
    branch_rule: str = "control"
    variant: gmt.ModelVariant | None = None  # None: the paper's model
    #: valve controller's own sample period [s]; None: it samples at the communication points
    #: (system_models.cosim.CosimSettings.controller_period)
    controller_period: float | None = None
    #: longest hydraulic substep [s]; None: one substep a communication step
    hydraulic_step: float | None = None

    def __post_init__(self):
        from system_models.flowcheck import MINIMUM_CYCLES
        if self.variant is not None:
            if not isinstance(self.variant, gmt.ModelVariant):
                raise gmt.ParameterError(
                    f"variant = {self.variant!r} must be a gmt.ModelVariant or None")
            if self.variant.is_paper:  # one spelling of the paper's model
                object.__setattr__(self, "variant", None)
        if not self.cycles >= MINIMUM_CYCLES:
            raise gmt.ParameterError(
                f"cycles = {self.cycles:g} is outside the allowed range [{MINIMUM_CYCLES}, inf): "
                f"the flow check discards the first cycles and averages at least two more")
        if self.mode not in MODES:
            raise gmt.ParameterError(f"mode = {self.mode!r} is not one of {MODES}")

    @property
    def load_force(self) -> float:
        if self.load is not None:
            return float(self.load)
        return 0.0 if self.ideal else presets.REALISTIC_LOAD

    @property
    def model(self) -> str:
        """"paper", or the variant's name (its cause, gmt.VARIANTS)."""
        return "paper" if self.variant is None else self.variant.name


def variant_start_values(variant: gmt.ModelVariant | None) -> dict:
    """The FMU's ``model_variant`` and ``variant_parameters`` for a variant ({} for the paper)."""
    if variant is None or variant.is_paper:
        return {}
    return {"model_variant": variant.name,
            "variant_parameters": json.dumps(variant.as_dict()["parameters"])}


class VariantDirectTransducer(DirectTransducer):
    """:class:`system_models.cosim.DirectTransducer` with a model variant."""

    def __init__(self, params=None, excitation=None, drive=None, variant=None):
        self.model = gmt.Transducer(params, excitation, drive, variant=variant)


def default_fmu_path() -> Path:
    """dist/SmehaGmt.fmu of the source tree (:data:`smeha.fmu_build.DIST`)."""
    from . import fmu_build
    return fmu_build.DIST / "SmehaGmt.fmu"


def ensure_fmu(path: Path | None = None, quiet: bool = False) -> Path:
    """Build the FMI 2.0 FMU unless it exists and is newer than its sources."""
    from . import fmu_build
    path = Path(path) if path else default_fmu_path()
    sources = list((fmu_build.FMU_SRC).rglob("*.py")) + [Path(fmu_build.__file__)]
    newest = max(p.stat().st_mtime for p in sources)
    if path.is_file() and path.stat().st_mtime >= newest:
        return path
    if not quiet:
        print(f"building the transducer FMU into {path.parent} ...", flush=True)
    return fmu_build.build("2", out=path.parent)


#: Free run of a model variant: samples a cycle and cycles (the dy is the last cycle's).
FREE_SAMPLES_PER_CYCLE, FREE_CYCLES = 1000, 6


@lru_cache(maxsize=64)
def free_dy(frequency: float, mode: str, branch_rule: str = "control",
            variant: gmt.ModelVariant | None = None) -> float:
    """dy of the transducer alone (no oil, no force) between the same instants, [m].

    Cached: a load line or a sweep asks for it once per case at the same
    frequency and mode.

    Uncompensated: y(i = I_m) - y(i = -I_m) in steady state (eq 40);
    compensated: y(u = 2a) - y(u = 0) of the compensated drive (eq 41).
    With a model variant the transducer is time-stepped alone
    (:data:`FREE_SAMPLES_PER_CYCLE` samples a cycle) and dy is read off the
    last of :data:`FREE_CYCLES` cycles (a drifting variant has no steady
    state: this is its dy after that many cycles).
    """
    params = gmt.TransducerParameters()
    if variant is not None and not variant.is_paper:
        return _stepped_free_dy(params, frequency, mode, branch_rule, variant)
    if mode == "uncompensated":
        point = gmt.operating_point(params, gmt.Excitation(frequency, CURRENT_AMPLITUDE))
        return gmt.loop_metrics(params, point)["dy"]
    from .paper import compensated_run
    run = compensated_run(params, frequency, control_amplitude(frequency), branch_rule)
    half = run.displacement.size // 2  # u = 2a at the cycle's start, u = 0 half way
    return float(run.displacement[0] - run.displacement[half])


def _stepped_free_dy(params, frequency, mode, branch_rule, variant):
    drive = gmt.DriveParameters(compensated=mode == "compensated", branch_rule=branch_rule)
    unit = gmt.Transducer(params, gmt.Excitation(frequency, CURRENT_AMPLITUDE), drive,
                          variant=variant)
    control, _ = control_signal(mode, frequency)
    n_cycle = FREE_SAMPLES_PER_CYCLE
    h = 1.0 / (frequency * n_cycle)
    n = n_cycle * FREE_CYCLES
    y = np.empty(n + 1)
    y[0] = unit.forward.displacement
    for k in range(n):
        y[k + 1] = unit.step(control(k * h), h).displacement
    start = n - n_cycle  # u at its maximum: i = +I_m, or u = 2a; half a cycle on: minimum
    return float(y[start] - y[start + n_cycle // 2])


def run_case(case: Case, fmu_path: Path | None = None, progress=None):
    """Run one case; return (record, FlowCheck, row dict)."""
    params = gmt.TransducerParameters()
    drive = gmt.DriveParameters(compensated=case.mode == "compensated",
                                branch_rule=case.branch_rule)
    control, a = control_signal(case.mode, case.frequency)
    circuit = presets.ideal_circuit() if case.ideal else presets.realistic_circuit()
    settings = CosimSettings(duration=case.cycles / case.frequency, step=case.step,
                             load_force=case.load_force, controller_period=case.controller_period,
                             hydraulic_step=case.hydraulic_step)
    start = {"frequency": case.frequency, "current_amplitude": CURRENT_AMPLITUDE,
             "compensated": drive.compensated, "branch_rule": drive.branch_rule,
             **variant_start_values(case.variant)}
    if case.backend == "fmu":
        backend = FmuTransducer(fmu_path or default_fmu_path(), start)
    elif case.backend == "direct":
        excitation = gmt.Excitation(case.frequency, CURRENT_AMPLITUDE)
        backend = (DirectTransducer(params, excitation, drive) if case.variant is None
                   else VariantDirectTransducer(params, excitation, drive, case.variant))
    else:
        raise gmt.ParameterError(f"backend = {case.backend!r} is not one of ('fmu', 'direct')")
    wall = time.perf_counter()
    try:
        record = cosimulate(backend, control, circuit, settings, progress=progress)
    finally:
        backend.close()
    wall = time.perf_counter() - wall
    check = flow_check(record, case.frequency, circuit.chamber.piston_area)
    imbalance, pumped = volume_balance(record, circuit)
    half = len(record) // 2
    paper = PAPER_DY_UM.get(float(case.frequency))
    paper_dy = None if paper is None else paper[MODES.index(case.mode)]
    dy_free = free_dy(case.frequency, case.mode, case.branch_rule, case.variant)
    row = {
        "frequency_Hz": case.frequency, "mode": case.mode, "model": case.model,
        "circuit": "ideal" if case.ideal else "realistic", "load_N": case.load_force,
        "flow_sim_m3_s": check.flow_sim, "flow_eq_m3_s": check.flow_eq,
        "flow_ratio": check.ratio, "dy_um": check.dy * 1e6,
        "flow_sim_L_min": check.flow_sim * 6e4,
        "flow_paper_m3_s": (None if paper_dy is None
                            else case.frequency * circuit.chamber.piston_area * paper_dy * 1e-6),
        "dy_paper_um": paper_dy,
        "dy_free_um": dy_free * 1e6,
        "flow_free_m3_s": case.frequency * circuit.chamber.piston_area * dy_free,
        "delivered_fraction": check.flow_sim / (case.frequency * circuit.chamber.piston_area
                                                * dy_free),
        "control_amplitude_V": a,
        "load_pressure_Pa": float(np.mean(record["p_big"][half:] - record["p_small"][half:])),
        "p_pump_min_Pa": float(record["p_pump"][half:].min()),
        "p_pump_max_Pa": float(record["p_pump"][half:].max()),
        "volume_imbalance_m3": imbalance, "volume_pumped_m3": pumped,
        "cycles_averaged": check.cycles, "step_s": case.step, "backend": case.backend,
        "wall_s": wall,
    }
    return record, check, row


def _run_one(args):
    case, fmu_path = args
    _, _, row = run_case(case, fmu_path)
    return row


def run_cases(cases, fmu_path=None, workers: int = 1, quiet: bool = False) -> list[dict]:
    """Run many cases (in worker processes when ``workers`` > 1), with a progress bar.

    Rows come back in the order of ``cases``. Each worker process loads its
    own FMU instances.
    """
    from tqdm import tqdm
    jobs = [(c, fmu_path) for c in cases]
    with tqdm(total=len(jobs), desc="co-simulations", unit="run", disable=quiet,
              file=__import__("sys").stderr) as bar:
        if workers <= 1 or len(jobs) == 1:
            rows = []
            for job in jobs:
                rows.append(_run_one(job))
                bar.update(1)
            return rows
        import concurrent.futures as cf
        import multiprocessing
        ctx = multiprocessing.get_context("spawn")
        with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            futures = [pool.submit(_run_one, job) for job in jobs]
            for _ in cf.as_completed(futures):
                bar.update(1)
            return [f.result() for f in futures]


def format_table(rows) -> str:
    """The flow table for the terminal."""
    head = (f"{'f [Hz]':>6}  {'mode':<13}  {'circuit':<9}  {'load [N]':>8}  {'q sim [m3/s]':>12}  "
            f"{'q eq40/41':>10}  {'sim/eq':>6}  {'dy [um]':>7}  {'q paper':>10}  "
            f"{'dy paper':>8}  {'dy free':>7}  {'q/q free':>8}  {'q [L/min]':>9}")
    lines = ["Cylinder flow: co-simulation against eqs 40/41 and the paper's Table 3",
             "(dy: the rod between the valve switching instants of this run; q paper: f A_d dy "
             "that the paper computes with eqs 40/41 from Table 3's measured dy (dy paper), not "
             "a measured flow; dy free: the transducer alone, no oil; q/q free: delivered flow "
             "over f A_d dy free, the flow eqs 40/41 give for the free transducer, as the paper "
             "computes them)", head]
    for r in rows:
        paper = "-" if r["flow_paper_m3_s"] is None else f"{r['flow_paper_m3_s']:.3e}"
        dyp = "-" if r["dy_paper_um"] is None else f"{r['dy_paper_um']:.1f}"
        lines.append(f"{r['frequency_Hz']:>6g}  {r['mode']:<13}  {r['circuit']:<9}  "
                     f"{r['load_N']:>8g}  {r['flow_sim_m3_s']:>12.4e}  {r['flow_eq_m3_s']:>10.4e}  "
                     f"{r['flow_ratio']:>6.3f}  {r['dy_um']:>7.2f}  {paper:>10}  {dyp:>8}  "
                     f"{r['dy_free_um']:>7.2f}  {r['delivered_fraction']:>8.3f}  "
                     f"{r['flow_sim_L_min']:>9.4f}")
    by = {(r["frequency_Hz"], r["mode"]): r for r in rows}
    gains = [f"{f:g} Hz: {by[(f, 'compensated')]['flow_sim_m3_s'] / by[(f, 'uncompensated')]['flow_sim_m3_s']:.3f}"
             for f in sorted({r["frequency_Hz"] for r in rows})
             if (f, "compensated") in by and (f, "uncompensated") in by
             and by[(f, "uncompensated")]["flow_sim_m3_s"] != 0]
    if gains:
        lines.append("compensated / uncompensated flow: " + ", ".join(gains))
    return "\n".join(lines)


def format_load_lines(rows) -> str:
    """Flow against load pressure (p_B - p_S) for each frequency and mode."""
    lines = ["Load lines: mean cylinder flow against load pressure p_B - p_S",
             f"{'f [Hz]':>6}  {'mode':<13}  {'load [N]':>8}  {'p_B - p_S [MPa]':>15}  "
             f"{'q sim [m3/s]':>12}  {'q [L/min]':>9}"]
    for r in sorted(rows, key=lambda r: (r["frequency_Hz"], r["mode"], r["load_N"])):
        lines.append(f"{r['frequency_Hz']:>6g}  {r['mode']:<13}  {r['load_N']:>8g}  "
                     f"{r['load_pressure_Pa'] / 1e6:>15.3f}  {r['flow_sim_m3_s']:>12.4e}  "
                     f"{r['flow_sim_L_min']:>9.4f}")
    return "\n".join(lines)


def compare_variant(rows) -> list[dict]:
    """Pair each variant row with the paper row of the same case (frequency, mode, circuit, load).

    Returns
    -------
    list of dict
        ``frequency_Hz``, ``mode``, ``circuit``, ``load_N``, ``model`` (the
        variant's cause), ``flow_paper_model_m3_s``, ``flow_variant_m3_s``,
        ``flow_ratio_variant_to_paper``, ``dy_paper_model_um``, ``dy_variant_um``,
        ``dy_free_paper_model_um``, ``dy_free_variant_um``, in the order of the
        variant rows.
    """
    def key(r):
        return (r["frequency_Hz"], r["mode"], r["circuit"], r["load_N"])

    paper = {key(r): r for r in rows if r.get("model", "paper") == "paper"}
    out = []
    for r in rows:
        if r.get("model", "paper") == "paper" or key(r) not in paper:
            continue
        p = paper[key(r)]
        out.append({"frequency_Hz": r["frequency_Hz"], "mode": r["mode"],
                    "circuit": r["circuit"], "load_N": r["load_N"], "model": r["model"],
                    "flow_paper_model_m3_s": p["flow_sim_m3_s"],
                    "flow_variant_m3_s": r["flow_sim_m3_s"],
                    "flow_ratio_variant_to_paper": (r["flow_sim_m3_s"] / p["flow_sim_m3_s"]
                                                    if p["flow_sim_m3_s"] else None),
                    "dy_paper_model_um": p["dy_um"], "dy_variant_um": r["dy_um"],
                    "dy_free_paper_model_um": p["dy_free_um"],
                    "dy_free_variant_um": r["dy_free_um"]})
    return out


def format_comparison(pairs, variant: gmt.ModelVariant, source: str = "") -> str:
    """The flow with the paper's model and with the variant, side by side."""
    where = f" (from {source})" if source else ""
    lines = [f"Cylinder flow: the paper's model against the variant {variant.describe()}"
             f"{where}",
             "(co-simulation, same circuit and drive; the compensator is the paper's inverse "
             "model in both; dy: the rod between the valve switching instants)",
             f"{'f [Hz]':>6}  {'mode':<13}  {'circuit':<9}  {'load [N]':>8}  "
             f"{'q paper [m3/s]':>14}  {'q variant [m3/s]':>16}  {'variant/paper':>13}  "
             f"{'dy paper [um]':>13}  {'dy variant [um]':>15}"]
    for c in pairs:
        ratio = "-" if c["flow_ratio_variant_to_paper"] is None else \
            f"{c['flow_ratio_variant_to_paper']:.4f}"
        lines.append(f"{c['frequency_Hz']:>6g}  {c['mode']:<13}  {c['circuit']:<9}  "
                     f"{c['load_N']:>8g}  {c['flow_paper_model_m3_s']:>14.4e}  "
                     f"{c['flow_variant_m3_s']:>16.4e}  {ratio:>13}  "
                     f"{c['dy_paper_model_um']:>13.2f}  {c['dy_variant_um']:>15.2f}")
    return "\n".join(lines)
