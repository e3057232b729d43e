"""Real-time factor of the EHA co-simulation at ``smeha simulate``'s defaults, and what it costs.

1. Real time: the default case of ``smeha simulate`` (100 Hz, compensated, realistic
   circuit, :class:`smeha.studies.flow.Case`'s defaults: the force port, its default step)
   over ``--duration`` simulated seconds, timed by the run's own ``wall_s``, through the
   FMU with fmpy and with gmt in one process, ``--repeats`` times each, interleaved
   (median): the real-time factor (simulated s per wall s) and the FMI overhead (FMU /
   direct, same run).
2. The cost of a communication step, split by one instrumented run per backend: the
   transducer (its steps through fmpy, or gmt's), the plant (the compiled kernel's calls)
   and the master (the rest: the grid, the controller, the records); with the plant's work
   per step (TR-BDF2 substeps, Newton iterations, Jacobians).
3. The plant window: one compiled call per communication step against ``window`` steps a
   call (CosimSettings.window), direct backend.
4. Convergence: the flow at the default step h, h/2 and h/4 (both modes), and at h with
   the plant's longest substep varied; against a fine reference (h/4, 5 us substeps).

Usage: python benchmarks/cosim_realtime.py [--duration 2] [--repeats 3] [--cycles 8] [--json]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import statistics
import time

import numpy as np

import gmt
from smeha.studies import flow
from system_models import cosim, kernel, presets
from system_models.defaults import DEFAULT_STEP, HYDRAULIC_STEP


def default_case(duration, **changes):
    """smeha simulate --frequency 100 --mode compensated --duration D (its defaults)."""
    case = flow.Case(100.0, "compensated", cycles=duration * 100.0)
    return dataclasses.replace(case, **changes)


def timed(case, fmu):
    """wall_s of one run (the run's own figure), its flow, and the process's CPU time over
    the run (on a machine shared with other jobs the wall time includes waiting for a core;
    the CPU time is what the run costs on one)."""
    cpu = time.process_time()
    _, _, row = flow.run_case(case, fmu)
    return row["wall_s"], row["flow_sim_m3_s"], time.process_time() - cpu


def split(case, fmu):
    """One run with its transducer and plant calls timed: per step figures [us]."""
    acc = {"transducer": 0.0, "plant": 0.0}
    counts = np.zeros(3, dtype=np.int64)
    backend = cosim.FmuTransducer if case.backend == "fmu" else cosim.DirectTransducer
    drive_step, plant_run = backend.drive_step, kernel.plant_run

    def timed_drive(self, *args):
        t0 = time.perf_counter()
        out = drive_step(self, *args)
        acc["transducer"] += time.perf_counter() - t0
        return out

    def timed_plant(*args, **kwargs):
        t0 = time.perf_counter()
        out = plant_run(*args, counts=counts, **kwargs)
        acc["plant"] += time.perf_counter() - t0
        return out

    backend.drive_step, kernel.plant_run = timed_drive, timed_plant
    try:
        record, _, row = flow.run_case(case, fmu)
    finally:
        backend.drive_step, kernel.plant_run = drive_step, plant_run
    n = len(record) - 1
    wall = row["wall_s"]
    return {"steps": n, "wall_s": wall, "us_per_step": wall / n * 1e6,
            "transducer_us": acc["transducer"] / n * 1e6, "plant_us": acc["plant"] / n * 1e6,
            "master_us": (wall - acc["transducer"] - acc["plant"]) / n * 1e6,
            "substeps_per_step": counts[0] / n, "newton_per_step": counts[1] / n,
            "jacobians_per_step": counts[2] / n}


def window_run(duration, window):
    """Wall time of the default case, gmt in-process, with ``window`` steps a plant call."""
    case = default_case(duration, backend="direct")
    control, _ = flow.control_signal(case.mode, case.frequency)
    backend = cosim.DirectTransducer(gmt.TransducerParameters(),
                                     gmt.Excitation(case.frequency, 1.0), case.drive())
    settings = cosim.CosimSettings(duration=duration, load_force=case.load_force,
                                   window=window)
    t0 = time.perf_counter()
    cosim.cosimulate(backend, control, presets.circuit(case.circuit), settings)
    return time.perf_counter() - t0


def convergence(cycles):
    """Flows at h, h/2, h/4 (both modes) and at h with the plant's substep varied."""
    out = []
    for mode in flow.MODES:
        base = flow.Case(100.0, mode, cycles=cycles, backend="direct")
        ref = flow.run_case(dataclasses.replace(base, step=DEFAULT_STEP / 4,
                                                     hydraulic_step=5e-6))[2]["flow_sim_m3_s"]
        rows = []
        for label, changes in (("h", {}), ("h/2", {"step": DEFAULT_STEP / 2}),
                               ("h/4", {"step": DEFAULT_STEP / 4}),
                               ("substep 100 us", {"hydraulic_step": 1e-4}),
                               ("substep 25 us", {"hydraulic_step": 2.5e-5}),
                               ("substep 10 us", {"hydraulic_step": 1e-5})):
            q = flow.run_case(dataclasses.replace(base, **changes))[2]["flow_sim_m3_s"]
            rows.append({"run": label, "flow_m3_s": q, "error_vs_reference": q / ref - 1})
        h = {r["run"]: r["flow_m3_s"] for r in rows}
        out.append({"mode": mode, "reference_m3_s": ref, "rows": rows,
                    "change_h_to_h2": abs(h["h/2"] / h["h"] - 1),
                    "change_h_to_h4": abs(h["h/4"] / h["h"] - 1)})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=2.0, help="simulated s of the timed runs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cycles", type=float, default=8.0, help="cycles of the accuracy runs")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    say = (lambda *a: None) if args.json else (lambda *a: print(*a, flush=True))
    fmu = flow.ensure_fmu(quiet=True)
    timed(default_case(0.05), fmu)  # compiled code loaded, FMU extracted
    walls, cpus = {"fmu": [], "direct": []}, {"fmu": [], "direct": []}
    flows = {}
    for _ in range(args.repeats):
        for backend in ("fmu", "direct"):
            wall, flows[backend], cpu = timed(default_case(args.duration, backend=backend), fmu)
            walls[backend].append(wall)
            cpus[backend].append(cpu)
    med = {k: statistics.median(v) for k, v in walls.items()}
    med_cpu = {k: statistics.median(v) for k, v in cpus.items()}
    rtf = {k: args.duration / v for k, v in med.items()}
    say(f"smeha simulate's defaults (100 Hz compensated, realistic, step {DEFAULT_STEP:g} s, "
        f"plant substeps <= {HYDRAULIC_STEP:g} s), {args.duration:g} s simulated:")
    for k in ("fmu", "direct"):
        say(f"  {k:<6} wall {med[k]:.3f} s (median of {args.repeats}): real-time factor "
            f"{rtf[k]:.2f}; CPU {med_cpu[k]:.3f} s (real-time factor on one core "
            f"{args.duration / med_cpu[k]:.2f}); flow {flows[k]:.6e} m^3/s")
    say(f"  FMI overhead (fmu / direct): {med['fmu'] / med['direct']:.3f} wall, "
        f"{med_cpu['fmu'] / med_cpu['direct']:.3f} CPU")
    costs = {k: split(default_case(args.duration, backend=k), fmu) for k in ("fmu", "direct")}
    for k, c in costs.items():
        say(f"  per communication step, {k}: {c['us_per_step']:.1f} us = transducer "
            f"{c['transducer_us']:.1f} + plant {c['plant_us']:.1f} + master "
            f"{c['master_us']:.1f}; plant work {c['substeps_per_step']:.2f} substeps, "
            f"{c['newton_per_step']:.1f} Newton iterations, {c['jacobians_per_step']:.2f} "
            f"Jacobians a step")
    window = {}
    for w in (1, 64):
        runs = [window_run(args.duration, w) for _ in range(args.repeats)]
        window[w] = statistics.median(runs)
    say(f"  plant window, direct: 1 step a call {window[1]:.3f} s, 64 steps a call "
        f"{window[64]:.3f} s")
    conv = convergence(args.cycles)
    for c in conv:
        say(f"  convergence, {c['mode']} (reference {c['reference_m3_s']:.6e} at h/4 with 5 us "
            f"substeps): " + ", ".join(f"{r['run']} {100 * r['error_vs_reference']:+.3f} %"
                                        for r in c["rows"])
            + f"; change h -> h/2 {100 * c['change_h_to_h2']:.3f} %, h -> h/4 "
              f"{100 * c['change_h_to_h4']:.3f} %")
    result = {
        "case": {"frequency_Hz": 100.0, "mode": "compensated", "circuit": "realistic",
                 "step_s": DEFAULT_STEP, "hydraulic_step_s": HYDRAULIC_STEP,
                 "coupling": "force"},
        "simulated_s": args.duration, "wall_s": walls, "median_wall_s": med,
        "cpu_s": cpus, "median_cpu_s": med_cpu,
        "real_time_factor": rtf,
        "real_time_factor_cpu": {k: args.duration / v for k, v in med_cpu.items()},
        "fmi_overhead_ratio": med["fmu"] / med["direct"],
        "fmi_overhead_ratio_cpu": med_cpu["fmu"] / med_cpu["direct"],
        "cost_split": costs, "window_wall_s": window, "convergence": conv,
        "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    if args.json:
        print(json.dumps(result))


if __name__ == "__main__":
    main()
