"""Convergence of the compensated drive in the compensator's sample period T_c.

For each root rule of the compensator (``gmt.inverse``: Figure 9's "control", the
"demand" rule that is the default) and each T_c, prints at 50 and 100 Hz the free
transducer's compensated stroke dy' (eq 41 window: u's minimum to its maximum, the
transducer alone, :func:`smeha.studies.flow.free_dy`) and the cylinder flow of the
ideal circuit co-simulated through the transducer FMU (``smeha flow --ideal --step h``
with h = min(10 us, T_c), so that u changes at every compensator sample), with each
figure's departure from the finest T_c's.

Usage: python benchmarks/compensator_convergence.py [--periods 1e-4,5e-5,2e-5,1e-5,5e-6]
       [--frequencies 50,100] [--rules control,demand] [--no-cosim] [--json]
"""
from __future__ import annotations

import argparse
import json
import time

from smeha.studies import flow


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", default="1e-4,5e-5,2e-5,1e-5,5e-6")
    ap.add_argument("--frequencies", default="50,100")
    ap.add_argument("--rules", default="control,demand")
    ap.add_argument("--no-cosim", action="store_true", help="the free transducer only")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    periods = [float(p) for p in args.periods.split(",")]
    fmu = None if args.no_cosim else flow.ensure_fmu(quiet=True)
    out = []
    for rule in args.rules.split(","):
        for f in (float(x) for x in args.frequencies.split(",")):
            rows = []
            for tc in periods:
                row = {"rule": rule, "frequency_Hz": f, "compensator_period_s": tc,
                       "dy_free_um": 1e6 * flow.free_dy(f, "compensated", rule,
                                                        compensator_period=tc)}
                if fmu is not None:
                    case = flow.Case(f, "compensated", circuit="ideal", step=min(1e-5, tc),
                                     branch_rule=rule, compensator_period=tc)
                    wall = time.perf_counter()
                    row["flow_m3_s"] = flow.run_case(case, fmu)[2]["flow_sim_m3_s"]
                    row["wall_s"] = time.perf_counter() - wall
                rows.append(row)
            for row in rows:  # against the finest sample period's
                for key, name in (("dy_free_um", "dy_free"), ("flow_m3_s", "flow")):
                    if key in row:
                        row[name + "_vs_finest"] = row[key] / rows[-1][key] - 1.0
            out.extend(rows)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"{'rule':<8} {'f [Hz]':>6} {'T_c [s]':>8} {'dy free [um]':>12} {'vs finest':>9} "
          f"{'flow [m3/s]':>11} {'vs finest':>9}")
    for r in out:
        q = ("" if "flow_m3_s" not in r
             else f"{r['flow_m3_s']:>11.4e} {100 * r['flow_vs_finest']:>+8.2f}%")
        print(f"{r['rule']:<8} {r['frequency_Hz']:>6g} {r['compensator_period_s']:>8.0e} "
              f"{r['dy_free_um']:>12.2f} {100 * r['dy_free_vs_finest']:>+8.2f}% {q}")


if __name__ == "__main__":
    main()
