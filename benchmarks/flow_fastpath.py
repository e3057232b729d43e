"""The flow table by the periodic-steady-state fast path against time stepping.

1. Fast path (:func:`smeha.fastpath.flow_table`): the whole table (default
   4 frequencies x 2 modes, realistic circuit, 150 N), ``--repeats`` times in
   one process. Prints the first (cold) and the median wall time.
2. Time stepped (:func:`smeha.flowstudy.run_case` at the study's defaults: the
   force port, gmt in-process, ``--steps-cycles`` cycles), each case once. A
   small warm-up run first loads the compiled kernel, so the table's time is
   the co-simulations'. Prints the wall time of the table and of each case.
3. Per case: both flows, their relative difference, and both dy.

``--skip-timestepping`` takes the time-stepped figures from
:data:`MEASURED` instead (8 cycles, measured as stated there); they are valid
for the default options only.

One core: BLAS and OpenMP threads are held to 1 before numpy loads (SuperLU
is single-threaded anyway).

Usage: python benchmarks/flow_fastpath.py [--frequencies 50,70,80,100] [--circuit NAME]
       [--load N] [--repeats 5] [--sampling-phases 1] [--steps-cycles 8]
       [--skip-timestepping] [--json]
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

from smeha import fastpath, flowstudy  # noqa: E402

#: Time-stepped flow table measured with this script on 2026-11-24: realistic circuit,
#: 150 N, the study's defaults (the force port, 100 us step), 8 cycles, gmt in-process, on
#: the 2-core machine with other jobs running (load average ~3.5): (frequency, mode) ->
#: (flow [m^3/s], dy [um], wall [s]).
MEASURED = {
    "table_wall_s": 0.32,
    "cases": {
        (50.0, "uncompensated"): (1.774323e-06, 28.522, 0.03),
        (50.0, "compensated"): (2.379999e-06, 38.092, 0.04),
        (70.0, "uncompensated"): (2.018339e-06, 23.223, 0.02),
        (70.0, "compensated"): (2.924379e-06, 33.386, 0.02),
        (80.0, "uncompensated"): (1.968684e-06, 19.880, 0.02),
        (80.0, "compensated"): (2.628166e-06, 26.282, 0.02),
        (100.0, "uncompensated"): (1.398711e-06, 11.544, 0.02),
        (100.0, "compensated"): (3.227019e-06, 25.801, 0.02),
    },
}


def fast_table(args):
    walls, rows = [], None
    for _ in range(args.repeats):
        start = time.perf_counter()
        rows = fastpath.flow_table(args.frequencies, flowstudy.MODES, circuit=args.circuit,
                                   load=args.load, sampling_phases=args.sampling_phases)
        walls.append(time.perf_counter() - start)
    return rows, walls


def stepped_table(args):
    # compile the hydraulic kernel (numba) outside the timed table
    flowstudy.run_case(flowstudy.Case(100.0, "uncompensated", cycles=4, backend="direct"))
    rows = []
    start = time.perf_counter()
    for f in args.frequencies:
        for mode in flowstudy.MODES:
            case = flowstudy.Case(f, mode, circuit=args.circuit, load=args.load,
                                  cycles=args.steps_cycles, backend="direct")
            rows.append(flowstudy.run_case(case)[2])
    return rows, time.perf_counter() - start


def measured_rows(args):
    if args.circuit != "realistic" or args.load is not None or args.steps_cycles != 8.0:
        raise SystemExit("--skip-timestepping: the stored figures are for the default realistic "
                         "circuit, 150 N and 8 cycles only")
    rows = []
    for f in args.frequencies:
        for mode in flowstudy.MODES:
            if (f, mode) not in MEASURED["cases"]:
                raise SystemExit(f"--skip-timestepping: no stored figure at {f:g} Hz, {mode}")
            flow, dy, wall = MEASURED["cases"][(f, mode)]
            rows.append({"frequency_Hz": f, "mode": mode, "flow_sim_m3_s": flow, "dy_um": dy,
                         "wall_s": wall})
    return rows, MEASURED["table_wall_s"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frequencies", default="50,70,80,100",
                    type=lambda s: [float(x) for x in s.split(",")])
    ap.add_argument("--circuit", choices=flowstudy.CIRCUITS, default="realistic")
    ap.add_argument("--load", type=float, default=None,
                    help="cylinder load [N] (default the circuit's: 150 realistic, else 0)")
    ap.add_argument("--repeats", type=int, default=5, help="fast-path tables timed")
    ap.add_argument("--sampling-phases", type=int, default=1,
                    help="fast path: grids offset by fractions of a step, averaged")
    ap.add_argument("--steps-cycles", type=float, default=8.0,
                    help="cycles of each time-stepped run (the study: 8)")
    ap.add_argument("--skip-timestepping", action="store_true",
                    help="use the stored time-stepped figures (MEASURED)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    stored = measured_rows(args) if args.skip_timestepping else None  # refuse early
    fast, walls = fast_table(args)
    stepped, stepped_wall = stored if stored is not None else stepped_table(args)
    cases = []
    for a, b in zip(fast, stepped):
        cases.append({
            "frequency_Hz": a["frequency_Hz"], "mode": a["mode"],
            "flow_fast_m3_s": a["flow_sim_m3_s"], "flow_stepped_m3_s": b["flow_sim_m3_s"],
            "flow_difference": a["flow_sim_m3_s"] / b["flow_sim_m3_s"] - 1.0,
            "dy_fast_um": a["dy_um"], "dy_stepped_um": b["dy_um"],
            "wall_fast_s": a["wall_s"], "wall_stepped_s": b["wall_s"],
            "newton_iterations": a["newton_iterations"],
        })
    result = {
        "circuit": args.circuit, "load_N": fast[0]["load_N"],
        "sampling_phases": args.sampling_phases,
        "fast_table_wall_s": walls, "fast_table_first_s": walls[0],
        "fast_table_median_s": statistics.median(walls),
        "stepped_table_wall_s": stepped_wall,
        "stepped_source": "stored (MEASURED)" if args.skip_timestepping
        else f"run now, {args.steps_cycles:g} cycles",
        "max_abs_flow_difference": max(abs(c["flow_difference"]) for c in cases),
        "cases": cases,
    }
    if args.json:
        print(json.dumps(result))
        return
    print(f"Flow table, {result['circuit']} circuit, load {result['load_N']:g} N, "
          f"{len(cases)} cases; time stepping: {result['stepped_source']}")
    print(f"  fast path: median {result['fast_table_median_s']:.3f} s of {args.repeats} "
          f"tables (first {walls[0]:.3f} s)")
    if stepped_wall is not None:
        print(f"  time stepped (direct): {stepped_wall:.1f} s "
              f"({stepped_wall / result['fast_table_median_s']:.0f}x the fast path)")
    print(f"  {'f [Hz]':>6}  {'mode':<13}  {'q fast [m3/s]':>13}  {'q stepped':>11}  "
          f"{'diff':>7}  {'dy fast':>7}  {'dy step':>7}  {'fast [s]':>8}  {'step [s]':>8}  "
          f"{'Newton':>6}")
    for c in cases:
        step_wall = "-" if c["wall_stepped_s"] is None else f"{c['wall_stepped_s']:.2f}"
        print(f"  {c['frequency_Hz']:>6g}  {c['mode']:<13}  {c['flow_fast_m3_s']:>13.5e}  "
              f"{c['flow_stepped_m3_s']:>11.5e}  {100 * c['flow_difference']:>+6.2f}%  "
              f"{c['dy_fast_um']:>7.2f}  {c['dy_stepped_um']:>7.2f}  {c['wall_fast_s']:>8.3f}  "
              f"{step_wall:>8}  {c['newton_iterations']:>6d}")
    print(f"  largest |difference|: {100 * result['max_abs_flow_difference']:.2f} %")


if __name__ == "__main__":
    main()
