"""The FMU's Python run time: which interpreter it runs in and where its packages are.

A pythonfmu FMU embeds no Python: its binary calls the CPython of the host process, or,
in a host that has none (a C or C++ tool), the one the FMU's loader found and started
(``smeha_fmu_loader.c``: ``SMEHA_FMU_PYTHON``, ``python3`` on ``PATH``, the system's
libpython). An FMU built without the loader (no C compiler) starts
the ``libpython`` the build made a needed library of pythonfmu's binary
(``smeha.fmu.build``). Each slave calls :func:`prepare` as its first statement,
before pythonfmu, numpy or gmt are imported, because three things may need
mending first, in this order:

1. **The Python C API must be visible to extension modules.** A host that is
   not a Python program loads the FMU with ``dlopen(RTLD_LOCAL)``: libpython,
   loaded as the FMU's needed library, then serves the FMU binary only, and
   every extension module (``math``, ``_ctypes``, numpy's) fails to load with
   ``undefined symbol: PyFloat_Type`` or the like. :func:`promote_libpython`
   re-opens the loaded libpython (:func:`loaded_libpython`) with ``RTLD_GLOBAL | RTLD_NOLOAD``
   (glibc then adds it to the global scope, dlopen(3)). In a Python host the C
   API is already global (the executable or its libpython): nothing changes, and
   ``RTLD_NOLOAD`` never loads a library that is not there.
2. **The standard library must be the interpreter's own.** An interpreter
   started inside a C host finds its prefix by looking for ``python3`` on
   ``PATH`` (CPython's ``getpath``), so with ``PATH=/usr/bin:/bin`` the build's
   libpython runs with the system's standard library, which lacks modules it
   expects. When the running libpython is the build's (same ``sys.version``)
   and its installation's prefix (the folder above the ``lib`` holding it) is not
   ``sys.base_prefix``, :func:`restore_standard_library` puts that installation's
   standard library on ``sys.path`` instead. A Python host's own interpreter (a
   different ``sys.version``, or the right prefix) is left alone.
3. **The packages the FMU needs must be importable** (:func:`required_packages`:
   numpy for the transducer, numpy and numba for the hydraulic plant): the ones this
   Python cannot import are named, and every instance of the FMU says so at Error level.

And one thing at exit (:func:`arm_clean_exit`, called by each slave when it is
instantiated): pythonfmu's export library (0.7 and pythonfmu3 0.3.4 alike)
keeps its interpreter state in a namespace-scope ``std::shared_ptr`` and also
resets that pointer from its ELF destructor. At ``exit()`` the C++ static
destructor runs first (``__cxa_atexit``) and frees the state, then the ELF
destructor (``_dl_fini``) resets the already destroyed pointer and releases the
freed block a second time: a use after free (valgrind: "invalid read in
finalizePythonInterpreter ... block free'd by __run_exit_handlers") that
corrupts the heap, and a later ``free`` aborts ("corrupted unsorted chunks") or
segfaults, in about half the runs of a C host. The library exports the
function its destructor calls, ``finalizePythonInterpreter``; registered with
``__cxa_atexit`` after the library's own handlers, it runs before them, resets
the pointer once (finalising the interpreter the FMU started, if it started
one), and leaves both later calls a null pointer, which they handle.

This module runs before the standard library can be trusted: it imports only
built-in and frozen modules (``sys``, ``os``, ``_imp``). The build's record is read
from :data:`ENVIRONMENT_FILE`, a text file the build writes next to it (one
``key<TAB>value`` per line; keys may repeat): the building interpreter's version and
the required packages, no path.
"""
from __future__ import annotations

import os
import sys

#: File the build writes into the FMU's resources: the interpreter version it was built with
#: and the packages it needs.
ENVIRONMENT_FILE = "smeha_fmu_environment.txt"
#: Top-level packages the transducer FMU imports at run time beyond the standard library
#: (another FMU's build records its own in the environment record, :func:`required_packages`).
REQUIRED_PACKAGES = ("numpy",)

#: Key of the build identifier in the environment record (``smeha.fmu.build.build_id``): a
#: hash of the Python sources the project's FMUs bundle, and the suffix of the names they are
#: bundled under.
BUILD_KEY = "build"

#: What :func:`prepare` did and found for the FMU that called it last, for messages and tests.
REPORT: dict = {}


def parse_environment(text: str) -> dict:
    """The build environment record: key -> list of values (see the module docstring)."""
    record: dict = {}
    for line in text.splitlines():
        if line and not line.startswith("#") and "\t" in line:
            key, value = line.split("\t", 1)
            record.setdefault(key, []).append(value)
    return record


def format_environment(record: dict) -> str:
    """The text of an environment record (the inverse of :func:`parse_environment`)."""
    lines = ["# The Python environment this FMU was built in (smeha.fmu.build), read by "
             "smeha_fmu_runtime.py"]
    for key, values in record.items():
        lines.extend(f"{key}\t{value}" for value in values)
    return "\n".join(lines) + "\n"


class _Spec:
    """The two attributes ``_imp.create_dynamic`` reads from a module spec."""

    def __init__(self, name, origin):
        self.name, self.origin = name, origin


def promote_libpython(path: str) -> str:
    """Re-open the loaded libpython at ``path`` with RTLD_GLOBAL; return what happened.

    ``_imp.create_dynamic`` opens a file with ``sys.getdlopenflags()`` before it
    looks for a module init function; libpython has none, so the call fails
    after the ``dlopen`` has done its work, and the failure is expected.
    """
    if not path or not os.path.isfile(path):
        return f"no libpython at {path!r}"
    import _imp

    flags = sys.getdlopenflags()
    sys.setdlopenflags(os.RTLD_NOW | os.RTLD_GLOBAL | os.RTLD_NOLOAD)
    try:
        _imp.create_dynamic(_Spec("smeha_fmu_libpython", path))
    except ImportError as exc:
        # "does not define module export function": opened (and now global);
        # anything else (not loaded in this process): left alone
        return "global" if "export function" in str(exc) else f"not loaded ({exc})"
    finally:
        sys.setdlopenflags(flags)
    return "global"  # pragma: no cover - libpython defines no PyInit_ function


def _in_standard_location(path: str, roots) -> bool:
    """Whether ``path`` is ``<root>/[local/]lib/python3...`` (library, zip, site dirs)."""
    for root in roots:
        root = root.rstrip(os.sep) + os.sep
        if path.startswith(root):
            parts = path[len(root):].split(os.sep)
            parts = parts[1:] if parts[0] == "local" else parts
            if len(parts) >= 2 and parts[0] == "lib" and parts[1].startswith("python3"):
                return True
    return False


def loaded_libpython() -> str:
    """Path of the shared libpython mapped into this process, or "" (Linux ``/proc``)."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                path = line.rstrip("\n").split(None, 5)[-1]
                if os.path.basename(path).startswith("libpython3") and ".so" in path:
                    return path
    except OSError:
        pass
    return ""


def restore_standard_library(record: dict, libpython: str) -> bool:
    """Put the standard library of the installation holding ``libpython`` on ``sys.path``
    if another one is there.

    Only when the running interpreter is the build's (same ``sys.version``) and started
    with another prefix, which happens when an FMU linked to its libpython starts it in a
    host that is not a Python program. Returns True if it changed anything.
    """
    version = (record.get("version") or [None])[0]
    prefix = os.path.dirname(os.path.dirname(libpython)) if libpython else ""
    minor = "%d.%d" % sys.version_info[:2]
    stdlib = os.path.join(prefix, "lib", "python" + minor)
    if (sys.version != version or not prefix or sys.base_prefix == prefix
            or not os.path.isfile(os.path.join(stdlib, "os.py"))):
        return False
    wrong = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix}
    kept = [p for p in sys.path if not _in_standard_location(p, wrong)]
    ours = [os.path.join(prefix, "lib", "python%d%d.zip" % sys.version_info[:2]), stdlib,
            os.path.join(stdlib, "lib-dynload")]
    sys.path[:] = kept + [p for p in ours if p not in kept]
    sys.prefix = sys.base_prefix = sys.exec_prefix = sys.base_exec_prefix = prefix
    return True


def _missing(packages) -> list[str]:
    from importlib.machinery import PathFinder  # frozen; the standard library is set by now

    return [name for name in packages
            if name not in sys.modules and PathFinder.find_spec(name, sys.path) is None]


def required_packages(record: dict) -> tuple:
    """The packages an FMU needs at run time: its record's ``required`` entries (an empty
    entry: none beyond the standard library), else :data:`REQUIRED_PACKAGES`."""
    if "required" not in record:
        return REQUIRED_PACKAGES
    return tuple(name for name in record["required"] if name)


def find_packages(packages=REQUIRED_PACKAGES) -> list[str]:
    """The ``packages`` this interpreter cannot import."""
    return _missing(packages)


#: FMU binaries whose exit handler :func:`arm_clean_exit` has registered.
_ARMED: set = set()


def _mapped_binaries(model_identifier: str) -> list[str]:
    """Paths of the loaded shared objects named ``<model_identifier>.so`` (Linux)."""
    name = f"{os.sep}{model_identifier}.so"
    found = []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                path = line.rstrip("\n").split(None, 5)[-1]
                if path.endswith(name) and path not in found:
                    found.append(path)
    except OSError:
        pass
    return found


def arm_clean_exit(model_identifier: str) -> list[str]:
    """Register the FMU binary's ``finalizePythonInterpreter`` to run at exit (module docstring).

    Once per binary and process; returns the binaries newly armed. Linux only
    (pythonfmu resets the pointer from ``DllMain`` on Windows, where this bug
    does not arise in the same way); a failure leaves things as they were.
    """
    if not sys.platform.startswith("linux"):
        return []
    armed = []
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", mode=os.RTLD_LAZY | os.RTLD_NOLOAD)
        register = libc.__cxa_atexit
        register.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
        register.restype = ctypes.c_int
        for path in _mapped_binaries(model_identifier):
            if path in _ARMED:
                continue
            library = ctypes.CDLL(path, mode=os.RTLD_LAZY | os.RTLD_NOLOAD)
            finalize = getattr(library, "finalizePythonInterpreter", None)
            if finalize is None:
                continue
            if register(ctypes.cast(finalize, ctypes.c_void_p), None, None) == 0:
                _ARMED.add(path)
                armed.append(path)
    except (OSError, AttributeError):
        pass
    return armed


def prepare(resources: str | None = None) -> dict:
    """Steps 1-3 of the module docstring; return :data:`REPORT`.

    Steps 1 and 2 are done once per process (again, harmlessly, by another build's copy of
    this module); step 3 once per FMU, since the FMUs of one build share this module (by
    name) in one process but each records its own packages: each slave passes its own
    resources folder.

    Parameters
    ----------
    resources : str, optional
        Directory holding :data:`ENVIRONMENT_FILE` (default: this module's).
    """
    folder = os.path.abspath(resources or os.path.dirname(os.path.abspath(__file__)))
    if folder in _PREPARED:
        REPORT.clear()
        REPORT.update(_PREPARED[folder])
        return REPORT
    report = {}
    try:
        with open(os.path.join(folder, ENVIRONMENT_FILE), encoding="utf-8") as fh:
            record = parse_environment(fh.read())
    except OSError as exc:
        record = {}
        report["environment"] = f"no build environment record ({exc})"
    if not _PREPARED:
        libpython = loaded_libpython()
        _PROCESS["libpython"] = promote_libpython(libpython)
        _PROCESS["standard_library_restored"] = restore_standard_library(record, libpython)
    report.update(_PROCESS)
    report["missing"] = find_packages(required_packages(record))
    _PREPARED[folder] = report
    REPORT.clear()
    REPORT.update(report)
    return REPORT


#: What :func:`prepare` did once per process (steps 1-2), and per resources folder.
_PROCESS: dict = {}
_PREPARED: dict = {}


def missing_packages_message() -> str | None:
    """Why the FMU whose :func:`prepare` ran last cannot run in this Python, or None when it can."""
    missing = REPORT.get("missing")
    if not missing:
        return None
    return (f"the FMU needs the Python package(s) {', '.join(missing)}, which this process's "
            f"Python {sys.version.split()[0]} (prefix {sys.prefix}) cannot import: install "
            f"them into it (pip install {' '.join(missing)}) or run the FMU in a Python that "
            "has them (docs/FMU.md)")
