"""Types (issue 28): mypy checks the whole core, no module excused, in the test command
(``scripts/test.sh``).
"""

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _mypy_config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]


def test_mypy_checks_the_whole_core_and_excuses_no_module():
    config = _mypy_config()
    assert config["files"] == ["wrinkle_vis/core"]
    excused = [o["module"] for o in config.get("overrides", []) if o.get("ignore_errors")]
    assert excused == []


def test_the_test_command_runs_mypy_before_pytest():
    lines = [line.strip() for line in (ROOT / "scripts" / "test.sh").read_text().splitlines()]
    pytest_line = next(i for i, line in enumerate(lines) if line.startswith("exec")
                       and "pytest" in line)
    assert ".venv/bin/mypy" in lines[:pytest_line]


def test_the_package_says_it_is_typed():
    """PEP 561: ``py.typed`` in the package, and installed with it."""
    assert (ROOT / "wrinkle_vis" / "py.typed").is_file()
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "py.typed" in data["package-data"]["wrinkle_vis"]


@pytest.mark.slow
def test_mypy_finds_no_error_in_the_core(tmp_path):
    done = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Success: no issues found" in done.stdout
