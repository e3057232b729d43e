"""Run the EHA system (:mod:`smeha.fmu.ssp`) in SSP and OSP masters and check its cylinder flow.

* :func:`run_fmpy` runs the ``.ssp`` with fmpy's ``fmpy.ssp.simulation.simulate_ssp``:
  fixed step, every unit stepped from the same communication point with the inputs of
  the last one (Jacobi), outputs held between points. fmpy 0.3.32 reads the SSD's
  parameter bindings but does not apply them (``simulate_ssp`` applies only the
  ``parameter_set`` it is given), and converts an SSV Boolean ``"false"`` to true; so
  the bindings are read here, typed, and handed to it (:func:`ssp_parameter_set`).
* :func:`run_libcosim` runs ``OspSystemStructure.xml`` with libcosim (libcosimpy): its
  fixed-step algorithm steps the units in parallel from one communication point and
  transfers the outputs afterwards (Jacobi too), after propagating the initial values.
* :func:`run_container` runs the container FMU (the three as one FMU) with fmpy's
  ``simulate_fmu``: the container steps its units and then connects them (Jacobi).

* :func:`run_omsimulator` runs the ``.ssp`` with OpenModelica's OMSimulator (its command
  line): the SSD's parameter connections applied in initialisation, its fixed-step master
  (the SSD's ``org.openmodelica`` annotation) Jacobi too.

Each returns a :class:`SystemRun`: a record with the fields the harness's flow check reads
(:func:`system_models.flowcheck.flow_check`), the plant's outputs at the end of each step.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gmt.errors import RunError

from .ssp import MECHANICS, NAMESPACES, OSP_CONFIG_NAMESPACE  # noqa: F401  (MECHANICS re-exported)

__all__ = ["PLANT_FIELDS", "SystemRun", "ssp_experiment", "osp_experiment",
           "ssp_parameter_set", "run_fmpy", "run_libcosim", "run_container", "run_omsimulator",
           "omsimulator", "omsimulator_errors", "flow"]

#: The plant outputs a record holds (and the flow check reads).
PLANT_FIELDS = ("rod_displacement", "volume_into_big", "valves_compressing", "p_pump",
                "piston_position")


@dataclass(frozen=True)
class SystemRun:
    """What every runner of this module returns.

    Attributes
    ----------
    record : numpy.ndarray
        Structured array: ``time`` [s] and :data:`PLANT_FIELDS`, the plant's outputs at the
        end of each step, labelled with that end's time.
    wall : float
        Wall time of the run, [s].
    end_time : float or None
        The master's own clock at the end, [s] (libcosim's nanoseconds converted); None where
        the master reports none.
    reported : dict
        {component: {name: value}} of the values a run was asked to report (libcosim).
    """

    record: np.ndarray
    wall: float
    end_time: float | None = None
    reported: dict = field(default_factory=dict)


def ssp_experiment(ssp_path) -> tuple[float, float]:
    """(step, stop time) [s] of a .ssp of :mod:`smeha.fmu.ssp`: its DefaultExperiment's stopTime
    and the fixed step of its OSP annotation (fmpy's SSD reader keeps neither)."""
    import zipfile
    from xml.etree import ElementTree as ET

    with zipfile.ZipFile(ssp_path) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    experiment = root.find(f"{{{NAMESPACES['ssd']}}}DefaultExperiment")
    fixed = experiment.find(f".//{{{NAMESPACES['osp']}}}FixedStepAlgorithm")
    return float(fixed.get("baseStepSize")), float(experiment.get("stopTime"))


def osp_experiment(osp_file) -> tuple[float, float]:
    """(step, stop time) [s] of an OspSystemStructure.xml: BaseStepSize, EndTime."""
    from xml.etree import ElementTree as ET

    ns = f"{{{OSP_CONFIG_NAMESPACE}}}"
    root = ET.parse(osp_file).getroot()
    return float(root.find(f"{ns}BaseStepSize").text), float(root.find(f"{ns}EndTime").text)


def _typed(kind: str, text: str):
    if kind == "Real":
        return float(text)
    if kind == "Integer":
        return int(text)
    if kind == "Boolean":
        if text not in ("true", "false", "1", "0"):
            raise ValueError(f"SSV Boolean value {text!r} is not true, false, 1 or 0")
        return text in ("true", "1")
    return text


def ssp_parameter_set(ssp_path):
    """The SSD's component parameter bindings as the ``parameter_set`` fmpy's
    ``simulate_ssp`` applies: names ``<component>.<variable>``, values typed.

    fmpy 0.3.32 cannot set String variables: a String equal to the FMU's start value is
    left out (setting it would change nothing), any other raises ``ValueError``.
    """
    import tempfile
    import zipfile

    from fmpy import read_model_description
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssd

    ssd = read_ssd(str(ssp_path))
    out = ParameterSet(name="bindings")
    with tempfile.TemporaryDirectory(prefix="smeha_ssp_") as tmp, \
            zipfile.ZipFile(ssp_path) as z:
        for element in ssd.system.elements:
            starts = {v.name: v.start for v in read_model_description(
                z.extract(element.source, tmp), validate=False).modelVariables}
            for binding in getattr(element, "parameterBindings", []):
                for values in binding.parameterValues:
                    for p in values.parameters:
                        if p.type == "String":
                            if p.value == starts.get(p.name):
                                continue
                            raise ValueError(
                                f"{element.name}.{p.name} = {p.value!r}: fmpy's simulate_ssp "
                                "cannot set String variables (run the OSP file in libcosim)")
                        out.parameters.append(Parameter(name=f"{element.name}.{p.name}",
                                                        type=p.type,
                                                        value=_typed(p.type, p.value)))
    return out


def _record(times, columns: dict) -> np.ndarray:
    record = np.zeros(len(times), dtype=[("time", float)] + [(n, float) for n in columns])
    record["time"] = times
    for name, values in columns.items():
        record[name] = values
    return record


def run_fmpy(ssp_path, step: float | None = None, stop_time: float | None = None
             ) -> SystemRun:
    """Run the .ssp in fmpy's SSP master (the file's step and stop time unless given).

    fmpy starts every connector at 0 (``simulate_ssp``), so the first step gives the plant
    and the transducer u = 0 and no force where libcosim and OMSimulator give them the
    drive's and the transducer's values after initialisation; docs/FMU.md gives what
    that changes in the cylinder flow."""
    from fmpy.ssp.simulation import simulate_ssp

    default_step, default_stop = ssp_experiment(ssp_path)
    step = default_step if step is None else step
    stop_time = default_stop if stop_time is None else stop_time
    parameters = ssp_parameter_set(ssp_path)
    wall = time.perf_counter()
    result = simulate_ssp(str(ssp_path), stop_time=stop_time, step_size=step,
                          parameter_set=parameters)
    wall = time.perf_counter() - wall
    # a row holds the outputs after the step from its time: they are those of time + step
    return SystemRun(_record(result["time"] + step, {n: result[f"plant.{n}"].astype(float)
                                                     for n in PLANT_FIELDS}), wall)


def run_libcosim(osp_file, step: float | None = None, stop_time: float | None = None,
                 report=()) -> SystemRun:
    """Run OspSystemStructure.xml in libcosim, step by step (the file's step and stop time
    unless given).

    libcosim's fixed-step algorithm does the stepping and the transfers; a last-value
    observer reads the plant's outputs after each step (libcosimpy's time-series observer
    takes no Booleans).

    Parameters
    ----------
    report : sequence of (component, names)
        Real variables whose values after the first step are reported (e.g. the
        parameters each unit runs with).

    Returns
    -------
    SystemRun
        With libcosim's end time and the values of ``report``.
    """
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    default_step, default_stop = osp_experiment(osp_file)
    step = default_step if step is None else step
    stop_time = default_stop if stop_time is None else stop_time
    log_output_level(CosimLogLevel.WARNING)
    execution = CosimExecution.from_osp_config_file(str(Path(osp_file).resolve()))
    index = execution.slave_index_from_instance_name("plant")
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    n = int(round(stop_time / step))
    reals = [refs[n_] for n_ in PLANT_FIELDS if n_ != "valves_compressing"]
    rows, phases = np.empty((n, len(reals))), np.empty(n)
    reported = {}
    wall = time.perf_counter()
    for k in range(n):
        if not execution.step(1):
            raise RunError(f"libcosim step {k} failed: {execution.status()}")
        rows[k] = observer.last_real_values(index, reals)
        phases[k] = observer.last_boolean_values(index, [refs["valves_compressing"]])[0]
        if k == 0:
            reported = _values(execution, observer, report)
    wall = time.perf_counter() - wall
    status = execution.status()
    columns = {name: rows[:, i] for i, name in
               enumerate(n_ for n_ in PLANT_FIELDS if n_ != "valves_compressing")}
    columns["valves_compressing"] = phases
    record = _record(step * np.arange(1, n + 1), columns)
    _KEEP.append((execution, observer))  # see _KEEP
    return SystemRun(record, wall, status.current_time * 1e-9, reported)


def _values(execution, observer, report) -> dict:
    out = {}
    for component, names in report:
        index = execution.slave_index_from_instance_name(component)
        refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
        values = observer.last_real_values(index, [refs[n] for n in names])
        out[component] = dict(zip(names, (float(v) for v in values)))
    return out


def run_container(fmu_path, step: float | None = None, stop_time: float | None = None
                  ) -> SystemRun:
    """Run the container FMU (:func:`smeha.fmu.ssp.write_container`) with fmpy's
    ``simulate_fmu`` (its DefaultExperiment's step and stop time unless given), recording
    every step."""
    from fmpy import read_model_description, simulate_fmu

    experiment = read_model_description(str(fmu_path)).defaultExperiment
    step = float(experiment.stepSize) if step is None else step
    stop_time = float(experiment.stopTime) if stop_time is None else stop_time
    wall = time.perf_counter()
    result = simulate_fmu(str(fmu_path), stop_time=stop_time, step_size=step,
                          output_interval=step, output=[f"plant.{n}" for n in PLANT_FIELDS])
    wall = time.perf_counter() - wall
    return SystemRun(_record(result["time"], {n: result[f"plant.{n}"].astype(float)
                                              for n in PLANT_FIELDS}), wall)


#: Environment variable naming OMSimulator's executable (else ``OMSimulator`` on ``PATH``).
OMSIMULATOR_VARIABLE = "SMEHA_OMSIMULATOR"


def omsimulator() -> str | None:
    """OMSimulator's executable: :data:`OMSIMULATOR_VARIABLE`, else ``OMSimulator`` on
    ``PATH``; None when neither names an executable file."""
    import os
    import shutil

    found = os.environ.get(OMSIMULATOR_VARIABLE) or shutil.which("OMSimulator")
    return found if found and os.path.isfile(found) and os.access(found, os.X_OK) else None


def omsimulator_errors(log: str) -> list[str]:
    """The error lines of an OMSimulator log: OMSimulator exits 0 even when its log holds
    errors (a system it could not add, a parameter binding it skipped)."""
    return [line.strip() for line in log.splitlines()
            if line.lstrip().lower().startswith(("error:", "fatal:"))]


def run_omsimulator(ssp_path, executable: str | None = None, env: dict | None = None
                    ) -> SystemRun:
    """Run the .ssp in OMSimulator's command line (the step and stop time of
    :func:`ssp_experiment`).

    ``executable`` defaults to :func:`omsimulator`; ``env`` is the environment it runs in
    (default this process's). The result file is OMSimulator's CSV, written in a
    temporary folder that is also its working and temporary folder.

    Raises
    ------
    gmt.errors.RunError
        No OMSimulator, a non-zero exit, or an error line in its log (named).
    """
    import csv
    import subprocess
    import tempfile

    exe = executable or omsimulator()
    if exe is None:
        raise RunError(f"OMSimulator not found: set {OMSIMULATOR_VARIABLE} to its "
                       "executable or put it on PATH (docs/FMU.md)")
    step, stop_time = ssp_experiment(ssp_path)
    with tempfile.TemporaryDirectory(prefix="smeha_oms_") as tmp:
        result = Path(tmp) / "result.csv"
        wall = time.perf_counter()
        # the command line's defaults (stop at 1 s) override the SSD's, so they are given;
        # --emitEvents=false: one row per communication point
        proc = subprocess.run([exe, str(Path(ssp_path).resolve()), f"--resultFile={result}",
                               f"--stopTime={stop_time!r}", f"--stepSize={step!r}",
                               "--emitEvents=false", f"--tempDir={tmp}",
                               f"--workingDir={tmp}"], cwd=tmp, env=env,
                              capture_output=True, text=True, timeout=1800)
        wall = time.perf_counter() - wall
        log = proc.stdout + proc.stderr
        errors = omsimulator_errors(log)
        if proc.returncode != 0 or errors or not result.is_file():
            raise RunError(f"OMSimulator failed (exit {proc.returncode}): "
                           + ("; ".join(errors) or log.strip()[-2000:]))
        with result.open(newline="") as fh:
            rows = list(csv.reader(fh))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    columns = {}
    for name in PLANT_FIELDS:
        matches = [i for i, h in enumerate(header) if h.endswith(f"plant.{name}")]
        if len(matches) != 1:
            raise RunError(f"OMSimulator's result has {len(matches)} columns for plant.{name}")
        columns[name] = data[:, matches[0]]
    # the first row is the state after initialisation, each next one the end of a step;
    # OMSimulator writes the last point twice: the last row of each time is kept
    times = data[:, header.index("time")]
    last = sorted({t: i for i, t in enumerate(times)}.values())[1:]
    return SystemRun(_record(times[last], {n: c[last] for n, c in columns.items()}), wall)


#: libcosim objects kept alive until the process ends: tearing down an execution that
#: holds pythonfmu slaves while Python runs has aborted now and then (docs/FMU.md, libcosim)
_KEEP: list = []


def flow(record, frequency: float, piston_area: float, skip_cycles: int | None = None):
    """The harness's flow check (eqs 39-41) of a system run's record."""
    from system_models.flowcheck import SKIP_CYCLES, flow_check

    return flow_check(record, frequency, piston_area,
                      SKIP_CYCLES if skip_cycles is None else skip_cycles)
