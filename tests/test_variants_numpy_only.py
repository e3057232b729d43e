"""The FMU's run-time path imports numpy only: the extensions' part.

Every model variant the FMU can run (each extension of gmt.extensions.REGISTRY, and
combinations) is built and stepped in a fresh interpreter in which scipy and python-control
cannot be imported once gmt is loaded: a step form that imported or called either would
fail there. The extensions' modules must not import them at module level either (they are
imported with gmt); that is checked on their source. (gmt's core modules are checked by the
FMU's own tests.)
"""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import gmt
import pytest
from gmt import extensions as ext

EXTENSIONS_DIR = Path(gmt.__file__).parent / "extensions"

SCRIPT = r"""
import math, sys
import gmt
import pytest
from gmt import extensions as ext

# the paper's model first: what gmt's core imports is the FMU's core tests' business
gmt.Transducer(gmt.TransducerParameters(), gmt.Excitation(100.0, 1.0)).step(0.5, 1e-5)
BEFORE = set(sys.modules)


class Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("scipy", "control"):
            raise ImportError(f"{name} imported by a variant's run-time path")
        return None


sys.meta_path.insert(0, Refuse())
P = gmt.TransducerParameters()
context = {"params": P, "field_max": P.field_per_ampere}
singles = []
for e in ext.EXTENSIONS:
    x = list(e.fit.starts[0])
    if e.form == "lag":
        x = [-3.0, 0.5]  # a fractional lag: the bank of sections (non-negative least squares)
    singles.append(gmt.ModelVariant(e.cause, e.from_fit(x, context), e.form))
by_name = {v.name: v for v in singles}
variants = singles + [
    gmt.ModelVariant.combine(by_name["eddy_current_diffusion:cylinder"],
                             by_name["rate_independent_hysteresis"],
                             by_name["magnetization_saturation"]),
    gmt.ModelVariant.combine(by_name["eddy_current_diffusion"], by_name["transport_delay"],
                             by_name["mechanical_resonance:two_dof"], by_name["thermal_drift"]),
]
for v in variants:
    for compensated in (False, True):
        tr = gmt.Transducer(P, gmt.Excitation(100.0, 1.0),
                            gmt.DriveParameters(compensated=compensated), variant=v)
        for k in range(300):
            u = math.cos(2 * math.pi * 100.0 * k * 1e-5)
            tr.step(1.5 + 1.5 * u if compensated else u, 1e-5 if k % 3 else 2.5e-5, 5.0)
        tr.set_state(tr.get_state())
bad = sorted(m for m in sys.modules if m.split(".")[0] in ("scipy", "control")
             and m not in BEFORE)
print("ok", len(variants), bad)
"""


@pytest.mark.integration  # a fresh interpreter stepping every variant, 2-10 s
def test_every_variant_steps_without_scipy_or_control():
    # modules gmt itself already loaded (its core modules, until they are numpy-only) are
    # allowed; anything a variant would import afterwards is refused
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    # every single extension and the two combinations
    assert proc.stdout.strip() == f"ok {len(ext.EXTENSIONS) + 2} []", proc.stdout


def test_extension_modules_import_neither_at_module_level():
    for path in sorted(EXTENSIONS_DIR.glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in tree.body:  # module level only; a function may import lazily
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            assert not any(n.split(".")[0] in ("scipy", "control") for n in names), (path, names)
