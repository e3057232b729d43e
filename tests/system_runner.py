"""Child-process side of the EHA system tests: write, run and check the system; write JSON.

    python tests/system_runner.py COMMAND OUT.json [ARGS...]

Commands
--------
``write OUT DIST FOLDER CIRCUIT CYCLES F:MODE...``
    the .ssp, OspSystemStructure.xml and container FMU of each case (smeha.fmu.ssp), from the
    FMUs in DIST
``harness OUT FMU CIRCUIT CYCLES F:MODE...``
    the project's co-simulation harness (smeha.studies.flow.run_case, the transducer FMU)
    for each case: its flow check, and the free transducer's flow of eqs 40/41
``fmpy OUT SSP F``        the .ssp in fmpy's simulate_ssp; its flow check
``libcosim OUT OSP F``    OspSystemStructure.xml in libcosim; its flow check, and the
                          mechanics each unit runs with
``container OUT FMU F``   the container FMU in fmpy's simulate_fmu; its flow check
``container_log OUT FMU STOP``
                          the container FMU in fmpy's simulate_fmu with its units' logging
                          on, to STOP: the transducer's current after each step, the
                          messages at Warning or above, the parameters (start values)
``free OUT F MODE CYCLES``  dy of the free transducer between the valve switches (eqs
                          40/41; smeha.studies.flow.free_dy: no hydraulics)
``plant_bad OUT FMU NAME=VALUE...``
                          fmpy.simulate_fmu of the plant FMU with each bad parameter: the
                          exception it raised and what the FMU wrote to stderr
``plant_drive OUT FMU N H F A U0 FORCE NAME...``
                          the plant FMU in fmpy as tests/fmu_c_host.c drives it: u = U0 +
                          A cos(2 pi F t) at t = k H, the force held at FORCE; rows [t, NAME...]

Why children: pythonfmu FMUs run in the host's interpreter and share its modules by
name, so each run gets a process of its own, as a user's would: the pytest process has
imported gmt and system_models (doctests), the writer has loaded the transducer FMU to
read its calculated parameters, and fmpy's SSP master extracts the FMUs afresh at every
run (modules imported from one run's folder would outlive it). Importable without side
effects (pytest's doctest collection imports it).
"""
from __future__ import annotations

import json
import os
import sys

#: Pump piston area A_d, [m^2] (paper, Table 2: 1256 mm^2), for the flow check's eq 39.
PISTON_AREA = 1256e-6


def _cases(items):
    return [(float(f), mode) for f, mode in (item.split(":") for item in items)]


def _check(chk, wall, steps) -> dict:
    return {"flow": chk.flow_sim, "dy": chk.dy, "cycles": chk.cycles,
            "window": list(chk.window), "wall_s": wall, "steps": steps}


def write(out_path, dist, folder, circuit, cycles, *cases):
    from pathlib import Path

    from smeha.fmu import ssp
    from smeha.studies.flow import Case

    fmus = {comp: Path(dist) / f"{name}.fmu" for comp, name in
            (("drive", "SmehaDrive"), ("transducer", "SmehaGmt"), ("plant", "SmehaPlant"))}
    written = {}
    for f, mode in _cases(cases):
        desc = ssp.describe(Case(f, mode, circuit=circuit, cycles=float(cycles)), fmus)
        tag = f"{circuit}_{f:g}_{mode}"
        written[f"{f:g}:{mode}"] = {
            "ssp": str(ssp.write_ssp(desc, Path(folder) / f"{tag}.ssp")),
            "osp": str(ssp.write_osp(desc, Path(folder) / tag)),
            "container": str(ssp.write_container(desc, Path(folder) / f"{tag}.fmu")),
            "step": desc.step, "stop_time": desc.stop_time, "parameters": desc.parameters}
    _write(out_path, written)


def harness(out_path, fmu, circuit, cycles, *cases):
    import time
    from pathlib import Path

    from smeha.studies.flow import Case, run_case

    rows = {}
    for f, mode in _cases(cases):
        wall = time.perf_counter()
        record, chk, row = run_case(Case(f, mode, circuit=circuit, cycles=float(cycles)),
                                    fmu_path=Path(fmu))
        rows[f"{f:g}:{mode}"] = dict(_check(chk, time.perf_counter() - wall, len(record) - 1),
                                     flow_free=row["flow_free_m3_s"], step=row["step_s"])
    _write(out_path, rows)


def fmpy(out_path, ssp_path, frequency):
    import fmpy as fmpy_package

    from smeha.fmu import systemrun

    run = systemrun.run_fmpy(ssp_path)
    chk = systemrun.flow(run.record, float(frequency), PISTON_AREA)
    _write(out_path, dict(_check(chk, run.wall, len(run.record)),
                          fmpy=fmpy_package.__version__, end_time=float(run.record["time"][-1])))


def container(out_path, fmu_path, frequency):
    from smeha.fmu import systemrun

    run = systemrun.run_container(fmu_path)
    chk = systemrun.flow(run.record, float(frequency), PISTON_AREA)
    _write(out_path, _check(chk, run.wall, len(run.record) - 1))


def container_log(out_path, fmu_path, stop_time):
    from fmpy import read_model_description, simulate_fmu

    messages = []

    def logger(environment, instance, status, category, message):
        if status >= 1:  # fmi2Warning and above
            messages.append([int(status), message.decode()])

    md = read_model_description(fmu_path)
    step = float(md.defaultExperiment.stepSize)
    result = simulate_fmu(fmu_path, stop_time=float(stop_time), step_size=step,
                          output_interval=step, output=["transducer.current"],
                          debug_logging=True, logger=logger)
    _write(out_path, {"step": step, "time": result["time"].tolist(),
                      "current": result["transducer.current"].tolist(), "messages": messages,
                      "parameters": {v.name: v.start for v in md.modelVariables
                                     if v.causality == "parameter"}})


def libcosim(out_path, osp_path, frequency):
    from smeha.fmu import systemrun

    run = systemrun.run_libcosim(osp_path, report=(
        ("transducer", systemrun.MECHANICS + ("displacement",)),
        ("plant", systemrun.MECHANICS + ("rod_start_displacement",))))
    chk = systemrun.flow(run.record, float(frequency), PISTON_AREA)
    _write(out_path, dict(_check(chk, run.wall, len(run.record)), end_time=run.end_time,
                          units=run.reported))


def free(out_path, frequency, mode, cycles):
    from smeha.studies.flow import free_dy

    _write(out_path, {"dy_free": free_dy(float(frequency), mode, cycles=float(cycles))})


def plant_drive(out_path, fmu_path, steps, h, frequency, amplitude, offset, force, *names):
    import math

    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(fmu_path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu_path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="plant")
    fmu.instantiate()
    fmu.setReal([vr["force"]], [float(force)])
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    h, w, a, u0 = float(h), 2.0 * math.pi * float(frequency), float(amplitude), float(offset)
    rows = []
    for k in range(int(steps)):
        t = k * h
        fmu.setReal([vr["u"]], [u0 + a * math.cos(w * t)])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        rows.append([(k + 1) * h] + list(fmu.getReal([vr[n] for n in names])))
    fmu.terminate()
    fmu.freeInstance()
    _write(out_path, {"rows": rows})


def plant_bad(out_path, fmu_path, *settings):
    import io
    import contextlib

    from fmpy import simulate_fmu

    results = {}
    for item in settings:
        name, value = item.split("=", 1)
        stderr = io.StringIO()
        error = None
        try:
            with contextlib.redirect_stderr(stderr):
                simulate_fmu(fmu_path, stop_time=1e-4, step_size=1e-5,
                             start_values={name: float(value)})
        except Exception as exc:  # what a user sees
            error = f"{type(exc).__name__}: {exc}"
        results[item] = {"error": error, "stderr": stderr.getvalue()}
    _write(out_path, results)


def _write(path, obj):
    with open(path, "w") as fh:
        json.dump(obj, fh)


COMMANDS = {"write": write, "harness": harness, "fmpy": fmpy, "libcosim": libcosim,
            "container": container, "container_log": container_log, "plant_bad": plant_bad,
            "free": free, "plant_drive": plant_drive}

if __name__ == "__main__":
    COMMANDS[sys.argv[1]](*sys.argv[2:])
    # leave without tearing down libcosim's execution (smeha.fmu.systemrun keeps it alive)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
