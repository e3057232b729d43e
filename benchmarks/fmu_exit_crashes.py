"""Crash count: the FMUs run N times in a C host and N times in fmpy, each a fresh process.

    python benchmarks/fmu_exit_crashes.py [--runs 50] [--dist DIR] [--steps 2000]
        [--fmus FMI2,FMI3,plant] [--json]

Each run is a new process that loads the FMU, steps the paper's 50 Hz drive and
exits normally (through the FMU library's destructors and, in fmpy, Python's own
finalisation), which is where pythonfmu's exit-time double release can
corrupt the heap (docs/FMU.md "Exit"):

* ``c_host``: tests/fmu_c_host.c, compiled with the system compiler, loads the
  binary with dlopen(RTLD_NOW | RTLD_LOCAL) in a clean environment (no
  LD_PRELOAD, no PYTHONPATH, PATH=/usr/bin:/bin) from a fresh extraction of the
  FMU every run (as tools do: a first run compiles the bundled sources);
* ``fmpy``: ``fmpy.simulate_fmu`` with the same drive, in this environment's Python.

The FMUs: the transducer (FMI 2.0 and 3.0) and the EHA system's hydraulic plant
(``plant``: u drives its valve controller, the force held at 1442 N, about K y at the
rod's rest position; it loads numba and the compiled kernel's shipped cache).

Prints, per host and FMU, the runs, how many exited 0, and the other exit
statuses (negative: killed by that signal; 134 = SIGABRT through the shell). Figures
only; nothing is asserted (tests/test_fmu_hosts.py runs a handful in CI).
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

REPO = Path(__file__).resolve().parents[1]
HOST = REPO / "tests" / "fmu_c_host.c"
CLEAN_ENV = {"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8"}

FMPY_RUN = r"""
import json, sys, numpy as np
from fmpy import simulate_fmu
steps = int(sys.argv[2])
t = np.arange(steps + 1) * 1e-5
u = np.array(list(zip(t, np.cos(2 * np.pi * 50 * t))), dtype=[("time", float), ("u", float)])
res = simulate_fmu(sys.argv[1], input=u, stop_time=steps * 1e-5, output_interval=1e-5,
                   output=[sys.argv[3]], start_values=json.loads(sys.argv[4]))
assert len(res) > steps // 2
"""

#: The FMUs counted: name -> (file, the output printed, Real start values).
FMUS = {"FMI2": ("SmehaGmt.fmu", "displacement", {}),
        "FMI3": ("SmehaGmt3.fmu", "displacement", {}),
        "plant": ("SmehaPlant.fmu", "rod_displacement", {"force": 1442.0})}


def compile_host(tmp: Path) -> Path:
    cc = shutil.which((sysconfig.get_config_var("CC") or "cc").split()[0]) or shutil.which("cc")
    exe = tmp / "fmu_c_host"
    subprocess.run([cc, "-std=c11", "-D_GNU_SOURCE", "-O2", "-o", str(exe), str(HOST), "-ldl",
                    "-lm"], check=True)
    return exe


def c_host_run(exe: Path, fmu: Path, work: Path, steps: int, output: str, starts: dict) -> int:
    """One C host process on a fresh extraction of ``fmu``; its exit status."""
    if work.exists():
        shutil.rmtree(work)
    with zipfile.ZipFile(fmu) as z:
        z.extractall(work)
    root = ET.parse(work / "modelDescription.xml").getroot()
    fmi = root.get("fmiVersion")[0]
    ident = root.find("CoSimulation").get("modelIdentifier")
    variables = (root.find("ModelVariables").findall("ScalarVariable") if fmi == "2"
                 else list(root.find("ModelVariables")))
    vr = {v.get("name"): v.get("valueReference") for v in variables}
    binary = work / "binaries" / ("linux64" if fmi == "2" else "x86_64-linux") / f"{ident}.so"
    token = root.get("guid" if fmi == "2" else "instantiationToken")
    settings = [f"r:{vr[name]}={value!r}" for name, value in starts.items()]
    proc = subprocess.run([str(exe), fmi, str(binary), f"{work / 'resources'}/", token, vr["u"],
                           str(steps), "1e-5", "50", "1", "0", *settings, "--", vr[output]],
                          env=CLEAN_ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True)
    return proc.returncode


def fmpy_run(fmu: Path, steps: int, output: str, starts: dict) -> int:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    proc = subprocess.run([sys.executable, "-c", FMPY_RUN, str(fmu), str(steps), output,
                           json.dumps(starts)], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    return proc.returncode


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--dist", help="directory with SmehaGmt.fmu, SmehaGmt3.fmu and "
                                   "SmehaPlant.fmu (default: build them into a temporary "
                                   "directory)")
    ap.add_argument("--fmus", default=",".join(FMUS), help=f"some of {','.join(FMUS)}")
    ap.add_argument("--hosts", default="c_host,fmpy")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="smeha_exit_") as tmp:
        tmp = Path(tmp)
        dist = Path(args.dist) if args.dist else tmp / "dist"
        if not args.dist:
            subprocess.run([sys.executable, str(REPO / "build_fmu.py"), "--fmi", "both",
                            "--system", "--out", str(dist)], check=True,
                           stdout=subprocess.DEVNULL)
        exe = compile_host(tmp)
        results = {}
        for host in args.hosts.split(","):
            for key in args.fmus.split(","):
                name, output, starts = FMUS[key]
                codes = [c_host_run(exe, dist / name, tmp / "unzipped", args.steps, output,
                                    starts)
                         if host == "c_host" else fmpy_run(dist / name, args.steps, output,
                                                           starts)
                         for _ in range(args.runs)]
                counts = collections.Counter(codes)
                results[f"{host} {key}"] = {
                    "runs": len(codes), "exit_0": counts.get(0, 0),
                    "crashes": sum(n for c, n in counts.items() if c != 0),
                    "other_statuses": {str(c): n for c, n in counts.items() if c != 0}}
                r = results[f"{host} {key}"]
                print(f"{host:7s} {key}: {r['runs']} runs, {r['exit_0']} exit 0, "
                      f"{r['crashes']} crashes {r['other_statuses'] or ''}", flush=True)
    if args.json:
        print(json.dumps(results))


if __name__ == "__main__":
    main()
