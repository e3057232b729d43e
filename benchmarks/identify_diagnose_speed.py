"""Wall time of ``smeha identify`` and ``smeha diagnose`` on a lab-sized dataset.

The target: ``diagnose`` on 16 runs x 6 cycles x 800 samples a period within 25 s when the
answer holds the Preisach density and within 5 s otherwise, on two quiet cores. The dataset is labsim's default (tests/labsim, its README; the independent
generator): 8 frequencies (5-200 Hz) x 2 current amplitudes (0.6, 1 A), 6 cycles at 800
samples a period, sense voltage, noise 0.05 um, seeded, with one hidden effect (default
``eddy_current_diffusion``; ``--effect none`` for clean data, ``a+b`` for a pair).

Timed, ``--repeats`` times each (default 3), the median printed:

* ``identify``: :func:`smeha.identify.identify` on all runs, as the CLI;
* ``diagnose``: :func:`smeha.diagnose.diagnose` on all runs (default held-out runs);
* ``cli``: ``smeha diagnose DATA.csv --json`` end to end in a subprocess (interpreter
  start, imports, reading and checking the CSV, diagnosis, JSON), once unless
  ``--cli-repeats`` says otherwise.

Each figure is wall time and the CPU time of the process and of its finished children
(the diagnosis' worker processes, the CLI's subprocess): on a shared machine the CPU
time grows far less with the others' load than the wall time. Figures only, no timed
asserts. BLAS pinned to one thread (the target's "on one core"); on a shared machine
read the figures as upper bounds.

    python benchmarks/identify_diagnose_speed.py [--repeats 3] [--cli-repeats 1]
        [--effect eddy_current_diffusion] [--samples-per-cycle 800] [--cycles 6]
        [--seed 3] [--workers N] [--formulations EFFECT=NAME,...] [--json]
"""
from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

TESTS = Path(__file__).resolve().parents[1] / "tests"


def dataset(effect, seed, cycles, samples_per_cycle, formulations=None):
    """labsim's dataset (the truth stays with it) and its runs as smeha reads them;
    ``formulations`` {effect: name} as labsim's ``make_dataset``."""
    sys.path.insert(0, str(TESTS))
    import labsim
    from labsim_runs import smeha_runs

    effects = None if effect == "none" else {e: 1.0 for e in effect.split("+")}
    ds = labsim.make_dataset(effects, seed=seed, cycles=cycles,
                             samples_per_cycle=samples_per_cycle, formulations=formulations)
    return ds, smeha_runs(ds)


def _cpu():
    """CPU seconds of this process and of its finished children (a pool's workers)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _timed(fn, cpu=None):
    """(wall seconds, result) of ``fn()``; ``cpu``, a list, gains its CPU seconds."""
    t, c = time.perf_counter(), _cpu()
    out = fn()
    if cpu is not None:
        cpu.append(_cpu() - c)
    return time.perf_counter() - t, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cli-repeats", type=int, default=1)
    ap.add_argument("--effect", default="eddy_current_diffusion",
                    help="hidden effect of labsim ('none', one name, or 'a+b')")
    ap.add_argument("--samples-per-cycle", type=int, default=800)
    ap.add_argument("--cycles", type=int, default=6)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--workers", type=int, default=None,
                    help="diagnose's worker processes (default smeha.pool.default_workers)")
    ap.add_argument("--formulations", default="", metavar="EFFECT=NAME,...",
                    help="labsim's formulation of named effects (tests/labsim/README.md), "
                         "e.g. rate_independent_hysteresis=preisach_random")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    forms = dict(kv.split("=", 1) for kv in args.formulations.split(",") if kv) or None
    from smeha import diagnose, identify

    load_start = os.getloadavg()[0]
    t_gen, (ds, runs) = _timed(lambda: dataset(args.effect, args.seed, args.cycles,
                                               args.samples_per_cycle, forms))
    walls = {"identify": [], "diagnose": [], "cli": []}
    cpus = {"identify": [], "diagnose": [], "cli": []}
    result = None
    cli_cause = None
    for _ in range(args.repeats):
        dt, _ = _timed(lambda: identify.identify(runs), cpus["identify"])
        walls["identify"].append(dt)
        dt, result = _timed(lambda: diagnose.diagnose(runs, workers=args.workers),
                            cpus["diagnose"])
        walls["diagnose"].append(dt)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "speed.csv"
        ds.write_csv(path)
        script = Path(sys.executable).with_name("smeha")
        command = ([str(script)] if script.is_file() else
                   [sys.executable, "-c", "import sys; from smeha.cli import main; "
                                          "sys.exit(main())"])
        for _ in range(args.cli_repeats):
            dt, proc = _timed(lambda: subprocess.run(
                command + ["diagnose", str(path), "--json"]
                + ([] if args.workers is None else ["--workers", str(args.workers)]),
                capture_output=True, text=True), cpus["cli"])
            if proc.returncode != 0:
                raise SystemExit(f"smeha diagnose failed ({proc.returncode}):\n{proc.stderr}")
            walls["cli"].append(dt)
            cli_cause = json.loads(proc.stdout)["causes"]
    med = {k: statistics.median(v) for k, v in walls.items() if v}
    med_cpu = {k: statistics.median(v) for k, v in cpus.items() if v}
    n_samples = sum(r.time.size for r in runs)
    out = {
        "dataset": {"generator": "labsim", "runs": len(runs), "cycles": args.cycles,
                    "samples_per_cycle": args.samples_per_cycle, "samples": n_samples,
                    "effect": args.effect, "seed": args.seed, "formulations": forms,
                    "generation_s": t_gen},
        "wall_s": walls, "median_s": med, "cpu_s": cpus, "median_cpu_s": med_cpu,
        "load_average_1min": {"start": load_start, "end": os.getloadavg()[0]},
        "diagnosis": {"cause": result.cause, "causes": result.causes, "gain": result.gain,
                      "cli_causes": cli_cause},
        "python": sys.version.split()[0],
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    d = out["dataset"]
    print(f"labsim: {d['runs']} runs x {d['cycles']} cycles x {d['samples_per_cycle']} samples "
          f"a period ({n_samples} samples), effect {d['effect']}, seed {d['seed']}, "
          f"formulations {forms or 'labsim default'} "
          f"(generated in {t_gen:.1f} s); diagnose's workers {args.workers or 'default'}, "
          f"load average (1 min) {load_start:.2f} at the start, {os.getloadavg()[0]:.2f} "
          "at the end")
    for k, label in (("identify", "identify (function)"), ("diagnose", "diagnose (function)"),
                     ("cli", "smeha diagnose --json (subprocess)")):
        if k in med:
            runs_s = ", ".join(f"{v:.2f}" for v in walls[k])
            print(f"  {label:<36} median {med[k]:7.2f} s wall, {med_cpu[k]:7.2f} s CPU "
                  f"({runs_s})")
    print(f"  diagnosis: causes {result.causes or result.cause}, held-out gain "
          f"{result.gain:.3g}; CLI causes {cli_cause}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
