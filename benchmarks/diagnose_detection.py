"""Detection study of ``smeha diagnose`` (issue 11, "done when").

For clean data, each hidden cause alone and pairs of causes, over many seeds, at
several sample rates, noise levels and strengths, run :func:`smeha.diagnose.diagnose`
(default held-out runs; the workflow is not told the truth) and tabulate:

* **named**: the answer's causes are exactly the hidden ones (for clean data: ``none``);
* **misnamed**: a cause that is not hidden appears among the answer's causes (for clean
  data: any cause); a miss that answers ``none`` or ``unexplained`` is not misnamed;
* the held-out gain (paper over extended misfit) and how often it reaches 2.

The data come from the independent generator ``labsim`` (tests/labsim, its README;
only its public API is used) or, with ``--generator synthetic``, from the project's own
``smeha.synthetic`` (reported beside it, never alone). Prints a table, or JSON with
``--json``. Figures only: no timed asserts.

    python benchmarks/diagnose_detection.py [--generator labsim|synthetic] [--seeds 20]
        [--first-seed 0] [--rates 100,800,20000Hz] [--cases clean,singles,pairs]
        [--strengths 1] [--noises 0.05] [--workers 2] [--no-sense]
        [--formulation default|alt] [--json]

``--rates``: samples per period (``100``) or one fixed sample rate for every frequency
(``20000Hz``; labsim only). Every (case, rate, strength, noise) combination runs
``--seeds`` seeds from ``--first-seed``. Run with ``nice -n 10`` on a shared machine.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

TESTS = Path(__file__).resolve().parents[1] / "tests"

#: The pairs of the study, fixed before any result was seen: the two the issue names
#: (eddy-current diffusion with hysteresis, a delay with saturation) and three more
#: that mix a magnetic with a mechanical or sensor cause and a drift with a resonance.
PAIRS = (("eddy_current_diffusion", "rate_independent_hysteresis"),
         ("transport_delay", "magnetization_saturation"),
         ("mechanical_resonance", "thermal_drift"),
         ("magnetization_saturation", "eddy_current_diffusion"),
         ("transport_delay", "rate_independent_hysteresis"))


def _rate_kwargs(rate):
    if rate.endswith("Hz"):
        return {"sample_rate": float(rate[:-2])}
    return {"samples_per_cycle": int(rate)}


def _runs(generator, effects, seed, rate, strength, noise, sense=True,
          formulation="default"):
    """The runs of one dataset, without the truth."""
    if generator == "labsim":
        sys.path.insert(0, str(TESTS))
        from labsim_runs import runs

        return runs({e: strength for e in effects} or None, seed=seed, noise_um=noise,
                    sense_coil=sense, formulation=formulation, **_rate_kwargs(rate))
    if not sense or formulation != "default":
        raise ValueError("--no-sense and --formulation are labsim options")
    from smeha.synthetic import generate_runs

    if len(effects) > 1:
        raise ValueError("smeha.synthetic hides one effect at a time")
    kwargs = _rate_kwargs(rate)
    if "sample_rate" in kwargs:
        raise ValueError("smeha.synthetic samples a fixed number of points a period")
    out = generate_runs(effects[0] if effects else None, seed=seed, strength=strength,
                        noise_um=noise, **kwargs)
    for r in out:
        r.meta = {}
    return out


def _one(task):
    generator, effects, seed, rate, strength, noise, sense, formulation = task
    from smeha import diagnose

    t = time.perf_counter()
    runs = _runs(generator, effects, seed, rate, strength, noise, sense, formulation)
    t_gen = time.perf_counter() - t
    t = time.perf_counter()
    try:
        d = diagnose.diagnose(runs)
        out = {"cause": d.cause, "causes": d.causes, "gain": d.gain, "weak": d.weak,
               "form": d.form}
    except Exception as exc:  # a failure is a result of the study, reported as such
        out = {"cause": f"error: {type(exc).__name__}: {exc}", "causes": [], "gain": 1.0,
               "weak": False, "form": ""}
    return {"effects": list(effects), "seed": seed, "rate": rate, "strength": strength,
            "noise_um": noise, "sense_voltage": sense, "formulation": formulation,
            "seconds": time.perf_counter() - t, "generation_s": t_gen,
            **out}


def _cases(names, effects):
    out = []
    for name in names:
        if name == "clean":
            out.append(())
        elif name == "singles":
            out += [(e,) for e in effects]
        elif name == "pairs":
            out += list(PAIRS)
        else:  # one effect or a pair written a+b
            out.append(tuple(name.split("+")))
    return out


def summarise(results):
    """Rows of the table: one per (effects, rate, strength, noise)."""
    keys = sorted({(tuple(r["effects"]), r["rate"], r["strength"], r["noise_um"])
                   for r in results}, key=lambda k: (len(k[0]), k[0], k[1], -k[2], k[3]))
    rows = []
    for key in keys:
        sel = [r for r in results if (tuple(r["effects"]), r["rate"], r["strength"],
                                      r["noise_um"]) == key]
        truth = set(key[0])
        named = [r for r in sel if (set(r["causes"]) == truth if truth
                                    else r["cause"] == "none")]
        misnamed = [r for r in sel if set(r["causes"]) - truth]
        answers = {}
        for r in sel:
            label = "+".join(r["causes"]) or r["cause"]
            answers[label] = answers.get(label, 0) + 1
        gains = [r["gain"] for r in named] or [1.0]
        rows.append({"effects": list(key[0]), "rate": key[1], "strength": key[2],
                     "noise_um": key[3], "runs": len(sel),
                     "named_rate": len(named) / len(sel),
                     "misnamed": len(misnamed),
                     "median_gain_named": float(np.median(gains)),
                     "min_gain_named": float(np.min(gains)),
                     "gain_ge_2_rate": float(np.mean([r["gain"] >= 2.0 for r in named]))
                     if named else 0.0,
                     "weak": sum(r["weak"] for r in named),
                     "answers": answers,
                     "median_seconds": float(np.median([r["seconds"] for r in sel]))})
    return rows


def format_table(rows, generator, wall, sense=True, formulation="default"):
    head = (f"{'hidden effects':<56} {'rate':>8} {'str':>5} {'noise':>6} {'n':>3} "
            f"{'named':>6} {'mis':>4} {'gain med':>9} {'min':>7} {'>=2':>5}  answers")
    lines = [f"generator: {generator}" + ("" if sense else ", runs without sense voltage")
             + ("" if formulation == "default" else f", {formulation} formulations"),
             head, "-" * len(head)]
    for r in rows:
        label = " + ".join(r["effects"]) or "clean (none expected)"
        answers = ", ".join(f"{k} x{v}" for k, v in sorted(r["answers"].items(),
                                                            key=lambda kv: -kv[1]))
        lines.append(f"{label:<56.56} {r['rate']:>8} {r['strength']:>5g} {r['noise_um']:>6g} "
                     f"{r['runs']:>3} {100 * r['named_rate']:>5.0f}% {r['misnamed']:>4} "
                     f"{r['median_gain_named']:>9.3g} {r['min_gain_named']:>7.3g} "
                     f"{100 * r['gain_ge_2_rate']:>4.0f}%  {answers}")
    lines.append(f"wall time {wall:.0f} s, {sum(r['runs'] for r in rows)} diagnoses")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--generator", choices=("labsim", "synthetic"), default="labsim")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--rates", default="100,800,20000Hz")
    ap.add_argument("--cases", default="clean,singles,pairs")
    ap.add_argument("--strengths", default="1")
    ap.add_argument("--noises", default="0.05")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-sense", action="store_true",
                    help="labsim runs without the sense-coil voltage (B_m not measured)")
    ap.add_argument("--formulation", choices=("default", "alt"), default="default",
                    help="labsim's formulation of every effect: its first or its second "
                         "(tests/labsim/README.md, 'Second formulations')")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.generator == "labsim":
        sys.path.insert(0, str(TESTS))
        import labsim

        effects = tuple(labsim.EFFECTS)
    else:
        from smeha.synthetic import EFFECTS as effects
    cases = _cases(args.cases.split(","), effects)
    rates = args.rates.split(",")
    strengths = [float(s) for s in args.strengths.split(",")]
    noises = [float(s) for s in args.noises.split(",")]
    tasks = [(args.generator, case, seed, rate, strength if case else 1.0, noise,
              not args.no_sense, args.formulation)
             for case in cases for rate in rates for noise in noises
             for strength in (strengths if case else [1.0])
             for seed in range(args.first_seed, args.first_seed + args.seeds)]
    tasks = list(dict.fromkeys(tasks))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(_one, tasks, chunksize=1))
    wall = time.perf_counter() - t0
    rows = summarise(results)
    if args.json:
        json.dump({"generator": args.generator, "rows": rows, "results": results,
                   "wall_seconds": wall, "pairs": [list(p) for p in PAIRS],
                   "sense_voltage": not args.no_sense,
                   "formulation": args.formulation}, sys.stdout,
                  indent=1)
        sys.stdout.write("\n")
        return 0
    print(format_table(rows, args.generator, wall, sense=not args.no_sense,
                       formulation=args.formulation))
    return 0


if __name__ == "__main__":
    sys.exit(main())
