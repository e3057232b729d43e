"""Wall time of `smeha identify` and `smeha diagnose` on a lab-sized dataset.

The speed issue asks for both on "6 runs x 10 cycles x 2000 samples". This
script reads that as **2000 samples per cycle** (20 000 samples per run,
120 000 in all): the more demanding reading, and the natural one for lab data
sampled at a fixed number of points per period. The dataset is generated,
seeded, by :func:`smeha.synthetic.generate_runs`: 3 frequencies (5, 50 and
200 Hz) x 2 current amplitudes (0.5 and 1 A), with the sensing-coil voltage
(diagnose needs it) and one hidden effect (default ``eddy_current_diffusion``,
``--effect none`` for the paper's model alone). With 3 frequencies diagnose
holds out the 50 Hz runs and trains on the other 4.

Timed, ``--repeats`` times each (default 3), the median printed:

* ``identify``: :func:`smeha.identify.identify` on all 6 runs, as the CLI;
* ``diagnose``: :func:`smeha.diagnose.diagnose` on all 6 runs (default held-out
  runs), as the CLI;
* ``cli``: ``smeha diagnose DATA.csv --json`` end to end in a subprocess
  (interpreter start, imports, reading the CSV, diagnosis, JSON), once
  unless ``--cli-repeats`` says otherwise. The ``smeha`` script next to the
  running interpreter is used; without it, ``python -c`` calls
  :func:`smeha.cli.main`.

Figures only, no timed asserts. One process, BLAS pinned to one thread (the
issue's "on one core").

    python benchmarks/identify_diagnose_speed.py [--repeats 3] [--cli-repeats 1]
        [--effect eddy_current_diffusion] [--samples-per-cycle 2000] [--cycles 10]
        [--seed 3] [--json]
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

FREQUENCIES = (5.0, 50.0, 200.0)
AMPLITUDES = (0.5, 1.0)


def dataset(effect, seed, cycles, samples_per_cycle):
    """The 6 runs, truth removed (the workflow never sees it)."""
    from smeha.synthetic import generate_runs

    runs = generate_runs(effect, seed=seed, frequencies=FREQUENCIES, amplitudes=AMPLITUDES,
                         cycles=cycles, samples_per_cycle=samples_per_cycle)
    for r in runs:
        r.meta = {}
    return runs


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cli-repeats", type=int, default=1)
    ap.add_argument("--effect", default="eddy_current_diffusion",
                    help="hidden effect of smeha.synthetic, or 'none'")
    ap.add_argument("--samples-per-cycle", type=int, default=2000)
    ap.add_argument("--cycles", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from smeha import diagnose, identify
    from smeha.measured import write_measurements

    effect = None if args.effect == "none" else args.effect
    t_gen, runs = _timed(lambda: dataset(effect, args.seed, args.cycles,
                                         args.samples_per_cycle))
    walls = {"identify": [], "diagnose": [], "cli": []}
    result = None
    cli_cause = None
    for _ in range(args.repeats):
        dt, _ = _timed(lambda: identify.identify(runs))
        walls["identify"].append(dt)
        dt, result = _timed(lambda: diagnose.diagnose(runs))
        walls["diagnose"].append(dt)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "speed.csv"
        write_measurements(path, runs)
        script = Path(sys.executable).with_name("smeha")
        command = ([str(script)] if script.is_file() else
                   [sys.executable, "-c", "import sys; from smeha.cli import main; "
                                          "sys.exit(main())"])
        for _ in range(args.cli_repeats):
            dt, proc = _timed(lambda: subprocess.run(
                command + ["diagnose", str(path), "--json"], capture_output=True, text=True))
            if proc.returncode != 0:
                raise SystemExit(f"smeha diagnose failed ({proc.returncode}):\n{proc.stderr}")
            walls["cli"].append(dt)
            cli_cause = json.loads(proc.stdout)["cause"]
    med = {k: statistics.median(v) for k, v in walls.items() if v}
    out = {
        "dataset": {"runs": len(runs), "frequencies_Hz": list(FREQUENCIES),
                    "amplitudes_A": list(AMPLITUDES), "cycles": args.cycles,
                    "samples_per_cycle": args.samples_per_cycle,
                    "samples_per_run": args.cycles * args.samples_per_cycle,
                    "effect": args.effect, "seed": args.seed,
                    "generation_s": t_gen},
        "wall_s": walls, "median_s": med,
        "diagnosis": {"cause": result.cause, "gain": result.gain, "cli_cause": cli_cause},
        "python": sys.version.split()[0],
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    d = out["dataset"]
    print(f"{d['runs']} runs ({', '.join(f'{f:g}' for f in FREQUENCIES)} Hz x "
          f"{', '.join(f'{a:g}' for a in AMPLITUDES)} A), {d['cycles']} cycles x "
          f"{d['samples_per_cycle']} samples per cycle = {d['samples_per_run']} samples per "
          f"run; effect {d['effect']}, seed {d['seed']} (generated in {t_gen:.1f} s)")
    for k, label in (("identify", "identify (function)"), ("diagnose", "diagnose (function)"),
                     ("cli", "smeha diagnose --json (subprocess)")):
        if k in med:
            runs_s = ", ".join(f"{v:.2f}" for v in walls[k])
            print(f"  {label:<36} median {med[k]:7.2f} s   ({runs_s})")
    print(f"  diagnosis: cause {result.cause}, held-out gain {result.gain:.3g}"
          + (f"; CLI cause {cli_cause}" if cli_cause is not None else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
