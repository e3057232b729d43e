"""The FMU's sources stand alone (issue 13 item 6): fast checks without building an FMU.

Everything the FMU runs is bundled from ``fmu_src/`` (the slaves, the variable table
``smeha_fmu_interface.py`` and ``gmt``); none of it may import the ``smeha`` package, which
an FMU does not carry.
"""
from __future__ import annotations

import ast
from pathlib import Path

FMU_SRC = Path(__file__).resolve().parents[1] / "fmu_src"


def _imported_modules(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_nothing_in_fmu_src_imports_smeha():
    sources = sorted(FMU_SRC.rglob("*.py"))
    assert any(p.name == "smeha_fmu_interface.py" for p in sources)
    offenders = {str(p.relative_to(FMU_SRC)): sorted(m for m in _imported_modules(p)
                                                     if m == "smeha" or m.startswith("smeha."))
                 for p in sources}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_build_reads_the_table_from_fmu_src_under_its_own_name():
    # the smeha process must not register the table as smeha_fmu_interface: an FMU it loads
    # later imports that name and must get its own bundled copy
    from smeha.fmu_build import iface

    assert Path(iface.__file__) == FMU_SRC / "smeha_fmu_interface.py"
    assert iface.__name__ != iface.INTERFACE_MODULE == "smeha_fmu_interface"
