"""Memory of a long co-simulation: 10 s at 100 Hz through the FMU, streamed.

The master keeps only the last two records (``cosimulate(keep_record=False)``)
and the flow is accumulated on the fly (:class:`system_models.flowcheck.RunningFlow`),
so resident memory should stay flat after the first cycles. Prints the RSS
every ``--report-every`` simulated seconds, the peak RSS and the flow.

Usage: python benchmarks/cosim_memory.py [--duration 10] [--step S] [--frequency 100]
       [--mode compensated] [--branch-rule demand] [--backend fmu|direct] [--json]
"""
from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path

import gmt
from smeha.studies import flow as flowstudy
from system_models import presets
from system_models.defaults import DEFAULT_STEP
from system_models.cosim import CosimSettings, DirectTransducer, FmuTransducer, cosimulate
from system_models.flowcheck import RunningFlow

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fmu_memory import rss_mb  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--step", type=float, default=DEFAULT_STEP)
    ap.add_argument("--frequency", type=float, default=100.0)
    ap.add_argument("--mode", choices=flowstudy.MODES, default="compensated")
    ap.add_argument("--branch-rule", choices=("control", "demand"), default="demand")
    ap.add_argument("--backend", choices=("fmu", "direct"), default="fmu")
    ap.add_argument("--report-every", type=float, default=1.0, help="simulated s")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    compensated = args.mode == "compensated"
    control, _ = flowstudy.control_signal(args.mode, args.frequency)
    if args.backend == "fmu":
        trans = FmuTransducer(flowstudy.ensure_fmu(quiet=True),
                              {"frequency": args.frequency, "current_amplitude": 1.0,
                               "compensated": compensated, "branch_rule": args.branch_rule})
    else:
        trans = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(args.frequency, 1.0),
                                 gmt.DriveParameters(compensated=compensated,
                                                     branch_rule=args.branch_rule))
    settings = CosimSettings(duration=args.duration, step=args.step,
                             load_force=presets.REALISTIC_LOAD)
    flow = RunningFlow()
    samples = []
    next_report = [0.0]
    wall0 = time.perf_counter()

    def observe(rec):
        flow(rec)
        if rec["time"] >= next_report[0] - 1e-12:
            samples.append({"simulated_s": float(rec["time"]), "rss_MB": rss_mb(),
                            "wall_s": time.perf_counter() - wall0})
            next_report[0] += args.report_every
            if not args.json:
                s = samples[-1]
                print(f"  t = {s['simulated_s']:5.2f} s  RSS {s['rss_MB']:7.1f} MB  "
                      f"wall {s['wall_s']:7.1f} s", flush=True)

    try:
        cosimulate(trans, control, presets.realistic_circuit(), settings, observer=observe,
                   keep_record=False)
    finally:
        trans.close()
    wall = time.perf_counter() - wall0
    after_first = [s["rss_MB"] for s in samples if s["simulated_s"] >= args.report_every - 1e-9]
    result = {
        "case": {"frequency_Hz": args.frequency, "mode": args.mode,
                 "branch_rule": args.branch_rule, "step_s": args.step,
                 "backend": args.backend, "simulated_s": args.duration},
        "samples": samples, "wall_s": wall, "real_time_factor": args.duration / wall,
        "rss_growth_after_first_report_MB": (max(after_first) - min(after_first)
                                              if after_first else None),
        "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "flow_m3_s": flow.flow, "cycles_averaged": len(flow.starts) - flow.skip_cycles - 1,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(f"{args.duration:g} s at {args.frequency:g} Hz ({args.mode}, {args.backend}, "
          f"h = {args.step * 1e6:g} us) in {wall:.1f} s: RSS grew "
          f"{result['rss_growth_after_first_report_MB']:.2f} MB after t = "
          f"{args.report_every:g} s; peak RSS {result['peak_rss_MB']:.0f} MB; flow "
          f"{result['flow_m3_s']:.5e} m^3/s over {result['cycles_averaged']} cycles")


if __name__ == "__main__":
    main()
