"""docs/examples/scan.py runs exactly as the README writes it."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAD = ROOT.parent / "shared" / "realmeshes" / "lee_perry_smith_head.obj"


def readme_command() -> list[str]:
    text = (ROOT / "README.md").read_text()
    found = re.search(r"`(\.venv/bin/python docs/examples/scan\.py[^`]*)`", text)
    assert found, "the README shows how to run docs/examples/scan.py"
    return shlex.split(" ".join(found.group(1).split()))


@pytest.mark.slow
@pytest.mark.skipif(not HEAD.exists(), reason="../shared/realmeshes is not here")
def test_the_scan_example_runs_as_the_readme_writes_it(tmp_path):
    argv = readme_command()
    assert argv[0] == ".venv/bin/python"
    done = subprocess.run([sys.executable, *argv[1:], "--png", str(tmp_path / "s.png")],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "21 muscles" in done.stdout and "unit m" in done.stdout
    assert "surprise  W != 0" in done.stdout and (tmp_path / "s.png").is_file()
    assert "Warning" not in done.stderr and "Traceback" not in done.stderr
