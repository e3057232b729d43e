"""The transducer FMUs as FMI Cross-Check test FMUs (``smeha build --cross-check DIR``).

The FMI Cross-Check (modelica/fmi-cross-check) collects, per exporting tool, test FMUs with
a reference result that importing tools compare their own simulation against. Its rules
set the layout and the files, which this module writes for each transducer FMU given::

    DIR/fmus/<FMI version>/cs/<platform>/smeha/<smeha version>/<model name>/
        <model name>.fmu      the FMU as built
        <model name>_in.csv   the inputs: "time", u, external_force at each step
        <model name>_ref.csv  the reference result: "time" and the outputs below
        <model name>_ref.opt  StartTime, StopTime, StepSize, RelTol
        README.md             the experiment, how the reference was made, how to run it

(FMI 2.0: platform ``linux64``; FMI 3.0: ``x86_64-linux``.) The experiment is the paper's
uncompensated 50 Hz case, the FMU's default parameters (Table 1, I_m = 1 A): one period,
u = cos(2 pi 50 t) A held over each 10 us step, no external force. The reference is the
exporting tool's own simulation: :class:`gmt.Transducer` stepped in this process with the
same inputs, not the FMU (``tests/test_fmu.py`` checks the FMU against gmt to 1e-12).
``tests/test_crosscheck.py`` validates the files with fmpy's cross-check validator and the
results of fmpy and fmusim with fmpy's band (``fmpy.util.validate_result``).
"""
from __future__ import annotations

import math
import shutil
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

__all__ = ["OUTPUTS", "REL_TOL", "PLATFORM", "TOOL", "inputs", "reference", "write"]

#: The experiment: [s].
START_TIME, STOP_TIME, STEP_SIZE = 0.0, 0.02, 1e-5
#: Drive frequency [Hz] and current amplitude [A] (the FMU's defaults: Table 1's 50 Hz case).
FREQUENCY, AMPLITUDE = 50.0, 1.0
#: The outputs in the reference result.
OUTPUTS = ("current", "displacement", "velocity", "flux_density", "force")
#: The cross-check rules' tolerance field (for model exchange solvers; a co-simulation FMU
#: with a fixed step does not use it).
REL_TOL = 1e-6
PLATFORM = {"2": "linux64", "3": "x86_64-linux"}
TOOL = "smeha"


def _steps() -> int:
    return round((STOP_TIME - START_TIME) / STEP_SIZE)


def inputs() -> list[tuple[float, float, float]]:
    """(t, u, external_force) at t = k h, k = 0 .. steps (the last for hosts that read it)."""
    return [(k * STEP_SIZE, math.cos(2.0 * math.pi * FREQUENCY * k * STEP_SIZE), 0.0)
            for k in range(_steps() + 1)]


def reference() -> list[list[float]]:
    """Rows [t, outputs...]: the rest state at t = 0, then gmt's outputs after each step."""
    import gmt

    tr = gmt.Transducer(gmt.TransducerParameters(),
                        gmt.Excitation(frequency=FREQUENCY, current_amplitude=AMPLITUDE),
                        gmt.DriveParameters())
    rows = [[START_TIME, 0.0, float(tr.forward.displacement), float(tr.forward.velocity),
             0.0, 0.0]]
    for k, (t, u, force) in enumerate(inputs()[:-1]):
        o = tr.step(u, STEP_SIZE, force)
        m = o.magnetics
        rows.append([(k + 1) * STEP_SIZE, o.current, o.displacement, o.velocity,
                     m.flux_density, m.force])
    return rows


def _csv(path: Path, names, rows) -> None:
    lines = [",".join(f'"{n}"' for n in names)]
    lines += [",".join(repr(float(x)) for x in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _readme(model_name: str, fmi: str, version: str) -> str:
    return f"""# {model_name}: smeha's transducer FMU (FMI {fmi}.0, co-simulation)

A giant magnetostrictive (Terfenol-D) transducer with the dynamic hysteresis model of its
source paper (complex permeability, loss separation, eqs 1-37) and the rod's mechanics,
exported by smeha {version} (pythonfmu). The FMU needs a CPython 3.11-3.13 with numpy at
run time; its binary finds one (the host's own, `SMEHA_FMU_PYTHON`, `python3` on `PATH`).

## Experiment

The paper's uncompensated 50 Hz case with the FMU's default parameters (I_m = 1 A): one
period from t = {START_TIME:g} s to {STOP_TIME:g} s in steps of {STEP_SIZE:g} s; the input
`u` (coil current through the amplifier gain, A) is cos(2 pi {FREQUENCY:g} t) held over each
step (`{model_name}_in.csv`), `external_force` is 0 N.

## Reference

`{model_name}_ref.csv` holds {", ".join(OUTPUTS)} (SI units) at every step, from smeha's
own model (`gmt.Transducer`, the physics the FMU bundles) with the same inputs; the FMU
reproduces it to 1e-12 relative in fmpy and fmusim (in the FMU Compliance Checker,
whose clock accumulates the step, to 1e-7).

Run with fmusim:

    fmusim --interface-type cs --input-file {model_name}_in.csv --stop-time {STOP_TIME:g} \\
        --output-interval {STEP_SIZE:g} --output-file out.csv {model_name}.fmu
"""


def write(folder, fmus) -> list[Path]:
    """Write each FMU of ``fmus`` (paths of transducer FMUs) with its cross-check files under
    ``folder``; return the model folders."""
    from .. import __version__

    header_in = ("time", "u", "external_force")
    header_ref = ("time", *OUTPUTS)
    rows_in, rows_ref = inputs(), reference()
    written = []
    for fmu in map(Path, fmus):
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        fmi = root.get("fmiVersion")[0]
        name = root.get("modelName")
        model_dir = (Path(folder) / "fmus" / f"{fmi}.0" / "cs" / PLATFORM[fmi] / TOOL /
                     __version__ / name)
        model_dir.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(fmu, model_dir / f"{name}.fmu")
        _csv(model_dir / f"{name}_in.csv", header_in, rows_in)
        _csv(model_dir / f"{name}_ref.csv", header_ref, rows_ref)
        (model_dir / f"{name}_ref.opt").write_text(
            f"StartTime, {START_TIME!r}\nStopTime, {STOP_TIME!r}\nStepSize, {STEP_SIZE!r}\n"
            f"RelTol, {REL_TOL!r}\n", encoding="utf-8")
        (model_dir / "README.md").write_text(_readme(name, fmi, __version__), encoding="utf-8")
        written.append(model_dir)
    return written
