"""Convergence of the co-simulated cylinder flow with the communication step.

Prints, for each mode and circuit at one frequency, the mean cylinder flow at
steps h, h/2, h/4 ... (the study's other settings at their defaults: the
compensator's 100 us samples, the plant's substeps) and the relative change
from each step to the next.

Usage: python benchmarks/cosim_convergence.py [--frequency 100] [--steps 1e-4,5e-5,2.5e-5]
       [--coupling force|displacement] [--backend fmu|direct] [--cycles 8]
       [--branch-rule control|demand] [--modes uncompensated,compensated] [--json]

The displacement port (``--coupling displacement``) holds the chamber force on
the rod over a step, a first-order error: give it steps of 40e-6 and below.
"""
from __future__ import annotations

import argparse
import json

from smeha.studies import flow
from system_models.defaults import DEFAULT_STEP


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frequency", type=float, default=100.0)
    ap.add_argument("--steps", default=f"{DEFAULT_STEP},{DEFAULT_STEP / 2},{DEFAULT_STEP / 4}")
    ap.add_argument("--coupling", choices=("force", "displacement"), default="force")
    ap.add_argument("--backend", choices=("fmu", "direct"), default="direct")
    ap.add_argument("--cycles", type=float, default=8.0)
    ap.add_argument("--branch-rule", choices=("control", "demand"), default="demand")
    ap.add_argument("--modes", default="uncompensated,compensated")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    steps = [float(s) for s in args.steps.split(",")]
    fmu = flow.ensure_fmu(quiet=True) if args.backend == "fmu" else None
    out = []
    for circuit in ("ideal", "realistic"):
        for mode in args.modes.split(","):
            rows = []
            for h in steps:
                case = flow.Case(args.frequency, mode, circuit=circuit, step=h,
                                      cycles=args.cycles, backend=args.backend,
                                      branch_rule=args.branch_rule, coupling=args.coupling)
                _, _, row = flow.run_case(case, fmu)
                rows.append(row)
            result = {"frequency_Hz": args.frequency, "mode": mode,
                      "branch_rule": args.branch_rule, "circuit": circuit,
                      "coupling": args.coupling, "steps_s": steps,
                      "flow_m3_s": [r["flow_sim_m3_s"] for r in rows],
                      "flow_ratio_eq": [r["flow_ratio"] for r in rows],
                      "delivered_fraction": [r["delivered_fraction"] for r in rows],
                      "wall_s": [r["wall_s"] for r in rows]}
            q = result["flow_m3_s"]
            result["relative_change"] = [abs(q[k + 1] - q[k]) / abs(q[k + 1])
                                         for k in range(len(q) - 1)]
            out.append(result)
            if not args.json:
                rule = f" ({args.branch_rule} rule)" if mode == "compensated" else ""
                print(f"{args.frequency:g} Hz {mode:<13} {circuit:<9} {args.coupling} port{rule}")
                for k, h in enumerate(steps):
                    change = ("" if k == 0 else
                              f"  change from {steps[k - 1] * 1e6:g} us: "
                              f"{result['relative_change'][k - 1] * 100:.3f} %")
                    print(f"  h = {h * 1e6:6.1f} us  q = {q[k]:.5e} m^3/s  "
                          f"q / f A_d dy_free = {result['delivered_fraction'][k]:.4f}  "
                          f"wall {result['wall_s'][k]:6.2f} s{change}")
    if args.json:
        print(json.dumps({"results": out}))


if __name__ == "__main__":
    main()
