"""Detection study of ``smeha diagnose``.

For clean data, each hidden cause alone and pairs of causes, over many seeds, at
several sample rates, noise levels and strengths, run :func:`smeha.diagnose.diagnose`
(default held-out runs; the workflow is not told the truth) and tabulate:

* **named**: the answer's causes are exactly the hidden ones (for clean data: ``none``);
* **misnamed**: a cause that is not hidden appears among the answer's causes (for clean
  data: any cause); a miss that answers ``none`` or ``unexplained`` is not misnamed;
* the held-out gain (paper over extended misfit) and how often it reaches 2;
* with ``--cases outside`` each cause beside each effect outside the six
  (labsim.OUTSIDE_EFFECTS): named when the known cause is named and nothing else; the
  share left unexplained (the report's remainder) is tabulated.

The data come from the independent generator ``labsim`` (tests/labsim, its README;
only its public API is used) or, with ``--generator synthetic``, from the project's own
``smeha.synthetic`` (reported beside it, never alone). Prints a table, or JSON with
``--json``. Figures only: no timed asserts.

    python benchmarks/diagnose_detection.py [--generator labsim|synthetic] [--seeds 20]
        [--first-seed 0] [--rates 100,800,20000Hz] [--cases clean,singles,pairs|allpairs,outside]
        [--strengths 1] [--noises 0.05] [--workers 2] [--no-sense]
        [--formulation default|alt] [--formulations EFFECT=NAME,...]
        [--low-frequency-cycles 3] [--start-in-transient] [--log FILE.jsonl]
        [--json]
    python benchmarks/diagnose_detection.py --markdown STUDY.json[.gz]
    python benchmarks/diagnose_detection.py --summary STUDY.json.gz,LOG.jsonl,... [--latest]

The studies quoted in docs/DIAGNOSE-detection.md are kept in benchmarks/detection/ (gzipped JSON).

``--rates``: samples per period (``100``) or one fixed sample rate for every frequency
(``20000Hz``; labsim only). Every (case, rate, strength, noise) combination runs
``--seeds`` seeds from ``--first-seed``. Run with ``nice -n 10`` on a shared machine.
"""
from __future__ import annotations

import argparse
import functools
import gzip
import itertools
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

TESTS = Path(__file__).resolve().parents[1] / "tests"

#: The pairs of the study, fixed before any result was seen: the two required
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


def _runs(generator, effects, seed, rate, strength, noise, sense=True, options=()):
    """The runs of one dataset, without the truth; ``options``: (name, value) pairs of
    labsim's make_dataset (formulation, low_frequency_cycles, start_in_transient)."""
    if generator == "labsim":
        sys.path.insert(0, str(TESTS))
        from labsim_runs import runs

        opts = {k: (dict(v) if k == "formulations" else v) for k, v in options}
        return runs({e: strength for e in effects} or None, seed=seed, noise_um=noise,
                    sense_coil=sense, **opts, **_rate_kwargs(rate))
    if not sense or options:
        raise ValueError("--no-sense, --formulation and the record options are labsim's")
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


@functools.lru_cache(maxsize=1)
def _code_version() -> str:
    """The commit the study ran (``git describe --always --dirty``), "unknown" outside git."""
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=TESTS.parent,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _later_shares(d) -> dict:
    """{cause: the decision's share} for each named cause after the first: the fraction of
    the paper's held-out excess, in the channels it acts on, that adding it removed
    (smeha.diagnose.rules.share; the model before it: the best-ranked fit of the causes
    named before it)."""
    from smeha.diagnose import rules

    fits = list(d.fits) + list(d.combinations) + [d.extended]
    out = {}
    for i, cause in enumerate(d.causes[1:], start=1):
        before = [f for f in fits if set(f.causes) == set(d.causes[:i])]
        after = [f for f in fits if set(f.causes) == set(d.causes[:i + 1])]
        if before and after:
            b = min(before, key=lambda f: f.total_score)
            a = min(after, key=lambda f: f.total_score)
            member = next(m for m in a.candidate.members if m.cause == cause)
            out[cause] = rules.share(d.paper, b, a, member)
    return out


def _one(task):
    generator, effects, seed, rate, strength, noise, sense, options = task
    from smeha import diagnose
    from smeha.diagnose.report import remainder_report

    t = time.perf_counter()
    runs = _runs(generator, effects, seed, rate, strength, noise, sense, options)
    t_gen = time.perf_counter() - t
    t = time.perf_counter()
    try:
        d = diagnose.diagnose(runs, workers=1)  # the study's own workers run the datasets
        rem = remainder_report(d)
        out = {"cause": d.cause, "causes": d.causes, "gain": d.gain, "weak": d.weak,
               "form": d.form,
               "explained_fraction": rem["explained_fraction"] if rem else {},
               "later_shares": _later_shares(d),
               "unexplained_fraction": rem["unexplained_fraction"] if rem else 0.0,
               "remainder": rem["summary"] if rem else "",
               # how the answer was reached: two causes named at once (decision._pair_first)
               # and why no further cause was named (decision.Selection.stopped)
               "together": any(e.startswith("named together") for e in d.evidence),
               "stopped": d.stopped}
    except Exception as exc:  # a failure is a result of the study, reported as such
        out = {"cause": f"error: {type(exc).__name__}: {exc}", "causes": [], "gain": 1.0,
               "weak": False, "form": "", "explained_fraction": {}, "later_shares": {},
               "unexplained_fraction": 0.0, "remainder": "", "together": False, "stopped": ""}
    return {"code": _code_version(), "effects": list(effects), "seed": seed, "rate": rate,
            "strength": strength, "noise_um": noise, "sense_voltage": sense,
            "labsim_options": dict(options),
            "seconds": time.perf_counter() - t, "generation_s": t_gen,
            **out}


def _cases(names, effects, outside=()):
    out = []
    for name in names:
        if name == "clean":
            out.append(())
        elif name == "singles":
            out += [(e,) for e in effects]
        elif name == "pairs":
            out += list(PAIRS)
        elif name == "allpairs":  # every pair of the causes
            out += list(itertools.combinations(effects, 2))
        elif name == "outside":  # each cause with each effect outside the six (labsim)
            out += [(e, o) for e in effects for o in outside]
        else:  # one effect or a pair written a+b
            out.append(tuple(name.split("+")))
    return out


def _verdict(r, outside):
    """"named", "misnamed" (a cause not hidden among the answer's; for clean data any
    cause) or "missed" (none, unexplained or only some of the hidden causes). Clean data
    are named by ``none``; an effect outside the candidates alone by ``unexplained`` (or
    ``none``, where it is within noise)."""
    truth = set(r["effects"]) - set(outside)
    causes = set(r["causes"])
    if causes - truth:
        return "misnamed"
    if truth:
        return "named" if causes == truth else "missed"
    right = ("none", "unexplained") if r["effects"] else ("none",)
    return "named" if r["cause"] in right else "missed"


def summarise(results, outside=()):
    """Rows of the table: one per (effects, rate, strength, noise). An effect in
    ``outside`` (labsim.OUTSIDE_EFFECTS) is not one of the causes: its case is named when
    the known causes are, nothing else."""
    keys = sorted({(tuple(r["effects"]), r["rate"], r["strength"], r["noise_um"])
                   for r in results}, key=lambda k: (len(k[0]), k[0], k[1], -k[2], k[3]))
    rows = []
    for key in keys:
        sel = [r for r in results if (tuple(r["effects"]), r["rate"], r["strength"],
                                      r["noise_um"]) == key]
        truth = set(key[0]) - set(outside)
        verdicts = [_verdict(r, outside) for r in sel]
        named = [r for r, v in zip(sel, verdicts) if v == "named"]
        misnamed = [r for r, v in zip(sel, verdicts) if v == "misnamed"]
        answers = {}
        for r in sel:
            label = "+".join(r["causes"]) or r["cause"]
            answers[label] = answers.get(label, 0) + 1
        gains = [r["gain"] for r in named] or [1.0]
        rows.append({"effects": list(key[0]), "known": sorted(truth), "rate": key[1],
                     "strength": key[2], "noise_um": key[3], "runs": len(sel),
                     "named_rate": len(named) / len(sel),
                     "misnamed": len(misnamed),
                     "median_gain_named": float(np.median(gains)),
                     "min_gain_named": float(np.min(gains)),
                     "gain_ge_2_rate": float(np.mean([r["gain"] >= 2.0 for r in named]))
                     if named else 0.0,
                     "weak": sum(r["weak"] for r in named),
                     "answers": answers,
                     "median_unexplained_fraction": float(np.median(
                         [r.get("unexplained_fraction", 0.0) for r in sel])),
                     "median_seconds": float(np.median([r["seconds"] for r in sel]))})
    return rows


def format_table(rows, generator, wall, sense=True, options=()):
    head = (f"{'hidden effects':<56} {'rate':>8} {'str':>5} {'noise':>6} {'n':>3} "
            f"{'named':>6} {'mis':>4} {'gain med':>9} {'min':>7} {'>=2':>5}  answers")
    lines = [f"generator: {generator}" + ("" if sense else ", runs without sense voltage")
             + "".join(f", {k} = {v}" for k, v in options),
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


def _rate_label(rate):
    if rate.endswith("Hz"):
        return f"{float(rate[:-2]) / 1e3:g} kHz, every f"
    return f"{rate} a period"


def markdown_table(study) -> str:
    """A saved study (``--json`` output) as the Markdown table of docs/DIAGNOSE-detection.md: one
    row per hidden case, one column per sample clock."""
    rows = study["rows"]
    rates = list(dict.fromkeys(r["rate"] for r in rows))
    cases = list(dict.fromkeys((tuple(r["effects"]), r["strength"], r["noise_um"])
                               for r in rows))
    out = ["| hidden | strength | noise [um] | "
           + " | ".join(_rate_label(r) for r in rates) + " |",
           "|" + "---|" * (3 + len(rates))]
    for case in cases:
        first = next(r for r in rows
                     if (tuple(r["effects"]), r["strength"], r["noise_um"]) == case)
        truth = set(first.get("known", case[0]))
        cells = []
        for rate in rates:
            sel = [r for r in rows if r["rate"] == rate
                   and (tuple(r["effects"]), r["strength"], r["noise_um"]) == case]
            if not sel:
                cells.append("")
                continue
            r = sel[0]
            cell = f"{100 * r['named_rate']:.0f} % of {r['runs']}, {r['misnamed']} misnamed"
            if truth and r["named_rate"] > 0:
                cell += (f"; gain {r['median_gain_named']:.3g} "
                         f"(min {r['min_gain_named']:.3g})")
            if set(case[0]) - truth:  # an outside effect: what stays unexplained
                cell += f"; unexplained {100 * r.get('median_unexplained_fraction', 0):.0f} %"
            other = [f"{a} x{n}" for a, n in r["answers"].items()
                     if (set(a.split("+")) != truth if truth else a != "none")]
            if other:
                cell += "; " + ", ".join(other)
            cells.append(cell)
        out.append(f"| {' + '.join(case[0]) or 'clean'} | {case[1]:g} | {case[2]:g} | "
                   + " | ".join(cells) + " |")
    return "\n".join(out)


def _open_text(path):
    """A saved study or log for reading, gzipped (``.gz``) or not."""
    return (gzip.open if path.endswith(".gz") else open)(path, "rt")


def _load_results(paths):
    """The results of saved studies (``--json`` output, gzipped or not) and ``--log``
    files (one JSON line a dataset), together."""
    out = []
    for path in paths:
        with _open_text(path) as fh:
            if ".jsonl" in path:
                out += [json.loads(line) for line in fh if line.strip()]
            else:
                out += json.load(fh)["results"]
    return out


def _commit_times() -> dict:
    """{full hash: commit time [s since the epoch]} of every commit in this repository's
    history ({} outside git)."""
    try:
        out = subprocess.run(["git", "log", "--all", "--format=%H %ct"], cwd=TESTS.parent,
                             capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {}
    return {full: int(t) for full, t in (line.split() for line in out.splitlines())}


def latest(results) -> list:
    """Of several results of one dataset (its case, seed, clock, strength, noise, sense
    voltage and generator options), the one of the newest code: the latest commit time
    of its ``code`` (``git describe`` output; a code not in this history counts as the
    oldest, and of equal times the later result in ``results`` is kept)."""
    times = _commit_times()

    @functools.lru_cache(maxsize=None)
    def commit_time(code):
        return next((t for h, t in times.items() if code and h.startswith(code)), -1)

    def when(r):
        return commit_time(r.get("code", "").removesuffix("-dirty").split("-g")[-1])
    newest = {}
    for r in results:
        key = (tuple(sorted(r["effects"])), r["seed"], str(r["rate"]), r["strength"],
               r["noise_um"], r.get("sense_voltage", True),
               json.dumps(r.get("labsim_options") or {}, sort_keys=True))
        t = when(r)
        if key not in newest or t >= newest[key][0]:
            newest[key] = (t, r)
    return [r for _, r in newest.values()]


def summary_table(results, outside) -> str:
    """The detection targets' table of the results of several studies: per generator
    (labsim's formulations), sense voltage and kind of case, the share named at each
    sample clock, the misnamed ones counted, then every dataset not named."""
    def group(r):
        forms = dict((r.get("labsim_options") or {}).get("formulations") or ())
        gen = "textbook forms" if forms else "first forms"
        effects = r["effects"]
        known = [e for e in effects if e not in outside]
        kind = ("clean" if not effects else "outside effect alone" if not known
                else "outside effect + " + known[0] if len(known) < len(effects)
                else effects[0] if len(effects) == 1 else "pairs of two causes")
        if r.get("strength", 1.0) != 1.0:  # the threshold studies apart from the others
            kind += f" at strength {r['strength']:g}"
        return gen, r.get("sense_voltage", True), kind
    rates = list(dict.fromkeys(r["rate"] for r in results))
    keys = list(dict.fromkeys(group(r) for r in results))
    out = ["| labsim | sense voltage | hidden | " + " | ".join(_rate_label(x) for x in rates)
           + " |", "|" + "---|" * (3 + len(rates))]
    for key in keys:
        cells = []
        for rate in rates:
            sel = [r for r in results if group(r) == key and r["rate"] == rate]
            if not sel:
                cells.append("")
                continue
            v = [_verdict(r, outside) for r in sel]
            cell = f"{v.count('named')}/{len(sel)} ({100 * v.count('named') / len(sel):.0f} %)"
            if v.count("misnamed"):
                cell += f", **{v.count('misnamed')} misnamed**"
            cells.append(cell)
        out.append(f"| {key[0]} | {'yes' if key[1] else 'no'} | {key[2]} | "
                   + " | ".join(cells) + " |")
    misses = [r for r in results if _verdict(r, outside) != "named"]
    if misses:
        out += ["", "Not named:", ""]
        for r in sorted(misses, key=lambda r: (group(r), r["effects"], r["rate"], r["seed"])):
            answer = "+".join(r["causes"]) or r["cause"]
            out.append(f"- {group(r)[0]}, {'with' if group(r)[1] else 'without'} B, "
                       f"{' + '.join(r['effects']) or 'clean'}, {r['rate']}, seed "
                       f"{r['seed']}: {_verdict(r, outside)} as {answer}"
                       + (f" (gain {r['gain']:.3g})" if r["causes"] else ""))
    return "\n".join(out)


def _parser() -> argparse.ArgumentParser:
    """The command line of this study."""
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
    ap.add_argument("--formulations", default="", metavar="EFFECT=NAME,...",
                    help="labsim's formulation of named effects (tests/labsim/README.md, "
                         "e.g. rate_independent_hysteresis=general_preisach)")
    ap.add_argument("--low-frequency-cycles", type=int, default=None, metavar="N",
                    help="labsim records N cycles of the runs below 10 Hz (default: 6)")
    ap.add_argument("--start-in-transient", action="store_true",
                    help="labsim records from the drive's switch-on, transient included")
    ap.add_argument("--log", metavar="FILE.jsonl",
                    help="also append each dataset's result to FILE as it finishes")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--markdown", metavar="STUDY.json",
                    help="print a saved study (--json output) as a Markdown table and exit")
    ap.add_argument("--summary", metavar="STUDY[,STUDY...]",
                    help="print the summary table of saved studies and --log files "
                         "together, and every dataset not named, and exit")
    ap.add_argument("--latest", action="store_true",
                    help="with --summary: of a dataset run by several codes, only the "
                         "result of the newest commit")
    return ap


def main(argv=None):
    args = _parser().parse_args(argv)
    if args.summary:
        sys.path.insert(0, str(TESTS))
        import labsim

        results = _load_results(args.summary.split(","))
        print(summary_table(latest(results) if args.latest else results,
                            labsim.OUTSIDE_EFFECTS))
        return 0
    if args.markdown:
        with _open_text(args.markdown) as fh:
            print(markdown_table(json.load(fh)))
        return 0
    if args.generator == "labsim":
        sys.path.insert(0, str(TESTS))
        import labsim

        effects, outside = tuple(labsim.EFFECTS), tuple(labsim.OUTSIDE_EFFECTS)
    else:
        from smeha.synthetic import EFFECTS as effects
        outside = ()
    cases = _cases(args.cases.split(","), effects, outside)
    rates = args.rates.split(",")
    strengths = [float(s) for s in args.strengths.split(",")]
    noises = [float(s) for s in args.noises.split(",")]
    options = tuple((k, v) for k, v in (
        ("formulation", args.formulation if args.formulation != "default" else None),
        ("formulations", tuple(tuple(kv.split("=", 1)) for kv in args.formulations.split(",")
                               if kv) or None),
        ("low_frequency_cycles", args.low_frequency_cycles),
        ("start_in_transient", args.start_in_transient or None)) if v is not None)
    tasks = [(args.generator, case, seed, rate, strength if case else 1.0, noise,
              not args.no_sense, options)
             for case in cases for rate in rates for noise in noises
             for strength in (strengths if case else [1.0])
             for seed in range(args.first_seed, args.first_seed + args.seeds)]
    tasks = list(dict.fromkeys(tasks))
    t0 = time.perf_counter()
    results = _run(tasks, args.workers, args.log)
    wall = time.perf_counter() - t0
    rows = summarise(results, outside)
    if args.json:
        json.dump({"generator": args.generator, "rows": rows, "results": results,
                   "wall_seconds": wall, "pairs": [list(p) for p in PAIRS],
                   "sense_voltage": not args.no_sense,
                   "labsim_options": dict(options)}, sys.stdout,
                  indent=1)
        sys.stdout.write("\n")
        return 0
    print(format_table(rows, args.generator, wall, sense=not args.no_sense,
                       options=options))
    return 0


def _run(tasks, workers, log_path):
    """Every task's result on ``workers`` processes, each also appended to ``log_path`` (one
    JSON line a dataset) as it finishes."""
    results = []
    log = open(log_path, "a") if log_path else None
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for res in pool.map(_one, tasks, chunksize=1):
            results.append(res)
            if log is not None:
                log.write(json.dumps(res) + "\n")
                log.flush()
    if log is not None:
        log.close()
    return results


if __name__ == "__main__":
    sys.exit(main())
