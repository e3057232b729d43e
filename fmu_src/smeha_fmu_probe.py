"""Where a CPython's shared libpython is, and what a candidate Python tells the FMU's loader.

One implementation for the build and the run time: ``smeha.fmu.native.find_libpython`` calls
:func:`shared_libpython` in the building interpreter, and the build compiles this file's
text into the FMU's loader (``smeha.fmu.loader``), which runs it as ``python3 -c`` in each
candidate Python it considers (``smeha_fmu_loader.c``). It therefore imports only the
standard library and runs under any CPython 3.

Run as a script with package names as arguments it prints three lines: ``sys.hexversion``,
the shared libpython's path (empty when there is none) and the names it cannot import.
"""
import importlib.util
import os
import sys
import sysconfig

#: CPython versions the FMU runs in (major, minor), newest first: the loader's last resort
#: loads their shared libraries by soname, in this order.
SUPPORTED = ((3, 13), (3, 12), (3, 11))


def shared_libpython():
    """This interpreter's shared libpython, [path], or None.

    ``LIBDIR/INSTSONAME`` (a ``--enable-shared`` build such as pyenv's), else the same name
    in the multiarch directory (Debian's statically linked ``/usr/bin/python3.11`` with the
    ``libpython3.11`` package installed).
    """
    var = sysconfig.get_config_var
    soname = var("INSTSONAME") or ""
    if not soname.endswith(".so") and ".so." not in soname:
        soname = "libpython%s%s.so.1.0" % (var("VERSION"), var("ABIFLAGS") or "")
    folders = [var("LIBDIR") or ""]
    if var("MULTIARCH"):
        folders.append(os.path.join("/usr/lib", var("MULTIARCH")))
    for folder in folders:
        path = os.path.join(folder, soname)
        if os.path.isfile(path):
            return os.path.realpath(path)
    return None


def report(packages):
    """The three lines the loader reads (module docstring)."""
    missing = [name for name in packages if importlib.util.find_spec(name) is None]
    return "%d\n%s\n%s\n" % (sys.hexversion, shared_libpython() or "", " ".join(missing))


if __name__ == "__main__":
    sys.stdout.write(report(sys.argv[1:]))
