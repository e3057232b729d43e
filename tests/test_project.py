"""The project's front door: README commands, CI script and packaging agree."""
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands():
    text = (ROOT / "README.md").read_text()
    return re.findall(r"```bash\n(.+?)\n```", text)


def test_ci_runs_exactly_the_readme_test_command():
    # DEVELOPERS' brief: .ci/run calls exactly the README's test command
    commands = _readme_commands()
    test_cmd = [c for c in commands if "pytest" in c]
    assert len(test_cmd) == 1, commands
    ci_lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert test_cmd[0].strip() in ci_lines


def test_readme_main_job_uses_the_console_script():
    commands = _readme_commands()
    main_cmd = [c for c in commands if "pytest" not in c]
    assert main_cmd and "smeha " in main_cmd[0]
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert meta["project"]["scripts"]["smeha"] == "smeha.cli:main"
    assert meta["project"]["requires-python"].startswith(">=3.11")


def test_required_top_level_exists():
    for name in ("pyproject.toml", "fmu_src", "build_fmu.py", "tests", "system_models",
                 "README.md", "benchmarks", "data", "smeha"):
        assert (ROOT / name).exists(), name
