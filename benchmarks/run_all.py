"""Run every benchmark, one after the other, and keep their JSON output.

    python benchmarks/run_all.py [--quick] [--out benchmarks/results.json] [--only NAME,...]

Each script runs in its own process (so one's peak RSS is not another's) with
``--json``; the collected objects go to ``--out`` with the machine they came
from. ``--quick`` shortens the long ones (fewer repeats and seeds, shorter
runs) for a smoke check; the figures in ``benchmarks/README.md`` come from the
full settings. Figures only: nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: name -> (full arguments, --quick arguments)
BENCHMARKS = {
    "cli_startup": ([], ["--repeats", "3"]),
    "fmu_step_cost": ([], ["--runs", "2", "--steps", "5000", "--memory-steps", "0"]),
    "fmu_exit_crashes": ([], ["--runs", "2", "--steps", "200"]),
    "cosim_realtime": (["--duration", "2", "--repeats", "3"],
                       ["--duration", "0.05", "--repeats", "1", "--cycles", "4"]),
    "cosim_memory": (["--duration", "10"], ["--duration", "0.2", "--report-every", "0.05"]),
    "cosim_convergence": ([], ["--steps", "1e-4,5e-5", "--modes", "uncompensated",
                               "--cycles", "4"]),
    "identify_diagnose_speed": ([], ["--repeats", "1"]),
    "sweep_throughput": ([], ["--frequencies", "50,100", "--no-dask"]),
    "diagnose_detection": (["--seeds", "20"], ["--seeds", "1", "--rates", "100"]),
    "system_step": ([], ["--steps", "1e-5", "--frequencies", "100", "--cycles", "4"]),
    "compensator_convergence": ([], ["--no-cosim", "--periods", "1e-4,1e-5"]),
    "position_realtime": ([], ["--repeats", "1", "--modes", "compensated"]),
    "timedomain_step_cost": ([], ["--runs", "2", "--steps", "3000"]),
    "blas_threads": ([], ["--rows", "4000", "--repeat", "3"]),
    "bounded_solve": ([], ["--problems", "20"]),
    "stacked_differences": (["--diagnose"], ["--repeats", "1"]),
    "losses_speed": ([], ["--materials", "3F4"]),
    "position_envelope_sweep": ([], ["--circuits", "ideal", "--loads", "0",
                                      "--frequencies", "100"]),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", help="comma-separated benchmark names")
    ap.add_argument("--out", default=str(HERE / "results.json"))
    args = ap.parse_args(argv)
    names = args.only.split(",") if args.only else list(BENCHMARKS)
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        ap.error(f"unknown benchmark(s) {unknown}; choose from {list(BENCHMARKS)}")
    results = {"machine": {"python": platform.python_version(), "platform": platform.platform(),
                           "cpus": os.cpu_count()},
               "started": time.strftime("%Y-%m-%d %H:%M:%S"), "quick": args.quick,
               "benchmarks": {}}
    for name in names:
        extra = BENCHMARKS[name][1 if args.quick else 0]
        cmd = [sys.executable, str(HERE / f"{name}.py"), *extra, "--json"]
        print(f"[{name}] {' '.join(cmd[1:])}", flush=True)
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t
        entry = {"command": " ".join(cmd[1:]), "wall_s": wall, "returncode": proc.returncode}
        try:  # the whole output is one JSON object, or its last line is
            try:
                entry["result"] = json.loads(proc.stdout)
            except json.JSONDecodeError:
                entry["result"] = json.loads(proc.stdout.strip().splitlines()[-1])
        except (json.JSONDecodeError, IndexError):
            entry["stdout"] = proc.stdout[-2000:]
            entry["stderr"] = proc.stderr[-2000:]
        results["benchmarks"][name] = entry
        print(f"[{name}] exit {proc.returncode} in {wall:.1f} s", flush=True)
        Path(args.out).write_text(json.dumps(results, indent=1))
    print(f"results: {args.out}")
    return 0 if all(e["returncode"] == 0 for e in results["benchmarks"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
