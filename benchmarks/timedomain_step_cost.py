"""Cost of one FMU step with the time-domain magnetics against the paper's.

    python benchmarks/timedomain_step_cost.py [--fmu dist/SmehaGmt.fmu] [--runs 5]
                                              [--steps 20000] [--json]

For each drive (uncompensated 100 Hz, i = cos(200 pi t) A; compensated, the paper's
u = 1.5 + 1.5 cos(200 pi t) V) and each ``magnetics`` ("paper", "time_domain"), an
fmpy loop does a host's full exchange per step (set u and external_force, doStep, get
the 8 Real outputs, saturated and saturation_count) at the co-simulation's 100 us step.
Prints the median time per step over ``--runs`` runs (the two models' runs interleaved)
and the ratio time_domain / paper, also of the fastest runs (the least disturbed by a
shared machine); also gmt's ``Transducer.step`` alone (in-process, no FMI). Figures only.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fmu_memory import built_fmu  # noqa: E402

STEP = 1e-4
DRIVES = {"uncompensated": (False, 0.0, 1.0), "compensated": (True, 1.5, 1.5)}


def open_fmu(fmu, magnetics, compensated, name):
    """An initialised fmpy FMU2Slave with ``magnetics`` and ``compensated`` set."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    slave.instantiate(loggingOn=False)
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setString([vr["magnetics"]], [magnetics])
    slave.setBoolean([vr["compensated"]], [compensated])
    slave.setReal([vr["frequency"]], [100.0])
    slave.exitInitializationMode()
    return slave, vr


def fmu_loop(slave, vr, steps, offset, amplitude):
    in_vr = [vr["u"], vr["external_force"]]
    out_vr = [vr[n] for n in ("current", "displacement", "velocity", "field", "flux_density",
                              "magnetization", "strain", "force")]
    b_vr, i_vr = [vr["saturated"]], [vr["saturation_count"]]
    w = 2 * math.pi * 100.0
    u = [offset + amplitude * math.cos(w * k * STEP) for k in range(steps)]
    t = 0.0
    start = time.perf_counter()
    for k in range(steps):
        slave.setReal(in_vr, [u[k], 0.0])
        slave.doStep(t, STEP)
        slave.getReal(out_vr)
        slave.getBoolean(b_vr)
        slave.getInteger(i_vr)
        t += STEP
    return (time.perf_counter() - start) / steps * 1e6


def gmt_loop(magnetics, compensated, offset, amplitude, steps):
    import gmt

    tr = gmt.Transducer(gmt.TransducerParameters(), gmt.Excitation(100.0, 1.0),
                        gmt.DriveParameters(compensated=compensated), magnetics=magnetics)
    w = 2 * math.pi * 100.0
    u = [offset + amplitude * math.cos(w * k * STEP) for k in range(steps)]
    start = time.perf_counter()
    for k in range(steps):
        tr.step(u[k], STEP)
    return (time.perf_counter() - start) / steps * 1e6


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", help="FMU to run (default: build one)")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    say = (lambda *a: None) if args.json else print
    result = {"steps_per_run": args.steps, "runs": args.runs, "step_s": STEP}
    with tempfile.TemporaryDirectory() as tmp:
        fmu = built_fmu(args.fmu, tmp)
        for drive, (compensated, offset, amplitude) in DRIVES.items():
            slaves = {m: open_fmu(fmu, m, compensated, f"{drive}-{m}")
                      for m in ("paper", "time_domain")}
            for slave, vr in slaves.values():
                fmu_loop(slave, vr, 2000, offset, amplitude)  # warm up
            # the two models run by run, interleaved in one process: a change of the shared
            # machine's load falls on both alike
            runs = {m: [] for m in slaves}
            direct = {m: [] for m in slaves}
            for _ in range(args.runs):
                for m, (slave, vr) in slaves.items():
                    runs[m].append(fmu_loop(slave, vr, args.steps, offset, amplitude))
                    direct[m].append(gmt_loop(m, compensated, offset, amplitude, args.steps))
            figures = {m: {"fmu_us": statistics.median(runs[m]), "fmu_min_us": min(runs[m]),
                           "fmu_runs": runs[m], "gmt_us": statistics.median(direct[m]),
                           "gmt_min_us": min(direct[m])} for m in slaves}
            for slave, _ in slaves.values():
                slave.terminate()
                slave.freeInstance()
            td, paper = figures["time_domain"], figures["paper"]
            ratio = td["fmu_us"] / paper["fmu_us"]
            result[drive] = dict(figures, ratio_fmu=ratio,
                                 ratio_fmu_min=td["fmu_min_us"] / paper["fmu_min_us"],
                                 ratio_gmt=td["gmt_us"] / paper["gmt_us"],
                                 ratio_gmt_min=td["gmt_min_us"] / paper["gmt_min_us"])
            say(f"{drive:14s} FMU exchange: paper {paper['fmu_us']:6.1f} us, time_domain "
                f"{td['fmu_us']:6.1f} us, ratio {ratio:.2f} (of the fastest runs "
                f"{result[drive]['ratio_fmu_min']:.2f}); gmt alone: {paper['gmt_us']:.1f} / "
                f"{td['gmt_us']:.1f} us, ratio {result[drive]['ratio_gmt']:.2f} (fastest "
                f"{result[drive]['ratio_gmt_min']:.2f})")
    if args.json:
        import json
        print(json.dumps(result))


if __name__ == "__main__":
    main()
