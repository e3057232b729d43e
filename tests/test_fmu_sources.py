"""The FMU's sources stand alone: fast checks without building an FMU.

Everything the FMU runs is bundled from ``fmu_src/`` (the slaves, the variable table
``smeha_fmu_interface.py`` and ``gmt``); none of it may import the ``smeha`` package, which
an FMU does not carry.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

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
    from smeha.fmu.build import iface

    assert Path(iface.__file__) == FMU_SRC / "smeha_fmu_interface.py"
    assert iface.__name__ != iface.INTERFACE_MODULE == "smeha_fmu_interface"


#: Child: everything the FMU's slave does with the paper's model -- build the transducer from
#: the FMU's start values (uncompensated and compensated, calibrated and measured B_m, a bad
#: B_m whose error message needs the root of eq 20), step it, save and restore its state --
#: then list the modules it imported. Run from the source tree, as the bundled copy runs.
_RUN_TIME_PATH = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import smeha_fmu_interface as iface
import smeha_fmu_slave as slave
gmt, problem = slave.load_physics()
assert problem is None, problem
values = {v.name: v.start for v in iface.VARIABLES if v.causality == "parameter"}
for extra in ({}, {"compensated": True}, {"flux_density_amplitude": 0.0531, "frequency": 100.0},
              {"compensated": True, "branch_rule": "demand", "current_limit": 0.5}):
    tr = slave.make_transducer(dict(values, **extra))
    for k in range(200):
        out = tr.step(1.0 + 0.5 * (k % 7), 1e-5 * (1 + k % 3), 3.0)
    tr.set_state(tr.get_state())
try:
    slave.make_transducer(dict(values, flux_density_amplitude=5.0))
except gmt.ParameterError as exc:
    assert "allowed range" in str(exc)
print(json.dumps(sorted(sys.modules)))
"""


def test_fmu_run_time_path_imports_numpy_only():
    # scipy and python-control must never load in the FMU's process
    # (minimal FMUs importing scipy crash the host at exit, numpy-only ones do not)
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", _RUN_TIME_PATH, str(FMU_SRC)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    modules = json.loads(proc.stdout)
    assert "numpy" in modules and "gmt" in modules
    top = {m.split(".")[0] for m in modules}
    assert not top & {"scipy", "control", "smeha", "matplotlib", "numba"}, sorted(
        top & {"scipy", "control", "smeha", "matplotlib", "numba"})


def test_docs_list_every_fmu_variable_once():
    # docs/FMU.md's interface table is the user's reference: one row per variable of the
    # table the slaves register (names and causality)
    from smeha.fmu.build import iface

    doc = (FMU_SRC.parent / "docs" / "FMU.md").read_text()
    rows = {}  # the first row naming each (later tables, e.g. the variants', come after)
    for line in doc.splitlines():
        if line.startswith("| `"):
            rows.setdefault(line.split("|")[1].strip().strip("`"), line.split("|")[2].strip())
    for v in iface.VARIABLES:
        causality = {"calculatedParameter": "calculated parameter"}.get(v.causality,
                                                                        v.causality)
        assert rows.get(v.name) == causality, v.name


# -- the run-time set-up (fmu_src/smeha_fmu_runtime.py) in pieces -------------------------------
def _runtime():
    from smeha.fmu.build import runtime
    return runtime


def test_environment_record_round_trips_through_its_text():
    runtime = _runtime()
    record = {"version": ["3.11.7 (main) [GCC 12.2.0]"], "required": ["numpy", "numba"]}
    assert runtime.parse_environment(runtime.format_environment(record)) == record


def test_the_build_records_this_pythons_version_and_the_packages_and_no_path():
    # what smeha.fmu.native writes into the FMU: nothing of the machine that built it
    import sys

    from smeha.fmu import native as fmu_native

    record = fmu_native.environment_record(["numpy"])
    assert record == {"version": [sys.version], "required": ["numpy"]}
    assert fmu_native.environment_record([]) == {"version": [sys.version], "required": [""]}
    with pytest.raises(fmu_native.NativeError, match="smeha_absent_package"):
        fmu_native.environment_record(["smeha_absent_package"])


def test_standard_locations_are_those_of_a_prefix():
    runtime = _runtime()
    roots = ["/usr"]
    assert runtime._in_standard_location("/usr/lib/python3.11", roots)
    assert runtime._in_standard_location("/usr/lib/python311.zip", roots)
    assert runtime._in_standard_location("/usr/lib/python3/dist-packages", roots)
    assert runtime._in_standard_location("/usr/local/lib/python3.11/dist-packages", roots)
    assert not runtime._in_standard_location("/usr/share/fmu/resources", roots)
    assert not runtime._in_standard_location("/usrx/lib/python3.11", roots)


def test_a_missing_package_is_named_with_the_install_command(monkeypatch):
    runtime = _runtime()
    assert runtime.find_packages(("sys", "smeha_absent_pkg")) == ["smeha_absent_pkg"]
    monkeypatch.setattr(runtime, "REPORT", {"missing": ["smeha_absent_pkg"]})
    message = runtime.missing_packages_message()
    assert "smeha_absent_pkg" in message and "pip install smeha_absent_pkg" in message


# -- the loader's limits (docs/FMU.md, "The loader": limits) ------------------------------------
@pytest.mark.parametrize("system,machine,named", [("linux", "aarch64", "aarch64"),
                                                  ("darwin", "x86_64", "darwin"),
                                                  ("win32", "AMD64", "win32")])
def test_the_loader_is_compiled_for_linux_x86_64_only(monkeypatch, system, machine, named):
    # pythonfmu ships its Linux binary for x86-64 alone: elsewhere the build is told why it
    # cannot have the loader (and falls back, smeha.fmu.build._linux_binaries)
    from smeha.fmu import loader

    monkeypatch.setattr(loader.sys, "platform", system)
    monkeypatch.setattr(loader.platform, "machine", lambda: machine)
    with pytest.raises(loader.LoaderError, match=named):
        loader.compile_loader("2", "SmehaGmt", "SmehaGmt", FMU_SRC / loader.SOURCE_NAME)


def test_the_loader_runs_the_builds_own_libpython_search():
    # one search: fmu_src/smeha_fmu_probe.py, compiled into the loader as its probe and
    # called by the build (smeha.fmu.native.find_libpython); run as the loader runs it, in
    # this Python, it names this Python's version, libpython and the missing package
    import json
    import subprocess
    import sys

    from smeha.fmu import loader, native

    text = (FMU_SRC / loader.PROBE_NAME).read_text()
    header = loader.probe_header(FMU_SRC / loader.PROBE_NAME)
    assert f"PROBE[] = {json.dumps(text)};" in header
    assert "#define MIN_HEXVERSION 0x030B0000L" in header  # CPython 3.11
    assert '"libpython3.13.so.1.0", "libpython3.12.so.1.0", "libpython3.11.so.1.0"' in header
    assert "sysconfig" not in (FMU_SRC / loader.SOURCE_NAME).read_text()
    out = subprocess.run([sys.executable, "-c", text, "json", "smeha_absent_pkg"],
                         capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[:3] == [str(sys.hexversion), str(native.find_libpython()), "smeha_absent_pkg"]


def test_the_loader_checks_every_function_a_cosimulation_fmu_needs():
    # pythonfmu 0.7's binary lacks FMI 2.0's Model Exchange functions: only the others make
    # instantiation fail (named) when missing
    from smeha.fmu import loader

    text = loader.forwarders("2")
    assert "if (!T_fmi2DoStep && ++count)" in text
    assert "if (!T_fmi2SetTime" not in text and "T_fmi2SetTime = " in text
    assert "if (!T_fmi3DoStep && ++count)" in loader.forwarders("3")


# -- the FMU's messages (fmu_src/smeha_fmu_base.py) ----------------------------------------------
def test_a_message_reaches_the_host_as_written_however_often_it_is_formatted():
    # An FMI 2.0 logger takes the message as a printf format, and a chain of hosts may format
    # it more than once: fmpy 0.3.32's container FMU formats its inner FMU's message and hands
    # the result on to its own host as the format. The FMU Compliance Checker printed "5%% in
    # frequency" from the transducer inside it as "5 16843008n frequency" (docs/FMU.md, "C and
    # C++ hosts"). FMI 3.0's logger takes plain text. Text without "%" is the same whether it
    # is formatted zero, one or two times, so the FMU writes "percent".
    from smeha.fmu.tables import _load_from_fmu_src

    base = _load_from_fmu_src("smeha_fmu_base")

    class Slave(base.SlaveBase):
        STATUS_ERROR, STATUS_WARNING = "error", "warning"

        def __init__(self):
            self.logged = []

        def log(self, message, status):
            self.logged.append((message, status))

    slave = Slave()
    slave._report("off its design point (tolerances 5% in frequency, 1 % in amplitude)",
                  slave.STATUS_WARNING)
    slave._report("rate 100%")
    assert slave.logged == [
        ("off its design point (tolerances 5 percent in frequency, 1 percent in amplitude)",
         "warning"),
        ("rate 100 percent", "error")]


def test_an_fmus_modules_are_bundled_under_names_of_its_build():
    """Every module of fmu_src/ and the FMU's packages are renamed ``<name>_<build>`` (whole
    words only: imports, the names given to importlib), so that FMUs of two builds never share
    a module in one Python (smeha.fmu.build.bundled_names)."""
    from smeha.fmu import build

    project_imports = 0
    for key in build.SPECS:
        fmu = build.spec(key)
        names = build.bundled_names(fmu, "0123456789ab")
        assert all(v == f"{k}_0123456789ab" for k, v in names.items())
        for module in (fmu.slave, *fmu.modules):
            path = FMU_SRC / f"{module}.py"
            project_imports += len({m for m in _imported_modules(path)
                                    if m.split(".")[0] in names})
            tree = ast.parse(build.rename_modules(path.read_text(), names))
            renamed = {n.module if isinstance(n, ast.ImportFrom) else a.name
                       for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                       for a in getattr(n, "names", [])}
            assert not {m for m in renamed if m and m.split(".")[0] in names}, module
    assert project_imports > 10  # the slaves import their neighbours by name
    text = ('import smeha_fmu_interface as iface\nfrom smeha_fmu_base import SlaveBase\n'
            'PACKAGE = "smeha_fmu_gmt"  # smeha_gmt_fmu3, smeha_fmu_environment.txt\n')
    names = build.bundled_names(build.spec("transducer2"), "0123456789ab")
    assert build.rename_modules(text, {k: v for k, v in names.items()
                                       if k != "smeha_gmt_fmu3"}) == (
        'import smeha_fmu_interface_0123456789ab as iface\n'
        'from smeha_fmu_base_0123456789ab import SlaveBase\n'
        'PACKAGE = "smeha_fmu_gmt_0123456789ab"  # smeha_gmt_fmu3, smeha_fmu_environment.txt\n')
    assert len(build.build_id()) == 12 and build.build_id() == build.build_id()
