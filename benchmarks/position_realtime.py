"""Real-time factor of the closed-loop position study (``smeha position``).

Identifies and designs once, then runs the 5 mm step through the transducer FMU
``--repeats`` times per mode and prints the median wall time of the co-simulation
(controller included), the simulated time and their ratio, the process's CPU time (the
FMU runs in-process: the real-time factor on one core, what a shared machine's load does
not change), with the machine's load.

Usage: python benchmarks/position_realtime.py [--modes compensated,uncompensated]
       [--repeats 3] [--backend fmu|direct] [--json]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import time

from smeha.studies import flow, position


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", default="compensated,uncompensated")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--backend", choices=("fmu", "direct"), default="fmu")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    fmu = flow.ensure_fmu(quiet=True) if args.backend == "fmu" else None
    out = []
    for mode in args.modes.split(","):
        settings = position.PositionSettings(mode=mode, backend=args.backend)
        t = time.perf_counter()
        model = position.identify(settings, fmu)
        identify_s = time.perf_counter() - t
        gains = position.design(model, settings.target)
        walls, cpus, simulated, rise = [], [], 0.0, 0.0
        for _ in range(args.repeats):
            res = position.run_step(settings, model, gains, fmu)
            walls.append(res.figures["wall_s"])
            cpus.append(res.figures["cpu_s"])
            simulated = res.figures["simulated_s"]
            rise = res.figures["rise_time_s"]
        wall, cpu = statistics.median(walls), statistics.median(cpus)
        out.append({"mode": mode, "backend": args.backend, "wall_s": wall,
                    "walls_s": walls, "cpu_s": cpu, "simulated_s": simulated,
                    "real_time_factor": simulated / wall,
                    "real_time_factor_one_core": simulated / cpu, "identify_s": identify_s,
                    "rise_time_s": rise, "loadavg": os.getloadavg()})
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for r in out:
        print(f"{r['mode']:<13} {r['backend']}: {r['simulated_s']:.2f} s simulated in "
              f"{r['wall_s']:.2f} s (median of {len(r['walls_s'])}): real-time factor "
              f"{r['real_time_factor']:.2f}; CPU {r['cpu_s']:.2f} s: "
              f"{r['real_time_factor_one_core']:.2f} on one core; identification "
              f"{r['identify_s']:.1f} s; rise "
              f"{r['rise_time_s']:.3f} s; load average {r['loadavg'][0]:.2f}")


if __name__ == "__main__":
    main()
