"""Sweep throughput: 1 against 2 local workers over grid sizes, and a Dask LocalCluster.

Runs grids of ``--points`` sizes (default 2, 4, 8, 16 points: frequencies from 50 Hz in
5 Hz steps x both modes, realistic circuit, FMU backend, ``--cycles`` cycles each) into
fresh tables, each ``smeha sweep`` in a new process as a user runs it (start-up
included): ``--workers 1`` (the points in that process), ``--workers 2`` with the workers
forked from the prepared parent (:data:`smeha.pool.START_METHOD` on Linux) and, for the
comparison, ``--workers 2`` spawned (fresh interpreters: what every platform did before,
and what Windows and macOS do), interleaved, ``--repeats`` times each; then the
``--dask-points`` grid on a 2-worker Dask LocalCluster (processes). Prints median wall
and CPU times (the command and its workers: what the workers' start-up costs, whatever
else runs on the machine), the ratio of 2 workers to 1 (below 1: faster) and the crossover,
the smallest grid from which two workers beat one. On this 2-core machine the ideal ratio is 0.5; what
is left of a worker's start-up (its own FMU instance) and the longest point's tail keep
it above.

Usage: python benchmarks/sweep_throughput.py [--points 2,4,8,16] [--cycles 16] [--step S]
       [--repeats 3] [--dask-points 8] [--no-dask] [--json]
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from smeha import pool
from smeha.studies import flow
from system_models.defaults import DEFAULT_STEP


#: ``smeha sweep`` as a user starts it, in a new process, with the workers' start method set
#: first (the benchmark's only intervention: spawn is what other platforms get).
COMMAND = ("import sys; from smeha import pool; pool.START_METHOD = sys.argv[1]; "
           "from smeha.cli import main; sys.exit(main(sys.argv[2:]))")


def timed_sweep(n, cycles, step, fmu, workers=None, method=None, scheduler=None) -> tuple:
    """Wall and CPU time (user + system, the command and its workers) of ``smeha sweep`` on
    a fresh table, end to end (start-up included), [s]."""
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "spec.toml"
        spec.write_text(f"[grid]\nfrequency = {[50.0 + 5.0 * k for k in range((n + 1) // 2)]}\n"
                        f"mode = {list(flow.MODES)}\n"
                        f"[settings]\ncycles = {cycles}\nstep = {step}\n".replace("'", '"'))
        argv = ["sweep", str(spec), "--fmu", str(fmu), "--json"]
        argv += ["--scheduler", scheduler] if scheduler else ["--workers", str(workers)]
        cpu = _children_cpu()
        t = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", COMMAND, method or pool.START_METHOD,
                               *argv], capture_output=True, text=True)
        wall = time.perf_counter() - t
        cpu = _children_cpu() - cpu
    report = json.loads(done.stdout) if done.stdout.strip() else {}
    if done.returncode != 0 or report.get("failed") or report.get("ran") != n:
        raise SystemExit(f"smeha {' '.join(argv)}: exit {done.returncode}\n{done.stderr}")
    return wall, cpu


def _children_cpu() -> float:
    """User + system time of this process's finished children (and theirs), [s]."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="2,4,8,16")
    ap.add_argument("--cycles", type=float, default=16.0)
    ap.add_argument("--step", type=float, default=DEFAULT_STEP)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--dask-points", type=int, default=8)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    fmu = flow.ensure_fmu(quiet=True)
    configs = {"1 worker": (1, pool.START_METHOD), f"2 workers, {pool.START_METHOD}":
               (2, pool.START_METHOD), "2 workers, spawn": (2, "spawn")}
    sizes = [int(n) for n in args.points.split(",")]
    walls = {n: {name: [] for name in configs} for n in sizes}
    cpus = {n: {name: [] for name in configs} for n in sizes}
    default_method = pool.START_METHOD
    for _ in range(args.repeats):
        for n in sizes:
            for name, (workers, method) in configs.items():
                wall, cpu = timed_sweep(n, args.cycles, args.step, fmu, workers, method)
                walls[n][name].append(wall)
                cpus[n][name].append(cpu)
    med = {n: {k: statistics.median(v) for k, v in w.items()} for n, w in walls.items()}
    med_cpu = {n: {k: statistics.median(v) for k, v in w.items()} for n, w in cpus.items()}
    fork = f"2 workers, {default_method}"
    faster = [n for n in sizes if med[n][fork] < med[n]["1 worker"]]
    result = {"cycles": args.cycles, "step_s": args.step, "start_method": default_method,
              "wall_s": {str(n): w for n, w in walls.items()},
              "median_wall_s": {str(n): m for n, m in med.items()},
              "cpu_s": {str(n): c for n, c in cpus.items()},
              "median_cpu_s": {str(n): m for n, m in med_cpu.items()},
              "ratio_2_to_1": {str(n): {k: m[k] / m["1 worker"] for k in m}
                               for n, m in med.items()},
              "crossover_points": faster[0] if faster else None}
    if not args.no_dask:
        from dask.distributed import LocalCluster
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster:
            dask = [timed_sweep(args.dask_points, args.cycles, args.step, fmu,
                                scheduler=cluster.scheduler_address)[0]
                    for _ in range(args.repeats)]
        result["dask"] = {"points": args.dask_points, "wall_s": dask,
                          "median_wall_s": statistics.median(dask)}
    if args.json:
        print(json.dumps(result))
        return
    print(f"FMU backend, {args.cycles:g} cycles a point, h = {args.step * 1e6:g} us, "
          f"median of {args.repeats}; ratio: 2 workers / 1 worker")
    print(f"{'points':>6}  " + "  ".join(f"{k:>26}" for k in configs)
          + f"  {'ratio ' + default_method:>11}  {'ratio spawn':>11}")
    for n in sizes:
        m, c = med[n], med_cpu[n]
        print(f"{n:>6}  " + "  ".join(f"{m[k]:>7.2f} s (CPU {c[k]:>5.2f} s)" for k in configs)
              + f"  {m[fork] / m['1 worker']:>11.2f}  {m['2 workers, spawn'] / m['1 worker']:>11.2f}")
    print("two workers beat one from " + (f"{faster[0]} points" if faster else
                                          "no grid size measured"))
    if "dask" in result:
        d = result["dask"]
        print(f"dask LocalCluster, 2 workers, {d['points']} points: {d['median_wall_s']:.2f} s")


if __name__ == "__main__":
    main()
