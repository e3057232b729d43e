"""Build the project's FMUs: the transducer (FMI 2.0 with pythonfmu 0.7, FMI 3.0 with
pythonfmu3), and the EHA system's plant and drive (FMI 2.0).

``smeha build [--fmi 2|3|both] [--out DIR]`` (:mod:`smeha.cli`; ``python build_fmu.py``
is the same command) calls :func:`build_all`, by default into :data:`DIST`. Each FMU is
described by an :class:`FmuSpec` (:data:`SPECS`): its slave script, the modules of
``fmu_src/`` and the packages it bundles, the packages it needs at run time. For each:

1. **Build in a child process.** pythonfmu's builder imports the slave module
   and its packages and instantiates the slave; those modules stay in
   ``sys.modules``, and an FMU later loaded by the same process would run them
   instead of its bundled copies. So the builder runs in a fresh interpreter
   (:func:`_worker`), on a staging copy of the sources: the slave script, the
   FMU's other modules of ``fmu_src/`` and its packages, each under the name the FMU
   bundles it as (:func:`bundle_package`; absolute imports of another bundled
   package are renamed with it). The child checks the variable table against the
   physics, and an FMU with compiled code (the plant's numba kernel) compiles it
   there, into the staged package, so the FMU carries numba's cache. The calling
   process imports none of it (it reads the variable tables through :func:`table`).
2. **Patch the model description** (this process, XML only). FMI 2.0:
   pythonfmu 0.7 writes no units and no ``ModelStructure/InitialUnknowns``;
   :func:`patch_fmi2` adds ``UnitDefinitions`` (SI base-unit exponents from
   ``smeha_fmu_variables.UNITS``), ``unit`` on every Real (from the FMU's table) and the
   initial unknowns. FMI 3.0 declares units natively (the slave registers them).
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

import ast
import datetime
import importlib.util
import re
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

from gmt.errors import RunError

from . import loader, native
from .tables import FMU_SRC, IN_SOURCE_TREE, REPO, _load_from_fmu_src, table

__all__ = ["DIST", "installed_dist", "FmuSpec", "SPECS", "BuildError", "build_fmu",
           "build_all", "table"]

def installed_dist(cache: str | None = None) -> Path:
    """Where an installed smeha keeps its FMUs: a per-user cache folder of this installation,
    ``<cache>/smeha/<version>-<key>/``, with ``cache`` ``$XDG_CACHE_HOME`` or ``~/.cache``
    and ``key`` a hash of the installation's folder (two installations keep theirs apart;
    the same one finds its FMUs from any folder, built once)."""
    import hashlib

    from .. import __version__

    base = Path(cache or os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    key = hashlib.sha256(str(REPO).encode()).hexdigest()[:12]
    return base / "smeha" / f"{__version__}-{key}"


#: Where ``smeha build`` writes the FMUs and ``smeha simulate``/``flow``/``sweep`` look for
#: ``SmehaGmt.fmu``: dist/ of the source tree, whatever the current folder; installed from a
#: wheel, the per-user cache folder of :func:`installed_dist`. ``--out`` overrides both.
DIST = REPO / "dist" if IN_SOURCE_TREE else installed_dist()


def _iface():
    """The transducer FMU's variable table (``fmu_src/smeha_fmu_interface.py``)."""
    return table("smeha_fmu_interface")


def _runtime():
    """The FMUs' run-time set-up (``fmu_src/smeha_fmu_runtime.py``): what it needs, and the
    format of the build environment record."""
    return _load_from_fmu_src(_iface().RUNTIME_MODULE)


def _common_modules() -> tuple:
    """The modules every FMU of the project bundles: the run-time set-up, the variable record,
    the callbacks every slave shares."""
    iface = _iface()
    return (iface.RUNTIME_MODULE, iface.VARIABLES_MODULE, iface.BASE_MODULE)


def __getattr__(name):
    # ``iface`` and ``runtime`` are loaded from fmu_src/ when first asked for: importing this
    # module executes nothing of fmu_src/ (PEP 562)
    if name == "iface":
        return _iface()
    if name == "runtime":
        return _runtime()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Source of each package an FMU may bundle (under a name of its own, :class:`FmuSpec`).
PACKAGE_SOURCES = {"gmt": FMU_SRC / "gmt" if IN_SOURCE_TREE else REPO / "gmt",
                   "system_models": REPO / "system_models"}


def build_id() -> str:
    """The build identifier every FMU of this source tree records (``smeha_fmu_runtime``'s
    ``BUILD_KEY``): the first 12 hex digits of a SHA-256 of the Python sources the FMUs bundle
    (``fmu_src/*.py``, the packages of :data:`PACKAGE_SOURCES` and this module, which renames
    them, by relative path and content): the same sources give the same identifier. Every
    module and package an FMU bundles is bundled under its name and this suffix
    (:func:`bundled_names`)."""
    import hashlib

    digest = hashlib.sha256()
    files = [("build.py", Path(__file__))]
    files += [(f"fmu_src/{path.name}", path) for path in sorted(FMU_SRC.glob("*.py"))]
    for key, root in sorted(PACKAGE_SOURCES.items()):
        files += [(f"{key}/{path.relative_to(root).as_posix()}", path)
                  for path in sorted(root.rglob("*.py")) if "__pycache__" not in path.parts]
    for name, path in files:
        digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:12]


@dataclass(frozen=True)
class FmuSpec:
    """What one FMU is built from.

    Attributes
    ----------
    model_name : str
        modelIdentifier (and the file's stem, ``<model_name>.fmu``).
    fmi : {"2", "3"}
    slave : str
        The slave script, ``fmu_src/<slave>.py``.
    table : str
        The module of fmu_src/ with its variable table (``VARIABLES``, ``BY_NAME``).
    modules : tuple of str
        Other modules of fmu_src/ bundled next to the slave, under their own names.
    packages : tuple of (str, str)
        (name bundled as, key of :data:`PACKAGE_SOURCES`); each package's absolute
        imports of another one bundled here are renamed with it.
    required : tuple of str
        Packages the FMU imports at run time beyond the standard library (their
        site-packages go into the environment record).
    check : str or None
        A function of the table run in the build's child (fails the build on a mismatch
        with the physics).
    compile : str or None
        ``module:function`` (bundled names) called in the child after staging to compile
        what the FMU would otherwise compile at its first run (numba's cache).
    """

    model_name: str
    fmi: str
    slave: str
    table: str
    modules: tuple = ()
    packages: tuple = ()
    required: tuple = ()
    check: str | None = None
    compile: str | None = None

    @property
    def renames(self) -> dict:
        return {source: bundled for bundled, source in self.packages}


def _transducer(fmi: str) -> FmuSpec:
    iface = _iface()
    # bundled next to the slave: the table, the callbacks both slaves share, and the
    # modules every FMU bundles
    modules = (iface.INTERFACE_MODULE, iface.SLAVE_LOGIC_MODULE, *_common_modules())
    return FmuSpec(iface.MODEL_NAME_FMI2 if fmi == "2" else iface.MODEL_NAME_FMI3, fmi,
                   iface.SLAVE_MODULE_FMI2 if fmi == "2" else iface.SLAVE_MODULE_FMI3,
                   iface.INTERFACE_MODULE, modules,
                   ((iface.BUNDLED_PHYSICS_PACKAGE, "gmt"),), _runtime().REQUIRED_PACKAGES,
                   check="check_against_gmt")


def _plant() -> FmuSpec:
    plant = table("smeha_plant_interface")
    return FmuSpec(plant.MODEL_NAME, "2", plant.SLAVE_MODULE, plant.INTERFACE_MODULE,
                   (plant.INTERFACE_MODULE, plant.MODEL_MODULE, *_common_modules()),
                   ((plant.BUNDLED_PLANT_PACKAGE, "system_models"),
                    (plant.BUNDLED_GMT_PACKAGE, "gmt")),
                   plant.REQUIRED_PACKAGES, check="check_against_system_models",
                   compile=f"{plant.BUNDLED_PLANT_PACKAGE}.kernel:ensure_compiled")


def _drive() -> FmuSpec:
    drive = table("smeha_drive_interface")
    return FmuSpec(drive.MODEL_NAME, "2", drive.SLAVE_MODULE, drive.INTERFACE_MODULE,
                   (drive.INTERFACE_MODULE, *_common_modules()), required=(), check="check")


#: Every FMU the project builds, by key: the transducer (FMI 2.0, FMI 3.0), and the EHA
#: system's hydraulic plant and drive signal (docs/FMU.md, "The EHA as an FMI system").
SPECS = {"transducer2": lambda: _transducer("2"), "transducer3": lambda: _transducer("3"),
         "plant": _plant, "drive": _drive}


def spec(key: str) -> FmuSpec:
    """The :class:`FmuSpec` of ``key`` (a key of :data:`SPECS`)."""
    if key not in SPECS:
        raise BuildError(f"FMU {key!r} is not one of {tuple(SPECS)}")
    return SPECS[key]()


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


class BuildError(RunError):
    """The FMU could not be built or does not validate (a :class:`gmt.errors.RunError`)."""


# -- model description --------------------------------------------------------------
def _insert_in_order(parent, element, order):
    rank = order.index(element.tag)
    for i, child in enumerate(list(parent)):
        if child.tag in order and order.index(child.tag) > rank:
            parent.insert(i, element)
            return
    parent.append(element)


def patch_fmi2(root: ET.Element, variables=None) -> ET.Element:
    """Add units and InitialUnknowns to a pythonfmu 0.7 model description (in place).

    * ``UnitDefinitions`` with the units the variables use, each with its SI
      ``BaseUnit`` exponents (none for a unit integer exponents cannot express);
    * ``unit`` on every ``Real`` (from ``variables``, the FMU table's ``BY_NAME``;
      default the transducer's);
    * ``ModelStructure/InitialUnknowns``: every output (initial calculated) and
      calculated parameter, by 1-based index in ModelVariables (pythonfmu issue #193).
    """
    iface = _iface()
    by_name = iface.BY_NAME if variables is None else variables
    for old in root.findall("UnitDefinitions"):
        root.remove(old)
    svs = root.find("ModelVariables").findall("ScalarVariable")
    used = sorted({by_name[sv.get("name")].unit for sv in svs
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
            real.set("unit", by_name[sv.get("name")].unit)
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


def finish_model_description(xml: bytes, variables=None) -> bytes:
    """Patch (FMI 2.0; ``variables`` as :func:`patch_fmi2`), set the deterministic GUID and the
    date; return the new XML."""
    root = ET.fromstring(xml)
    if root.get("fmiVersion", "").startswith("2"):
        patch_fmi2(root, variables)
    root.set(_id_attribute(root), deterministic_guid(root))
    root.set("generationDateAndTime",
             _build_time().strftime("%Y-%m-%dT%H:%M:%SZ"))
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


#: Folders of the Linux binaries (FMI 2.0, FMI 3.0), which get libpython as a needed library.
LINUX_BINARIES = ("binaries/linux64/", "binaries/x86_64-linux/")


def _linux_binaries(zin: zipfile.ZipFile) -> dict:
    """The FMU's Linux binary members: the loader (:mod:`smeha.fmu.loader`) as
    ``<modelIdentifier>.so`` and pythonfmu's binary beside it, or, where the loader cannot be
    compiled (the reason is printed), pythonfmu's binary linked to the building interpreter's
    libpython (:mod:`smeha.fmu.native`)."""
    root = ET.fromstring(zin.read("modelDescription.xml"))
    fmi = root.get("fmiVersion", "2")[0]
    ident = root.find("CoSimulation").get("modelIdentifier")
    out = {}
    for name in zin.namelist():
        if not (name.startswith(LINUX_BINARIES) and name == f"{name.rsplit('/', 1)[0]}/"
                f"{ident}.so"):
            continue
        data = zin.read(name)
        try:
            out[name] = loader.compile_loader(fmi, ident, root.get("modelName", ident),
                                              FMU_SRC / loader.SOURCE_NAME)
            out[name[:-len(".so")] + loader.TARGET_SUFFIX] = data
        except loader.LoaderError as exc:
            print(f"smeha build: note: no loader for {ident} ({exc}): its binary runs with "
                  "the build's Python only (docs/FMU.md)", file=sys.stderr)
            # the fallback names the building libpython in the binary: it runs where that is
            out[name] = (native.link_libpython(data, str(native.find_libpython()))
                         if sys.platform.startswith("linux") else data)
    return out


def rewrite_fmu(raw: Path, dest: Path, variables=None, extra=None) -> Path:
    """Write ``dest``: ``raw`` with its model description finished (``variables`` as
    :func:`patch_fmi2`), the members ``extra`` (archive name -> bytes) added, its Linux binary
    the loader (:func:`_linux_binaries`), members sorted, timestamps fixed
    (SOURCE_DATE_EPOCH, else 1980-01-01)."""
    stamp = _build_time().timetuple()[:6] if os.environ.get("SOURCE_DATE_EPOCH") \
        else (1980, 1, 1, 0, 0, 0)
    dest.parent.mkdir(parents=True, exist_ok=True)
    # a temporary name of its own: two processes building the same FMU at once (test
    # workers, two shells) each rename a whole file onto dest, the same bytes either way
    fd, tmp_name = tempfile.mkstemp(dir=dest.parent, prefix=f".{dest.name}.", suffix=".tmp")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        with zipfile.ZipFile(raw) as zin, \
                zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zout:
            members = {name: None for name in zin.namelist()}
            members.update(extra or {})
            members.update(_linux_binaries(zin))
            for name in sorted(members):
                data = zin.read(name) if members[name] is None else members[name]
                if name == "modelDescription.xml":
                    data = finish_model_description(data, variables)
                info = zipfile.ZipInfo(name, date_time=stamp)
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                zout.writestr(info, data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, dest)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return dest


# -- building -----------------------------------------------------------------------
def rename_imports(text: str, renames: dict, where: str = "") -> str:
    """``text`` (Python source) with its absolute imports of the packages in ``renames``
    (name -> bundled name) rewritten to the bundled names.

    ``from gmt.errors import x`` becomes ``from <bundled>.errors import x`` and
    ``import gmt`` becomes ``import <bundled> as gmt``; any other form of import of a
    renamed package is a :class:`BuildError` (checked again on the result).
    """
    lines = text.splitlines(keepends=True)
    for node in ast.walk(ast.parse(text, where)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            top = node.module.split(".")[0]
            if top in renames:
                i = node.lineno - 1
                lines[i] = re.sub(rf"\bfrom\s+{top}\b", f"from {renames[top]}", lines[i],
                                  count=1)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in renames and alias.asname is None and len(node.names) == 1:
                    i = node.lineno - 1
                    lines[i] = re.sub(rf"\bimport\s+{alias.name}\b",
                                      f"import {renames[alias.name]} as {alias.name}", lines[i],
                                      count=1)
    out = "".join(lines)
    for node in ast.walk(ast.parse(out, where)):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0
                 else [])
        if any(n and n.split(".")[0] in renames for n in names):
            raise BuildError(f"{where}:{node.lineno}: an import of {names} the build cannot "
                             f"rename to the bundled {sorted(renames.values())}")
    return out


def bundle_package(source: Path, dest: Path, renames: dict) -> None:
    """Copy package ``source`` to ``dest`` (no caches), its imports renamed
    (:func:`rename_imports`)."""
    shutil.copytree(source, dest, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for path in sorted(dest.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        renamed = rename_imports(text, renames, str(path.relative_to(dest.parent)))
        if renamed != text:
            path.write_text(renamed, encoding="utf-8")


def bundled_names(fmu: FmuSpec, build: str | None = None) -> dict:
    """Every module of ``fmu_src/`` and every package ``fmu`` bundles -> the name this build
    bundles it under, ``<name>_<build>`` (``build``: :func:`build_id`).

    One Python interpreter serves every pythonfmu FMU of a host process, and it keeps one
    module per name: pythonfmu imports each FMU's slave module by the name in its
    ``slavemodule.txt``, and the slave imports the rest by name. Under names of their own
    build, the modules of FMUs built from other sources never meet: each FMU runs its own
    build's code beside any other, and FMUs of one build share theirs."""
    build = build or build_id()
    names = {path.stem for path in FMU_SRC.glob("*.py") if not path.stem.startswith("_")}
    names.update(bundled for bundled, _ in fmu.packages)
    return {name: f"{name}_{build}" for name in sorted(names)}


def rename_modules(text: str, names: dict) -> str:
    """``text`` with every whole-word occurrence of a key of ``names`` replaced by its value:
    imports, and the names the bundled code passes to importlib (its ``BUNDLED_*`` constants)."""
    if not names:
        return text
    pattern = re.compile(r"\b(" + "|".join(map(re.escape, sorted(names, key=len, reverse=True)))
                         + r")\b")
    return pattern.sub(lambda m: names[m.group(1)], text)


def _stage(fmu: FmuSpec, staging: Path, names: dict) -> Path:
    """Copy the slave, its modules and packages into ``staging`` under their bundled
    ``names`` (:func:`bundled_names`), every name in them renamed; return the script."""
    script = FMU_SRC / f"{fmu.slave}.py"
    missing = [str(p) for p in (script, *(FMU_SRC / f"{m}.py" for m in fmu.modules),
                                *(PACKAGE_SOURCES[k] / "__init__.py" for _, k in fmu.packages))
               if not p.is_file()]
    if missing:
        raise BuildError(f"the FMU sources are missing ({', '.join(missing)}): the build needs "
                         "the smeha source tree (fmu_src/ and system_models/ as checked out)")
    staging.mkdir(parents=True)
    for module in (fmu.slave, *fmu.modules):
        (staging / f"{names[module]}.py").write_text(rename_modules(
            (FMU_SRC / f"{module}.py").read_text(encoding="utf-8"), names), encoding="utf-8")
    record = native.environment_record(fmu.required)
    record[_runtime().BUILD_KEY] = [names[fmu.slave][len(fmu.slave) + 1:]]
    (staging / _runtime().ENVIRONMENT_FILE).write_text(_runtime().format_environment(record),
                                                       encoding="utf-8")
    for bundled, key in fmu.packages:
        dest = staging / names[bundled]
        bundle_package(PACKAGE_SOURCES[key], dest, fmu.renames)
        for path in sorted(dest.rglob("*.py")):
            path.write_text(rename_modules(path.read_text(encoding="utf-8"), names),
                            encoding="utf-8")
    return staging / f"{names[fmu.slave]}.py"


def _worker(key: str, workdir: str) -> None:
    """Child process: stage the sources, check, compile, run the pythonfmu(3) builder into
    workdir/raw."""
    fmu = spec(key)
    work = Path(workdir)
    names = bundled_names(fmu)
    script = _stage(fmu, work / "src", names)
    sys.path.insert(0, str(script.parent))
    if fmu.check:
        getattr(importlib.import_module(names[fmu.table]), fmu.check)()  # the staged copy
    if fmu.compile:
        module, function = rename_modules(fmu.compile, names).split(":")
        getattr(importlib.import_module(module), function)()
    project_files = [script.parent / name for name in (
        *(names[bundled] for bundled, _ in fmu.packages),
        *(f"{names[m]}.py" for m in fmu.modules), _runtime().ENVIRONMENT_FILE)]
    if fmu.fmi == "2":
        from pythonfmu.builder import FmuBuilder
        FmuBuilder.build_FMU(script, dest=work / "raw", project_files=project_files,
                             **FMI2_OPTIONS)
    else:
        from pythonfmu3 import FmuBuilder as Fmu3Builder
        Fmu3Builder.build_FMU(script, dest=work / "raw", project_files=project_files,
                              **FMI3_OPTIONS)


def _child(key: str, workdir: str) -> int:
    """Entry point of the child process: :func:`_worker`, a known failure as a message."""
    try:
        _worker(key, workdir)
    except (native.NativeError, BuildError) as exc:
        print(exc, file=sys.stderr)
        return 1
    return 0


def build(fmi: str = "2", out: str | os.PathLike = DIST, validate: bool = True) -> Path:
    """Build one transducer FMU (``fmi`` "2" or "3") into ``out``; return its path.

    Raises
    ------
    BuildError
        The child failed, or fmpy's validation found problems.
    """
    if fmi not in ("2", "3"):
        raise BuildError(f"fmi = {fmi!r} is not one of ('2', '3')")
    return build_fmu(f"transducer{fmi}", out, validate)


def build_fmu(key: str, out: str | os.PathLike = DIST, validate: bool = True) -> Path:
    """Build the FMU ``key`` (a key of :data:`SPECS`) into ``out``; return its path.

    The pythonfmu builder runs in a child process (see the module docstring).

    Raises
    ------
    BuildError
        The child failed, or fmpy's validation found problems.
    """
    fmu = spec(key)
    with tempfile.TemporaryDirectory(prefix="smeha_fmu_build_") as tmp:
        env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1",
                   PYTHONPATH=os.pathsep.join(
                       p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
        code = "import sys; from smeha.fmu.build import _child; sys.exit(_child(*sys.argv[1:]))"
        proc = subprocess.run([sys.executable, "-c", code, key, tmp], cwd=tmp, env=env,
                              capture_output=True, text=True)
        raw = Path(tmp) / "raw" / f"{fmu.model_name}.fmu"
        if proc.returncode != 0 or not raw.is_file():
            raise BuildError(f"building the {fmu.model_name} FMU (FMI {fmu.fmi}) failed "
                             f"(exit {proc.returncode}):\n{proc.stdout}{proc.stderr}")
        try:
            dest = rewrite_fmu(raw, Path(out) / f"{fmu.model_name}.fmu",
                               table(fmu.table).BY_NAME, _compiled(fmu, Path(tmp) / "src"))
        except native.NativeError as exc:
            raise BuildError(str(exc)) from None
    if validate:
        problems = validate_fmu(dest)
        if problems:
            raise BuildError(f"{dest} does not validate:\n  " + "\n  ".join(problems))
    return dest


def _compiled(fmu: FmuSpec, staging: Path) -> dict:
    """numba's cache the child compiled into the staged packages, as FMU members (pythonfmu
    leaves ``__pycache__`` out). Its index is keyed by the source's content, not its path,
    so the extracted FMU loads it; a host on another CPU compiles again, at its first run."""
    if not fmu.compile:
        return {}
    names = bundled_names(fmu)
    return {f"resources/{path.relative_to(staging).as_posix()}": path.read_bytes()
            for bundled, _ in fmu.packages
            for path in sorted((staging / names[bundled]).rglob("__pycache__/*.nb[ic]"))}


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

