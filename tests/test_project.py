"""The project's front door: what the README promises is what the repository does.

The developers' brief sets the rules these check: the README's two commands (one runs the
main job, one is exactly what CI runs), every command and option the README shows exists,
every file it points to exists, the benchmarks it lists are the ones ``run_all.py`` runs,
and the repository stands alone (no reference to notes kept outside it).
"""
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from smeha import cli

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _readme_commands():
    return re.findall(r"```bash\n(.+?)\n```", README)


def _subparsers():
    import argparse

    parser = cli.build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return action.choices


def test_ci_runs_exactly_the_readme_test_command():
    # DEVELOPERS' brief: .ci/run calls exactly the README's test command
    commands = _readme_commands()
    test_cmd = [c for c in commands if "pytest" in c]
    assert len(test_cmd) == 1, commands
    ci_lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_cmd[0].strip() in ci_lines
    # a fresh environment each time, and the test extra that holds pytest
    assert "rm -rf .venv" in ci_lines and '".[test]"' in test_cmd[0]
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert any(d.startswith("pytest") for d in meta["project"]["optional-dependencies"]["test"])


def test_readme_main_job_is_the_flow_study_through_the_console_script():
    commands = _readme_commands()
    (main_cmd,) = [c for c in commands if "pytest" not in c]
    assert main_cmd.startswith("python3 -m venv .venv") and "pip install -e ." in main_cmd
    assert main_cmd.endswith(".venv/bin/smeha flow")
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["scripts"]["smeha"] == "smeha.cli:main"
    # any current CPython from 3.11 (CI runs 3.11, 3.12 and 3.13, .ci/run)
    assert meta["project"]["requires-python"] == ">=3.11"
    versions = {c.rsplit(" :: ", 1)[1] for c in meta["project"]["classifiers"]
                if c.startswith("Programming Language :: Python :: 3.")}
    assert versions == {"3.11", "3.12", "3.13"}


def test_packages_and_test_configuration():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    setup = meta["tool"]["setuptools"]
    for package in setup["packages"]:
        # a subpackage (system_models.kernel) is listed too: setuptools takes no subpackages
        folder = ROOT / setup.get("package-dir", {}).get(package, package.replace(".", "/"))
        if package in setup.get("package-data", {}) and not (folder / "__init__.py").is_file():
            # files that travel in the wheel (fmu_src/ as smeha.fmu.sources, data/ as
            # smeha.data): no package, but the folder holds files of its patterns
            patterns = setup["package-data"][package] + ["*.py"]
            assert any(any(folder.glob(p)) for p in patterns), package
            continue
        assert (folder / "__init__.py").is_file(), package
    pytest_cfg = meta["tool"]["pytest"]["ini_options"]
    assert any(m.startswith("integration:") for m in pytest_cfg["markers"])
    assert "--strict-markers" in pytest_cfg["addopts"]  # a mistyped marker fails, not skips
    for path in pytest_cfg["testpaths"]:
        assert (ROOT / path).is_dir(), path


def test_every_package_folder_is_listed():
    # setuptools installs the listed packages only, none of their subpackages: a package
    # folder left out is missing from a non-editable install (an editable one hides that)
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    dirs = setup.get("package-dir", {})
    listed = {dirs.get(p, p.replace(".", "/")) for p in setup["packages"]}
    tops = [dirs.get(p, p) for p in setup["packages"] if "." not in p]
    found = {init.parent.relative_to(ROOT).as_posix() for top in tops
             for init in (ROOT / top).rglob("__init__.py")}
    assert found <= listed, sorted(found - listed)


def _readme_command_rows():
    """(command, options) of each row of the README's command table."""
    rows = re.findall(r"^\| `smeha (\w+)([^`]*)`", README, flags=re.M)
    return [(name, set(re.findall(r"--[a-z][a-z-]*", rest))) for name, rest in rows]


def test_readme_command_table_matches_the_parser():
    rows = _readme_command_rows()
    commands = _subparsers()
    assert {name for name, _ in rows} == set(commands)  # every command listed, none extra
    for name, options in rows:
        known = {o for a in commands[name]._actions for o in a.option_strings}
        assert options <= known, (name, options - known)


@pytest.mark.parametrize("doc", ["README.md", "data/README.md", "benchmarks/README.md",
                                 *sorted(str(p.relative_to(ROOT))
                                         for p in (ROOT / "docs").glob("*.md"))])
def test_relative_links_resolve(doc):
    text = (ROOT / doc).read_text()
    for target in re.findall(r"\]\(([^)#\s]+)\)", text):
        if "://" in target:
            continue
        assert (ROOT / doc).parent.joinpath(target).exists(), f"{doc}: {target}"


def test_readme_tree_names_what_exists():
    tree = re.search(r"## What is here\n\n```\n(.+?)```", README, flags=re.S).group(1)
    for line in tree.splitlines():
        name = line.split()[0] if line.strip() and not line.startswith(" ") else None
        if name:
            assert (ROOT / name).exists(), name


def test_every_benchmark_script_is_run_and_listed():
    # benchmarks/run_all.py runs each script; benchmarks/README.md says what each measures
    import importlib.util

    spec = importlib.util.spec_from_file_location("run_all", ROOT / "benchmarks" / "run_all.py")
    run_all = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(run_all)
    scripts = {p.stem for p in (ROOT / "benchmarks").glob("*.py")} - {"run_all"}
    helpers = {"fmu_memory"}  # run by fmu_step_cost.py, not on its own
    assert set(run_all.BENCHMARKS) == scripts - helpers
    listed = (ROOT / "benchmarks" / "README.md").read_text()
    for name in scripts:
        assert f"`{name}.py`" in listed, name


def test_the_repository_stands_alone():
    # the brief: cite the paper, books and standards, never notes kept outside the repository
    # (the pattern is spelt so that this file does not match it)
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if tracked.returncode != 0:
        pytest.skip("not a git checkout")
    outside = re.compile(r"(NOTES|HYDRAULICS|DIAGNOSIS)[.]md|shared[/]paper|/work[/]shared")
    found = []
    for name in tracked.stdout.split():
        path = ROOT / name
        if path.is_file() and path.suffix not in (".fmu", ".png", ".zip"):
            for k, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                if outside.search(line):
                    found.append(f"{name}:{k}: {line.strip()}")
    assert not found, "\n".join(found)


def test_license_and_changelog():
    # pyproject says MIT; the LICENSE file says so too, and the changelog has
    # an entry for the version pyproject gives
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["license"] == {"text": "MIT"}
    license_text = (ROOT / "LICENSE").read_text()
    assert license_text.startswith("MIT License\n")
    assert "Permission is hereby granted" in license_text
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert f"## {meta['project']['version']} " in changelog


@pytest.mark.parametrize("doc", ["README.md", *sorted(
    str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))])
def test_docs_hold_no_notes_to_the_lead(doc):
    # docs/MEASURED.md opened with "(README section, for the lead to merge.)"
    text = (ROOT / doc).read_text()
    assert not re.search(r"for the lead|to merge\.\)", text), doc


def test_the_fmu_tooling_does_not_import_the_command_line():
    # the FMU tooling has its own package, smeha.fmu, with no import circle through the
    # command line: the tooling imports without the commands
    code = ("import sys, smeha.fmu.build, smeha.fmu.ssp, smeha.fmu.systemrun, "
            "smeha.fmu.crosscheck, smeha.fmu.loader, smeha.fmu.native; "
            "print(sorted(m for m in sys.modules if m.startswith(('smeha.cli', 'smeha.studies', "
            "'smeha.diagnose'))))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_the_docs_keep_to_their_size():
    # the project's documentation budget: a README of at most 300 lines, each file under
    # docs/ at most 500 and all of them at most 2,000 (history goes to CHANGELOG.md and
    # benchmarks/, not to the docs)
    sizes = {p.name: len(p.read_text().splitlines()) for p in (ROOT / "docs").glob("*.md")}
    assert len((ROOT / "README.md").read_text().splitlines()) <= 300
    assert max(sizes.values()) <= 500, sizes
    assert sum(sizes.values()) <= 2000, sum(sizes.values())
