"""Sweep throughput: points per minute with 1 and 2 local workers, and on a Dask LocalCluster.

Runs the same grid (default 4 frequencies x 2 modes, realistic circuit, FMU
backend, 16 cycles each) into fresh tables with ``--workers 1``, ``--workers 2``
and a 2-worker Dask LocalCluster (processes), ``--repeats`` times each, and
prints the median wall time, the throughput and the speed-up over one worker.
On this 2-core machine the ideal speed-up is 2; the shortfall is process
start-up (a spawned worker imports numpy, scipy, control, fmpy and numba and loads the
compiled kernel before its first point; one local worker runs in the calling process), FMU
loading per point and the longest point's tail.

Usage: python benchmarks/sweep_throughput.py [--cycles 16] [--step S] [--repeats 1]
       [--no-dask] [--json]
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from system_models.defaults import DEFAULT_STEP
from smeha import flowstudy, sweep


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frequencies", default="50,70,80,100")
    ap.add_argument("--cycles", type=float, default=16.0)
    ap.add_argument("--step", type=float, default=DEFAULT_STEP)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    spec = {"grid": {"frequency": [float(f) for f in args.frequencies.split(",")],
                     "mode": list(flowstudy.MODES)},
            "settings": {"cycles": args.cycles, "step": args.step}}
    points = sweep.parse_spec(spec)
    fmu = flowstudy.ensure_fmu(quiet=True)
    configs = [("local, 1 worker", {"workers": 1}), ("local, 2 workers", {"workers": 2})]
    cluster = None
    if not args.no_dask:
        from dask.distributed import LocalCluster
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        configs.append(("dask LocalCluster, 2 workers", {"scheduler": cluster.scheduler_address}))
    walls = {name: [] for name, _ in configs}
    try:
        for _ in range(args.repeats):
            for name, kw in configs:
                with tempfile.TemporaryDirectory() as tmp:
                    out = Path(tmp) / "sweep.csv"
                    t = time.perf_counter()
                    res = sweep.run_sweep(points, out, fmu_path=fmu, quiet=True, **kw)
                    walls[name].append(time.perf_counter() - t)
                    if res.failed:
                        raise SystemExit(f"{name}: {res.failed} points failed")
    finally:
        if cluster is not None:
            cluster.close()
    med = {k: statistics.median(v) for k, v in walls.items()}
    base = med["local, 1 worker"]
    result = {"points": len(points), "cycles": args.cycles, "step_s": args.step,
              "wall_s": walls, "median_wall_s": med,
              "points_per_minute": {k: 60.0 * len(points) / v for k, v in med.items()},
              "speedup_over_1_worker": {k: base / v for k, v in med.items()}}
    if args.json:
        print(json.dumps(result))
        return
    print(f"{len(points)} points ({args.cycles:g} cycles, h = {args.step * 1e6:g} us, FMU), "
          f"median of {args.repeats}:")
    for k in med:
        print(f"  {k:<30} {med[k]:7.1f} s  {result['points_per_minute'][k]:6.1f} points/min  "
              f"speed-up {result['speedup_over_1_worker'][k]:.2f}")


if __name__ == "__main__":
    main()
