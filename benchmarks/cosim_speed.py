"""Wall time of one simulated second of the EHA co-simulation, and the FMI overhead.

Runs the same case (default 100 Hz, compensated, realistic circuit, 20 us step)
through the FMU with fmpy and with gmt coupled directly in Python, in one
process, several times each; prints the medians, the real-time factor
(simulated seconds per wall second), the FMU/direct ratio and the peak RSS.

Usage: python benchmarks/cosim_speed.py [--duration 1.0] [--repeats 3] [--frequency 100]
       [--mode compensated] [--step 20e-6] [--ideal] [--json]
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics

from smeha import flowstudy


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=1.0, help="simulated time [s]")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--frequency", type=float, default=100.0)
    ap.add_argument("--mode", choices=flowstudy.MODES, default="compensated")
    ap.add_argument("--step", type=float, default=20e-6)
    ap.add_argument("--ideal", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    fmu = flowstudy.ensure_fmu(quiet=True)
    walls = {"fmu": [], "direct": []}
    for _ in range(args.repeats):
        for backend in ("fmu", "direct"):
            case = flowstudy.Case(args.frequency, args.mode, ideal=args.ideal, step=args.step,
                                  cycles=args.duration * args.frequency, backend=backend)
            _, _, row = flowstudy.run_case(case, fmu)
            walls[backend].append(row["wall_s"])
    med = {k: statistics.median(v) for k, v in walls.items()}
    result = {
        "case": {"frequency_Hz": args.frequency, "mode": args.mode, "step_s": args.step,
                 "circuit": "ideal" if args.ideal else "realistic",
                 "simulated_s": args.duration},
        "wall_s": walls, "median_wall_s": med,
        "real_time_factor": {k: args.duration / v for k, v in med.items()},
        "fmi_overhead_ratio": med["fmu"] / med["direct"],
        "us_per_step": {k: v / (args.duration / args.step) * 1e6 for k, v in med.items()},
        "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    if args.json:
        print(json.dumps(result))
        return
    c = result["case"]
    print(f"{c['mode']} {c['frequency_Hz']:g} Hz, {c['circuit']} circuit, step {c['step_s']:g} s, "
          f"{c['simulated_s']:g} s simulated, median of {args.repeats}")
    for k in ("fmu", "direct"):
        print(f"  {k:<6} wall {med[k]:7.2f} s  real-time factor {result['real_time_factor'][k]:.4f}"
              f"  {result['us_per_step'][k]:7.1f} us per communication step")
    print(f"  FMI overhead (fmu / direct, same process): {result['fmi_overhead_ratio']:.3f}")
    print(f"  peak RSS: {result['peak_rss_MB']:.0f} MB")


if __name__ == "__main__":
    main()
