"""Build the transducer FMUs: FMI 2.0 (pythonfmu 0.7) and FMI 3.0 (pythonfmu3).

``smeha build [--fmi 2|3|both] [--out DIR]`` (:mod:`smeha.cli`; ``python build_fmu.py``
is the same command) calls :func:`build_all`, by default into :data:`DIST`. For each FMU:

1. **Build in a child process.** pythonfmu's builder imports the slave module
   and ``gmt`` and instantiates the slave; those modules stay in
   ``sys.modules``, and an FMU later loaded by the same process would run them
   instead of its bundled copies. So the builder runs in a fresh interpreter
   (:func:`_worker`), on a staging copy of the sources: the slave script,
   ``fmu_src/gmt`` and the FMU's other modules of ``fmu_src/`` (:data:`FMU_MODULES`). The calling process
   imports neither (it reads the variable table through :data:`iface`).
2. **Patch the model description** (this process, XML only). FMI 2.0:
   pythonfmu 0.7 writes no units and no ``ModelStructure/InitialUnknowns``;
   :func:`patch_fmi2` adds ``UnitDefinitions`` (SI base-unit exponents from
   :data:`iface.UNITS`), ``unit`` on every Real and the initial
   unknowns. FMI 3.0 declares units natively (the slave registers them).
3. **Make it reproducible.** The GUID (FMI 2.0) or instantiationToken (FMI 3.0)
   is ``uuid5(GUID_NAMESPACE, <model description with guid and date blanked>)``:
   the same sources give the same GUID, and any change to the interface gives a
   new one. ``generationDateAndTime`` is the build time, or ``SOURCE_DATE_EPOCH``
   when set. The zip is rewritten with sorted members and fixed timestamps, so
   with ``SOURCE_DATE_EPOCH`` set two builds are byte-identical.
4. **Validate** with :func:`fmpy.validation.validate_fmu`; any problem makes the
   build fail (exit status 1).
"""
from __future__ import annotations

import datetime
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from . import fmu_native

#: Repository root (the build needs the source tree: fmu_src/ is not installed).
REPO = Path(__file__).resolve().parents[1]
FMU_SRC = REPO / "fmu_src"
#: Where ``smeha build`` writes the FMUs and ``smeha simulate``/``flow``/``sweep`` look for
#: ``SmehaGmt.fmu``: dist/ of the source tree, whatever the current folder.
DIST = REPO / "dist"


def _load_from_fmu_src(module: str):
    """``fmu_src/<module>.py`` loaded from the source tree as ``smeha._<module>``.

    Under a name of its own: registered under its file's name, an FMU this
    process loads later would import this copy instead of the one bundled in
    its resources.
    """
    name = f"smeha._{module}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, FMU_SRC / f"{module}.py")
    loaded = importlib.util.module_from_spec(spec)
    sys.modules[name] = loaded  # dataclasses look their module up while it executes
    spec.loader.exec_module(loaded)
    return loaded


#: The FMU's variable table (``fmu_src/smeha_fmu_interface.py``).
iface = _load_from_fmu_src("smeha_fmu_interface")
RUNTIME_MODULE = iface.RUNTIME_MODULE
#: The modules of fmu_src/ bundled next to the slave: the table, the callbacks both slaves
#: share, the run-time set-up.
FMU_MODULES = (iface.INTERFACE_MODULE, iface.SLAVE_LOGIC_MODULE, iface.RUNTIME_MODULE)
#: The FMU's run-time set-up (``fmu_src/smeha_fmu_runtime.py``): what it needs, and the
#: format of the build environment record.
runtime = _load_from_fmu_src(RUNTIME_MODULE)
#: Namespace of the deterministic GUIDs (uuid5 of the model description).
GUID_NAMESPACE = uuid.UUID("5d0c3c8e-6f1e-5a4b-9a55-736d6568612e")

_FMI2_ORDER = ("ModelExchange", "CoSimulation", "UnitDefinitions", "TypeDefinitions",
               "LogCategories", "DefaultExperiment", "VendorAnnotations", "ModelVariables",
               "ModelStructure")
_FMI2_MODEL_STRUCTURE_ORDER = ("Outputs", "Derivatives", "InitialUnknowns")

FMI2_OPTIONS = dict(needsExecutionTool=True, canHandleVariableCommunicationStepSize=True,
                    canInterpolateInputs=False, canBeInstantiatedOnlyOncePerProcess=False,
                    canGetAndSetFMUstate=True, canSerializeFMUstate=True)
#: pythonfmu3 0.3.4 writes a stale value for canHandleVariableCommunicationStepSize
#: unless it is given explicitly.
FMI3_OPTIONS = dict(needsExecutionTool=True, canHandleVariableCommunicationStepSize=True,
                    canBeInstantiatedOnlyOncePerProcess=False, canGetAndSetFMUState=True,
                    canSerializeFMUState=True)


class BuildError(RuntimeError):
    """The FMU could not be built or does not validate."""


# -- model description --------------------------------------------------------------
def _insert_in_order(parent, element, order):
    rank = order.index(element.tag)
    for i, child in enumerate(list(parent)):
        if child.tag in order and order.index(child.tag) > rank:
            parent.insert(i, element)
            return
    parent.append(element)


def patch_fmi2(root: ET.Element) -> ET.Element:
    """Add units and InitialUnknowns to a pythonfmu 0.7 model description (in place).

    * ``UnitDefinitions`` with the units the variables use, each with its SI
      ``BaseUnit`` exponents (none for a unit integer exponents cannot express);
    * ``unit`` on every ``Real`` (from :data:`iface.VARIABLES`);
    * ``ModelStructure/InitialUnknowns``: every output (initial calculated) and
      calculated parameter, by 1-based index in ModelVariables (pythonfmu issue #193).
    """
    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    svs = root.find("ModelVariables").findall("ScalarVariable")
    used = sorted({iface.BY_NAME[sv.get("name")].unit for sv in svs
                   if sv.find("Real") is not None})
    units = ET.Element("UnitDefinitions")
    for name in used:
        unit = ET.SubElement(units, "Unit", name=name)
        exponents = iface.UNITS[name]
        if exponents is not None:
            ET.SubElement(unit, "BaseUnit", {k: str(v) for k, v in exponents.items() if v})
    _insert_in_order(root, units, _FMI2_ORDER)
    for sv in svs:
        real = sv.find("Real")
        if real is not None:
            real.set("unit", iface.BY_NAME[sv.get("name")].unit)
    structure = root.find("ModelStructure")
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    unknown = [i + 1 for i, sv in enumerate(svs)
               if (sv.get("causality") == "output"
                   and sv.get("initial", "calculated") in ("approx", "calculated"))
               or sv.get("causality") == "calculatedParameter"]
    if unknown:
        initial = ET.Element("InitialUnknowns")
        for i in unknown:
            ET.SubElement(initial, "Unknown", index=str(i))
        _insert_in_order(structure, initial, _FMI2_MODEL_STRUCTURE_ORDER)
    return root


def _id_attribute(root) -> str:
    return "guid" if root.get("fmiVersion", "").startswith("2") else "instantiationToken"


def deterministic_guid(root: ET.Element) -> str:
    """uuid5 of the model description with its GUID/token and date blanked, as text."""
    blank = ET.fromstring(ET.tostring(root))
    blank.set(_id_attribute(blank), "")
    blank.set("generationDateAndTime", "")
    ET.indent(blank, "  ")
    return "{" + str(uuid.uuid5(GUID_NAMESPACE, ET.tostring(blank, encoding="unicode"))) + "}"


def _build_time() -> datetime.datetime:
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch:
        return datetime.datetime.fromtimestamp(int(epoch), datetime.timezone.utc)
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)


def finish_model_description(xml: bytes) -> bytes:
    """Patch (FMI 2.0), set the deterministic GUID and the date; return the new XML."""
    root = ET.fromstring(xml)
    if root.get("fmiVersion", "").startswith("2"):
        patch_fmi2(root)
    root.set(_id_attribute(root), deterministic_guid(root))
    root.set("generationDateAndTime",
             _build_time().strftime("%Y-%m-%dT%H:%M:%SZ"))
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


#: Folders of the Linux binaries (FMI 2.0, FMI 3.0), which get libpython as a needed library.
LINUX_BINARIES = ("binaries/linux64/", "binaries/x86_64-linux/")


def rewrite_fmu(raw: Path, dest: Path) -> Path:
    """Write ``dest``: ``raw`` with its model description finished, its Linux binary
    linked to the libpython of its environment record (:mod:`smeha.fmu_native`),
    members sorted, timestamps fixed (SOURCE_DATE_EPOCH, else 1980-01-01)."""
    stamp = _build_time().timetuple()[:6] if os.environ.get("SOURCE_DATE_EPOCH") \
        else (1980, 1, 1, 0, 0, 0)
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = dest.with_name(dest.name + ".tmp")
    with zipfile.ZipFile(raw) as zin, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
        record = runtime.parse_environment(
            zin.read(f"resources/{runtime.ENVIRONMENT_FILE}").decode("utf-8"))
        for name in sorted(zin.namelist()):
            data = zin.read(name)
            if name == "modelDescription.xml":
                data = finish_model_description(data)
            elif (name.startswith(LINUX_BINARIES) and name.endswith(".so")
                  and record.get("libpython")):
                data = fmu_native.link_libpython(data, record["libpython"][0])
            info = zipfile.ZipInfo(name, date_time=stamp)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zout.writestr(info, data)
    os.replace(tmp, dest)
    return dest


# -- building -----------------------------------------------------------------------
def _stage(fmi: str, staging: Path) -> Path:
    """Copy the slave, the interface table and gmt into ``staging``; return the script."""
    module = iface.SLAVE_MODULE_FMI2 if fmi == "2" else iface.SLAVE_MODULE_FMI3
    script = FMU_SRC / f"{module}.py"
    if not script.is_file() or not (FMU_SRC / "gmt" / "__init__.py").is_file():
        raise BuildError(f"the FMU sources are missing under {FMU_SRC}: the build needs "
                         "the smeha source tree (fmu_src/ is not installed)")
    staging.mkdir(parents=True)
    shutil.copy2(script, staging / script.name)
    for module in FMU_MODULES:
        shutil.copy2(FMU_SRC / f"{module}.py", staging)
    (staging / runtime.ENVIRONMENT_FILE).write_text(runtime.format_environment(
        fmu_native.environment_record(runtime.REQUIRED_PACKAGES)), encoding="utf-8")
    shutil.copytree(FMU_SRC / "gmt", staging / iface.BUNDLED_PHYSICS_PACKAGE,
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return staging / script.name


def _worker(fmi: str, workdir: str) -> None:
    """Child process: stage the sources and run the pythonfmu(3) builder into workdir/raw."""
    work = Path(workdir)
    script = _stage(fmi, work / "src")
    sys.path.insert(0, str(script.parent))
    import smeha_fmu_interface  # the staged copy

    smeha_fmu_interface.check_against_gmt()
    project_files = [script.parent / name for name in (
        iface.BUNDLED_PHYSICS_PACKAGE, *(f"{m}.py" for m in FMU_MODULES),
        runtime.ENVIRONMENT_FILE)]
    if fmi == "2":
        from pythonfmu.builder import FmuBuilder
        FmuBuilder.build_FMU(script, dest=work / "raw", project_files=project_files,
                             **FMI2_OPTIONS)
    else:
        from pythonfmu3 import FmuBuilder as Fmu3Builder
        Fmu3Builder.build_FMU(script, dest=work / "raw", project_files=project_files,
                              **FMI3_OPTIONS)


def _child(fmi: str, workdir: str) -> int:
    """Entry point of the child process: :func:`_worker`, a known failure as a message."""
    try:
        _worker(fmi, workdir)
    except fmu_native.NativeError as exc:
        print(exc, file=sys.stderr)
        return 1
    return 0


def build(fmi: str = "2", out: str | os.PathLike = DIST, validate: bool = True) -> Path:
    """Build one FMU (``fmi`` "2" or "3") into ``out``; return its path.

    The pythonfmu builder runs in a child process (see the module docstring).

    Raises
    ------
    BuildError
        The child failed, or fmpy's validation found problems.
    """
    if fmi not in ("2", "3"):
        raise BuildError(f"fmi = {fmi!r} is not one of ('2', '3')")
    name = iface.MODEL_NAME_FMI2 if fmi == "2" else iface.MODEL_NAME_FMI3
    with tempfile.TemporaryDirectory(prefix="smeha_fmu_build_") as tmp:
        env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1",
                   PYTHONPATH=os.pathsep.join(
                       p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
        code = "import sys; from smeha.fmu_build import _child; sys.exit(_child(*sys.argv[1:]))"
        proc = subprocess.run([sys.executable, "-c", code, fmi, tmp], cwd=tmp, env=env,
                              capture_output=True, text=True)
        raw = Path(tmp) / "raw" / f"{name}.fmu"
        if proc.returncode != 0 or not raw.is_file():
            raise BuildError(f"building the FMI {fmi} FMU failed (exit {proc.returncode}):\n"
                             f"{proc.stdout}{proc.stderr}")
        try:
            dest = rewrite_fmu(raw, Path(out) / f"{name}.fmu")
        except fmu_native.NativeError as exc:
            raise BuildError(str(exc)) from None
    if validate:
        problems = validate_fmu(dest)
        if problems:
            raise BuildError(f"{dest} does not validate:\n  " + "\n  ".join(problems))
    return dest


def validate_fmu(path) -> list[str]:
    """fmpy's validation of an FMU (model description schema and structure)."""
    from fmpy.validation import validate_fmu as fmpy_validate
    return [str(p) for p in fmpy_validate(str(path))]


def build_all(fmi: str = "2", out: str | os.PathLike = DIST, validate: bool = True) -> int:
    """Build ``fmi`` ("2", "3" or "both") into ``out``, printing each FMU; return the exit status.

    A :class:`BuildError` is printed on stderr and gives status 1 (the other
    version is still built).
    """
    versions = ("2", "3") if fmi == "both" else (fmi,)
    status = 0
    for version in versions:
        try:
            path = build(version, out, validate=validate)
        except BuildError as exc:
            print(f"smeha build: error: {exc}", file=sys.stderr)
            status = 1
            continue
        checked = ", validated: no problems found" if validate else ""
        print(f"FMI {version}.0 co-simulation FMU: {path}{checked}")
    return status


def main(argv=None) -> int:
    """``python build_fmu.py [...]``: the command line of ``smeha build`` (:mod:`smeha.cli`)."""
    from .cli import main as cli_main
    return cli_main(["build", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
