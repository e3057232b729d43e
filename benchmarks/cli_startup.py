"""Start-up time of the command line: ``smeha --help`` and each command's ``--help``.

    python benchmarks/cli_startup.py [--repeats 5] [--json]

Each command runs as a user runs it, a fresh ``smeha`` process (the console script
beside this interpreter), first once to warm the file cache and then ``--repeats``
times; the median, min and max wall times are printed. The target is
``smeha --help`` under 0.5 s, median of 5 warm runs. Also prints which heavy
modules ``import smeha.cli`` loads (none is the design: each command imports what
it needs). Figures only: nothing is asserted.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: system_models itself is light (its defaults module is read for --help); its co-simulation
#: and compiled kernel are not
HEAVY = ("numpy", "scipy", "control", "fmpy", "matplotlib", "numba", "dask",
         "system_models.cosim", "system_models.kernel")


def smeha_command() -> list[str]:
    """The ``smeha`` console script of this environment, or ``python -m smeha.cli``."""
    script = Path(sys.executable).with_name("smeha")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "smeha.cli"]


def wall_times(argv, repeats):
    subprocess.run(argv, capture_output=True, check=True)  # warm
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        times.append(time.perf_counter() - t)
    return times


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    smeha = smeha_command()
    cases = [[], ["flow"], ["simulate"], ["sweep"], ["identify"], ["diagnose"], ["paper"],
             ["build"]]
    result = {"command": " ".join(smeha), "repeats": args.repeats, "help": {}}
    for case in cases:
        times = wall_times([*smeha, *case, "--help"], args.repeats)
        result["help"][" ".join(["smeha", *case, "--help"])] = {
            "median_s": statistics.median(times), "min_s": min(times), "max_s": max(times)}
    code = ("import sys, smeha.cli; print(' '.join(m for m in %r if m in sys.modules))"
            % (HEAVY,))
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.split()
    result["heavy_modules_loaded_by_import"] = loaded
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{'command':<30}  median [s]  min [s]  max [s]   ({args.repeats} warm runs each)")
    for name, t in result["help"].items():
        print(f"{name:<30}  {t['median_s']:>10.3f}  {t['min_s']:>7.3f}  {t['max_s']:>7.3f}")
    print(f"heavy modules loaded by 'import smeha.cli': {', '.join(loaded) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
