"""The EHA system's cylinder flow against the harness, by communication step and force hold.

For each case (frequency, mode) it writes the system (smeha.fmu.ssp) twice -- the plant holding
the transducer's force over each step, and extrapolating it from its last two values --
runs each in fmpy's SSP master (smeha.fmu.systemrun.run_fmpy) at every step given, each run in
a child process, and prints the flow of eqs 39-41's check, its relative difference from
the harness's flow for the same case (smeha.studies.flow.run_case with the transducer FMU,
its own default step) and the wall time. The plant's valve controller samples u at each
communication step, so the step is also that controller's period.

Usage: python benchmarks/system_step.py [--steps 5e-6,1e-5,2e-5] [--cycles 4]
       [--frequencies 50,100] [--modes uncompensated,compensated] [--dist DIR] [--json]

The FMUs are dist/'s of the source tree (``smeha build --system``), built if missing.
Figures only: nothing is asserted.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import tempfile
from pathlib import Path

#: Pump piston area A_d, [m^2] (paper, Table 2).
PISTON_AREA = 1256e-6


def _run(ssp_path, step, frequency) -> dict:
    """Child: one fmpy SSP run; print its flow and wall time as JSON."""
    from smeha.fmu import systemrun

    run = systemrun.run_fmpy(ssp_path, step=float(step))
    flow = systemrun.flow(run.record, float(frequency), PISTON_AREA).flow_sim
    return {"flow": flow, "wall_s": run.wall, "steps": len(run.record)}


def _fmus(dist: Path) -> dict:
    from smeha.fmu import build as fmu_build, ssp

    fmus = {}
    for comp, key in ssp.COMPONENTS.items():
        path = dist / f"{fmu_build.spec(key).model_name}.fmu"
        fmus[comp] = path if path.is_file() else fmu_build.build_fmu(key, dist)
    return fmus


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", default="5e-6,1e-5,2e-5")
    ap.add_argument("--cycles", type=float, default=4.0)
    ap.add_argument("--frequencies", default="50,100")
    ap.add_argument("--modes", default="uncompensated,compensated")
    ap.add_argument("--dist", type=Path, default=None)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--run", nargs=3, metavar=("SSP", "STEP", "F"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.run:
        print(json.dumps(_run(*args.run)))
        return 0
    from smeha.fmu import build as fmu_build, ssp
    from smeha.studies import flow

    fmus = _fmus(args.dist or fmu_build.DIST)
    rows = []
    with tempfile.TemporaryDirectory(prefix="smeha_system_step_") as tmp:
        for f in (float(x) for x in args.frequencies.split(",")):
            for mode in args.modes.split(","):
                case = flow.Case(f, mode, cycles=args.cycles)
                _, check, _ = flow.run_case(case, fmu_path=fmus["transducer"])
                desc = ssp.describe(case, fmus)
                for extrapolate in (False, True):
                    plant = dict(desc.parameters["plant"], extrapolate_force=extrapolate)
                    variant = dataclasses.replace(
                        desc, parameters=dict(desc.parameters, plant=plant))
                    path = ssp.write_ssp(variant, Path(tmp) / f"{f:g}_{mode}_{extrapolate}.ssp")
                    for step in (float(s) for s in args.steps.split(",")):
                        out = subprocess.run([sys.executable, __file__, "--run", str(path),
                                              repr(step), repr(f)],
                                             capture_output=True, text=True, check=True)
                        run = json.loads(out.stdout.strip().splitlines()[-1])
                        rows.append({"frequency_Hz": f, "mode": mode, "step_s": step,
                                     "force": "extrapolated" if extrapolate else "held",
                                     "flow_m3_s": run["flow"], "harness_m3_s": check.flow_sim,
                                     "difference": run["flow"] / check.flow_sim - 1.0,
                                     "wall_s": run["wall_s"], "steps": run["steps"]})
                        if not args.json:
                            r = rows[-1]
                            print(f"{f:5g} Hz {mode:<13} h = {step * 1e6:4.1f} us  force "
                                  f"{r['force']:<12}  flow {r['flow_m3_s']:.6e}  harness "
                                  f"{r['harness_m3_s']:.6e}  {100 * r['difference']:+.3f} %  "
                                  f"{r['wall_s']:.1f} s", flush=True)
    if args.json:
        json.dump({"cycles": args.cycles, "rows": rows}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
