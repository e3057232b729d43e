"""Sweep ``smeha position`` over its envelope and print each run's outcome.

Every combination of circuit, drive mode, pump frequency, load and step direction runs
through the command line in-process (``smeha.cli.main``); the outcome is either the step's
figures (rise, overshoot, settling or "not settled", final error) or the one line of an
exit 2. Anything else -- a traceback, exit 1, a NaN figure -- is counted as a failure.

    nice -n 10 python benchmarks/position_envelope_sweep.py            # the full grid
    nice -n 10 python benchmarks/position_envelope_sweep.py --backend fmu --loads 150

The transducer runs in-process by default (``--backend direct``: the same gmt model the FMU
wraps, about twice as fast on the shared machine).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import json
import math
import time

from smeha import cli

CIRCUITS = ("realistic", "differential")
MODES = ("compensated", "uncompensated")
FREQUENCIES = (20.0, 100.0, 200.0)
LOADS = (-500.0, 0.0, 150.0, 300.0, 1000.0)
TARGETS = (5.0, -5.0)


def run_one(circuit, mode, frequency, load, target, backend) -> tuple[str, str, float]:
    """(outcome, text, wall seconds) of one command line."""
    argv = ["position", "--mode", mode, "--circuit", circuit, "--frequency", f"{frequency:g}",
            f"--load={load:g}", f"--target-mm={target:g}", "--backend", backend, "--json"]
    out, err = io.StringIO(), io.StringIO()
    wall = time.perf_counter()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.main(argv)
    except Exception as exc:  # noqa: BLE001 - a benchmark counts every escape as a failure
        return "FAIL", f"{type(exc).__name__}: {exc}", time.perf_counter() - wall
    wall = time.perf_counter() - wall
    lines = [s for s in err.getvalue().splitlines() if s.strip()]
    if code == 2:
        ok = len(lines) == 1 and "Traceback" not in err.getvalue()
        return ("exit 2" if ok else "FAIL"), lines[-1] if lines else "", wall
    if code != 0:
        return "FAIL", f"exit {code}: {lines[-1] if lines else ''}", wall
    d = json.loads(out.getvalue())
    numbers = [d[k] for k in ("rise_time_s", "overshoot_fraction", "final_error_m")]
    if any(v is None or not math.isfinite(v) for v in numbers):
        return "FAIL", f"a figure is not a number: {numbers}", wall
    settle = (f"settling {d['settling_time_s']:.3f} s" if d["settled"]
              else f"not settled within {d['duration_s']:g} s")
    return "figures", (f"rise {d['rise_time_s']:.3f} s, overshoot "
                       f"{100 * d['overshoot_fraction']:.1f} %, {settle}, final error "
                       f"{d['final_error_m'] * 1e6:.1f} um"), wall


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--backend", choices=("direct", "fmu"), default="direct")
    p.add_argument("--circuits", type=lambda s: s.split(","), default=CIRCUITS)
    p.add_argument("--loads", type=lambda s: [float(v) for v in s.split(",")], default=LOADS)
    p.add_argument("--frequencies", type=lambda s: [float(v) for v in s.split(",")],
                   default=FREQUENCIES)
    p.add_argument("--json", action="store_true", help="print one JSON object at the end")
    args = p.parse_args(argv)
    counts, runs = {}, []
    if not args.json:
        print(f"{'circuit':<12} {'mode':<13} {'f [Hz]':>6} {'load [N]':>8} {'step [mm]':>9} "
              f"{'wall [s]':>8}  outcome")
    for circuit, mode, f, load, target in itertools.product(
            args.circuits, MODES, args.frequencies, args.loads, TARGETS):
        outcome, text, wall = run_one(circuit, mode, f, load, target, args.backend)
        counts[outcome] = counts.get(outcome, 0) + 1
        runs.append({"circuit": circuit, "mode": mode, "frequency_Hz": f, "load_N": load,
                     "target_mm": target, "wall_s": wall, "outcome": outcome, "text": text})
        if not args.json:
            print(f"{circuit:<12} {mode:<13} {f:>6g} {load:>8g} {target:>+9g} {wall:>8.1f}  "
                  f"{outcome}: {text}", flush=True)
    if args.json:
        print(json.dumps({"runs": runs, "outcomes": counts}))
    else:
        print("outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return 1 if counts.get("FAIL") else 0


if __name__ == "__main__":
    raise SystemExit(main())
