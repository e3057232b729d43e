"""The FMUs' sources (``fmu_src/``) and their variable tables, found and loaded.

Where the sources are: the source tree's ``fmu_src/`` in a checkout, ``smeha/fmu/sources/`` in
an installed wheel (pyproject's package-dir). A variable table (``fmu_src/<module>.py``) is
loaded under a private name, so that an FMU this process loads later imports its own bundled
copy. This module imports nothing of the FMU tooling: :mod:`smeha.fmu.build` and
:mod:`smeha.fmu.native` both read it.
"""
from __future__ import annotations

import ast
import importlib.util
import sys
from pathlib import Path

__all__ = ["REPO", "IN_SOURCE_TREE", "FMU_SRC", "table"]

#: The folder holding the packages: the source tree's root in a checkout (also under
#: ``pip install -e``), site-packages in an installed wheel.
REPO = Path(__file__).resolve().parents[2]
#: Whether smeha runs from its source tree; an installed wheel carries the FMU sources as
#: package data, ``smeha/fmu/sources/`` (pyproject's package-dir).
IN_SOURCE_TREE = (REPO / "fmu_src" / "smeha_fmu_interface.py").is_file()
FMU_SRC = REPO / "fmu_src" if IN_SOURCE_TREE else Path(__file__).resolve().parent / "sources"


def _fmu_src_neighbours(module: str) -> list[str]:
    """The modules of fmu_src/ that ``fmu_src/<module>.py`` imports by name at its top level."""
    tree = ast.parse((FMU_SRC / f"{module}.py").read_text(encoding="utf-8"))
    names = []
    for node in tree.body:
        found = ([a.name for a in node.names] if isinstance(node, ast.Import)
                 else [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0
                 else [])
        names += [n for n in found if n and (FMU_SRC / f"{n}.py").is_file()]
    return names


def _load_from_fmu_src(module: str):
    """``fmu_src/<module>.py`` loaded from the source tree as ``smeha._<module>``.

    Under a name of its own: registered under its file's name, an FMU this
    process loads later would import this copy instead of the one bundled in
    its resources. The neighbours it imports by name (``smeha_fmu_variables``)
    are loaded the same way and lent under their own names only while it executes.
    """
    name = f"smeha._{module}"
    if name in sys.modules:
        return sys.modules[name]
    lent = {n: _load_from_fmu_src(n) for n in _fmu_src_neighbours(module)}
    saved = {n: sys.modules.get(n) for n in lent}
    spec = importlib.util.spec_from_file_location(name, FMU_SRC / f"{module}.py")
    loaded = importlib.util.module_from_spec(spec)
    sys.modules[name] = loaded  # dataclasses look their module up while it executes
    sys.modules.update(lent)
    try:
        spec.loader.exec_module(loaded)
    finally:
        for n, previous in saved.items():
            if previous is None:
                sys.modules.pop(n, None)
            else:
                sys.modules[n] = previous
    return loaded


def table(module: str):
    """An FMU's variable table (``fmu_src/<module>.py``), loaded under a private name."""
    return _load_from_fmu_src(module)
