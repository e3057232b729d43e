"""Resident memory of a host stepping the FMI 2.0 FMU a million times (fmpy).

    python benchmarks/fmu_memory.py [--fmu dist/SmehaGmt.fmu] [--steps 1e6]

Prints RSS every tenth of the run. Without --fmu, builds the FMU into a temporary
directory first (in a child process, so this process never imports the
repository's gmt and the FMU runs its bundled copy). Prints figures; asserts
nothing (the test suite checks 1e5 steps).
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def rss_mb() -> float:
    """Resident set size of this process, [MB] (Linux /proc)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return math.nan


def built_fmu(path=None, tmp=None) -> Path:
    """``path``, or a freshly built dist/SmehaGmt.fmu in ``tmp``."""
    if path:
        return Path(path)
    subprocess.run([sys.executable, str(REPO / "build_fmu.py"), "--out", tmp], check=True,
                   stdout=subprocess.DEVNULL)
    return Path(tmp) / "SmehaGmt.fmu"


def open_fmu(fmu: Path, name="bench"):
    """An initialised fmpy FMU2Slave with default parameters, and its value references."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(loggingOn=False)
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave, {v.name: v.valueReference for v in md.modelVariables}


def memory_run(fmu: Path, steps: int, report=print):
    """Step the paper's 50 Hz drive ``steps`` times (set u, doStep, get outputs); RSS samples."""
    slave, vr = open_fmu(fmu)
    u_vr = [vr["u"]]
    out_vr = [vr[n] for n in ("current", "displacement", "velocity", "field", "flux_density",
                              "magnetization", "strain", "force")]
    h, w, t = 1e-5, 2 * math.pi * 50.0, 0.0
    samples = [(0, rss_mb())]
    tick = max(1, steps // 10)
    start = time.perf_counter()
    for k in range(1, steps + 1):
        slave.setReal(u_vr, [math.cos(w * t)])
        slave.doStep(t, h)
        slave.getReal(out_vr)
        t += h
        if k % tick == 0:
            samples.append((k, rss_mb()))
            report(f"  {k:>9d} steps  RSS {samples[-1][1]:8.1f} MB  "
                   f"({time.perf_counter() - start:6.1f} s)")
    return samples


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", help="FMU to run (default: build one)")
    parser.add_argument("--steps", type=float, default=1e6)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        fmu = built_fmu(args.fmu, tmp)
        print(f"{fmu.name}: {int(args.steps)} steps of set u + doStep(1e-5 s) + get 8 outputs")
        samples = memory_run(fmu, int(args.steps))
    first = samples[1][1] if len(samples) > 1 else samples[0][1]
    print(f"RSS after {samples[-1][0]} steps: {samples[-1][1]:.1f} MB "
          f"(after the first tenth: {first:.1f} MB, growth {samples[-1][1] - first:+.1f} MB)")


if __name__ == "__main__":
    main()
