"""Detection study of the diagnosis workflow (issue #5, "done when").

For every hidden effect of :mod:`smeha.synthetic` (and clean data), over many
seeds, at the default noise, at lower noise and at smaller effect strengths,
run :func:`smeha.diagnose.diagnose` (default held-out runs; the workflow is
not told the effect) and tabulate the detection rate (cause named = truth;
for clean data, ``none``) and the median held-out gain (paper RMS / extended
RMS). Prints a table, or JSON with ``--json``. Figures only: no timed asserts.
For the causes with several formulations (``smeha.diagnose.FORMS``) the
table also counts which form won.

    python benchmarks/diagnose_detection.py [--seeds 20] [--workers 2] [--json]
        [--strengths 1,0.3,0.1,0.03] [--noises 0.05,0.01]

Settings: every noise level at strength 1, and every strength at the first
(default) noise level; clean data once per noise level.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def _one(task):
    effect, seed, strength, noise = task
    from smeha import diagnose
    from smeha.synthetic import generate_runs

    runs = generate_runs(effect, seed=seed, strength=strength, noise_um=noise)
    for r in runs:  # the workflow never sees the truth
        r.meta = {}
    t = time.perf_counter()
    d = diagnose.diagnose(runs)
    return {"effect": effect or "none", "seed": seed, "strength": strength, "noise_um": noise,
            "cause": d.cause, "form": d.extended.form, "gain": d.gain,
            "seconds": time.perf_counter() - t,
            "paper_um": d.paper.heldout_rms * 1e6, "extended_um": d.extended.heldout_rms * 1e6}


def main(argv=None):
    from smeha.synthetic import EFFECTS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--strengths", default="1,0.3,0.1,0.03")
    ap.add_argument("--noises", default="0.05,0.01")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    strengths = [float(s) for s in args.strengths.split(",")]
    noises = [float(s) for s in args.noises.split(",")]
    settings = [(1.0, n) for n in noises] + [(s, noises[0]) for s in strengths if s != 1.0]
    tasks = []
    for strength, noise in settings:
        effects = list(EFFECTS) + ([None] if strength == 1.0 else [])
        for e in effects:
            tasks += [(e, seed, strength, noise) for seed in range(args.seeds)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(_one, tasks, chunksize=2))
    rows = []
    for strength, noise in settings:
        for e in list(EFFECTS) + ["none"]:
            sel = [r for r in results if r["effect"] == e and r["strength"] == strength
                   and r["noise_um"] == noise]
            if not sel:
                continue
            named = [r for r in sel if r["cause"] == e]
            gains = [r["gain"] for r in sel]
            wrong = {}
            forms = {}
            for r in sel:
                if r["cause"] != e:
                    wrong[r["cause"]] = wrong.get(r["cause"], 0) + 1
                elif r["form"]:
                    forms[r["form"]] = forms.get(r["form"], 0) + 1
            rows.append({"effect": e, "strength": strength, "noise_um": noise, "runs": len(sel),
                         "detection_rate": len(named) / len(sel),
                         "median_gain": float(np.median(gains)),
                         "min_gain": float(np.min(gains)),
                         "gain_ge_2_rate": float(np.mean([g >= 2.0 for g in gains])),
                         "misnamed_as": wrong, "forms": forms,
                         "median_seconds": float(np.median([r["seconds"] for r in sel]))})
    if args.json:
        json.dump({"rows": rows, "wall_seconds": time.perf_counter() - t0}, sys.stdout,
                  indent=2)
        sys.stdout.write("\n")
        return 0
    head = (f"{'effect':<29} {'strength':>8} {'noise um':>8} {'n':>3} {'detect':>7} "
            f"{'med gain':>9} {'min gain':>9} {'gain>=2':>8}  misnamed as; forms")
    print(head)
    print("-" * len(head))
    for r in rows:
        wrong = ", ".join(f"{k} x{v}" for k, v in sorted(r["misnamed_as"].items()))
        if r["forms"]:
            wrong += ("; " if wrong else "") + "form " + ", ".join(
                f"{k} x{v}" for k, v in sorted(r["forms"].items()))
        print(f"{r['effect']:<29} {r['strength']:>8g} {r['noise_um']:>8g} {r['runs']:>3} "
              f"{100 * r['detection_rate']:>6.0f}% {r['median_gain']:>9.3g} "
              f"{r['min_gain']:>9.3g} {100 * r['gain_ge_2_rate']:>7.0f}%  {wrong}")
    fails = [r for r in rows if r["detection_rate"] < 0.9]
    print()
    print("detection below 90 %: " + ("; ".join(
        f"{r['effect']} at strength {r['strength']:g}, noise {r['noise_um']:g} um "
        f"({100 * r['detection_rate']:.0f} %)" for r in fails) or "none"))
    print(f"wall time {time.perf_counter() - t0:.0f} s, {len(tasks)} diagnoses")
    return 0


if __name__ == "__main__":
    sys.exit(main())
