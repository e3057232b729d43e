"""Cost of one FMU step from an fmpy loop, and memory after a million steps.

    python benchmarks/fmu_step_cost.py [--fmu dist/SmehaGmt.fmu] [--runs 5] [--steps 20000]
                                       [--memory-steps 1e6] [--json]

Prints the median (over ``--runs`` runs of ``--steps`` steps) of the time per
step in microseconds, for doStep alone and for a host's full exchange (set u and
external_force, doStep, get the 8 Real outputs, saturated and saturation_count),
then the resident memory after ``--memory-steps`` steps (0 skips it). Figures
only; nothing is asserted.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fmu_memory import built_fmu, memory_run, open_fmu  # noqa: E402


def time_loop(slave, vr, steps, full):
    in_vr = [vr["u"], vr["external_force"]]
    out_vr = [vr[n] for n in ("current", "displacement", "velocity", "field", "flux_density",
                              "magnetization", "strain", "force")]
    b_vr, i_vr = [vr["saturated"]], [vr["saturation_count"]]
    h, w, t = 1e-5, 2 * math.pi * 50.0, 0.0
    u = [math.cos(w * k * h) for k in range(steps)]
    start = time.perf_counter()
    if full:
        for k in range(steps):
            slave.setReal(in_vr, [u[k], 0.0])
            slave.doStep(t, h)
            slave.getReal(out_vr)
            slave.getBoolean(b_vr)
            slave.getInteger(i_vr)
            t += h
    else:
        slave.setReal(in_vr, [0.5, 0.0])
        for k in range(steps):
            slave.doStep(t, h)
            t += h
    return (time.perf_counter() - start) / steps * 1e6


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", help="FMU to run (default: build one)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--memory-steps", type=float, default=1e6)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    say = (lambda *a: None) if args.json else print
    result = {"steps_per_run": args.steps, "runs": args.runs}
    with tempfile.TemporaryDirectory() as tmp:
        fmu = built_fmu(args.fmu, tmp)
        slave, vr = open_fmu(fmu)
        time_loop(slave, vr, 2000, True)  # warm up (imports, ZOH cache)
        for key, label, full in (("doStep_us", "doStep only", False),
                                 ("exchange_us", "set 2 inputs + doStep + get 10 outputs", True)):
            runs = [time_loop(slave, vr, args.steps, full) for _ in range(args.runs)]
            result[key] = statistics.median(runs)
            result[key + "_runs"] = runs
            say(f"{label:40s} median {statistics.median(runs):7.2f} us/step "
                f"(runs: {', '.join(f'{r:.2f}' for r in runs)})")
        if args.memory_steps > 0:
            n = int(args.memory_steps)
            say(f"memory over {n} steps (set u + doStep + get 8 outputs):")
            samples = memory_run(fmu, n)
            result["memory"] = {"steps": n, "rss_after_MB": samples[-1][1],
                                "rss_early_MB": samples[1][1], "early_steps": samples[1][0]}
            say(f"RSS after {n} steps: {samples[-1][1]:.1f} MB (after {samples[1][0]} steps: "
                f"{samples[1][1]:.1f} MB, growth {samples[-1][1] - samples[1][1]:+.1f} MB)")
    if args.json:
        import json
        print(json.dumps(result))

if __name__ == "__main__":
    main()
