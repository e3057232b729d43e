"""The joint steps' bounded least squares: smeha's active set against scipy's bvls.

:func:`smeha.diagnose.linearfit._joint` solves a bounded linear least-squares problem at
each damped Gauss-Newton step of a fit that holds the Preisach density.
:func:`smeha.diagnose.boxsolve.bounded_least_squares` solves it in its normal equations;
scipy's ``lsq_linear(method="bvls")`` (Stark & Parker 1995) is the reference it replaced.
This benchmark diagnoses one labsim dataset (tests/labsim, the independent generator;
default: the Preisach density of ``preisach_random``, seed 103, 800 samples a period),
records every bounded problem the joint steps pose (up to ``--problems``), and solves
each again with both, in one process:

* the time of each solver over all problems and their ratio;
* the largest relative difference of the objectives ||A v - b||^2 (negative: smeha's is
  lower) and of the solutions (over each solution's largest entry).

Figures only, no asserts. BLAS pinned to one thread.

    python benchmarks/bounded_solve.py [--effect rate_independent_hysteresis] [--seed 103]
        [--samples-per-cycle 800] [--problems 200] [--json]
"""
from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "fmu_src"), str(ROOT)]


def record_problems(effects, seed, samples_per_cycle, limit):
    """The bounded problems (a, b, lower, upper) of one diagnosis, up to ``limit``."""
    from labsim_runs import TEXTBOOK_FORMULATIONS, runs

    from smeha import diagnose
    from smeha.diagnose import linearfit

    data = runs({e: 1.0 for e in effects}, seed=seed, noise_um=0.05,
                samples_per_cycle=samples_per_cycle, formulations=TEXTBOOK_FORMULATIONS)
    problems = []
    solve = linearfit.bounded_least_squares

    def recording(a, b, lower, upper):
        if len(problems) < limit:
            problems.append((np.array(a), np.array(b), np.array(lower), np.array(upper)))
        return solve(a, b, lower, upper)

    linearfit.bounded_least_squares = recording
    try:
        diagnose.diagnose(data, workers=1)
    finally:
        linearfit.bounded_least_squares = solve
    return problems


def compare(problems):
    """Times and differences of the two solvers on ``problems`` (module docstring)."""
    from scipy.optimize import lsq_linear

    from smeha.diagnose.boxsolve import bounded_least_squares

    t0 = time.perf_counter()
    ref = [lsq_linear(a, b, bounds=(lo, hi), method="bvls").x for a, b, lo, hi in problems]
    t1 = time.perf_counter()
    new = [bounded_least_squares(a, b, lo, hi) for a, b, lo, hi in problems]
    t2 = time.perf_counter()
    objective, solution = [], []
    for (a, b, _, _), x, v in zip(problems, ref, new):
        f_ref, f_new = float(np.sum((a @ x - b) ** 2)), float(np.sum((a @ v - b) ** 2))
        objective.append((f_new - f_ref) / max(f_ref, 1e-300))
        solution.append(float(np.max(np.abs(v - x)) / max(np.max(np.abs(x)), 1e-300)))
    worst = max(objective, key=abs) if objective else 0.0
    return {"problems": len(problems),
            "shape": list(problems[0][0].shape) if problems else [],
            "bvls_s": round(t1 - t0, 3), "active_set_s": round(t2 - t1, 3),
            "ratio": round((t1 - t0) / max(t2 - t1, 1e-9), 2),
            "objective_rel_diff_extreme": worst,
            "solution_rel_diff_max": max(solution) if solution else 0.0}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--effect", default="rate_independent_hysteresis",
                    help="labsim effect(s) hidden, a+b for a pair")
    ap.add_argument("--seed", type=int, default=103)
    ap.add_argument("--samples-per-cycle", type=int, default=800)
    ap.add_argument("--problems", type=int, default=200)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    problems = record_problems(args.effect.split("+"), args.seed, args.samples_per_cycle,
                               args.problems)
    out = {"effect": args.effect, "seed": args.seed,
           "samples_per_cycle": args.samples_per_cycle, **compare(problems)}
    if args.json:
        print(json.dumps(out))
        return
    for key, value in out.items():
        print(f"{key:28s} {value}")


if __name__ == "__main__":
    main()
