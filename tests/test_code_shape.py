"""Short functions (issue 28): no function of the package (``wrinkle_vis/``, and ``widgets/``
and ``datasets/``, installed as ``wrinkle_vis.widgets`` and ``wrinkle_vis.datasets``) over
60 lines, docstring included, or of a cyclomatic complexity over 15 (ruff's C901, whose
``max-complexity`` pyproject.toml sets), but the survivors listed here, each with its reason.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("wrinkle_vis", "widgets", "datasets")
MAX_LINES = 60

#: Functions allowed over MAX_LINES, by ``path:qualified name``, each with its reason.
#: Take one off the list when it is split (the test says when a survivor is short).
SURVIVORS = {
    # The numpydoc of the public evaluate (every parameter: expression, intensity, refine,
    # gradient, skin, fold_guard...) is 55 lines; its body is 22.
    "wrinkle_vis/core/face.py:FaceModel.evaluate":
        "its docstring, every parameter of the public entry point, is 55 lines; the body 22",
    # The numpydoc of the public notebook entry point (one entry per option, 56 lines)
    # alone is over 60 lines; its body is 8 lines.
    "wrinkle_vis/plotting/notebook.py:plot_state":
        "its docstring, every option of a public entry point, is 56 lines; the body is 8",
    # load_face is split by what it loads (issue 28); its numpydoc (a built-in face or a
    # scan, every argument) is 71 lines, its body 17.
    "datasets/face.py:load_face":
        "its docstring, every argument of the public loader, is 71 lines; the body is 17",
}


def _functions(tree: ast.AST, prefix: str = ""):
    """``(qualified name, node)`` of every function and method in ``tree``, nested ones
    included (``Outer.inner``).
    """
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield prefix + node.name, node
            yield from _functions(node, f"{prefix}{node.name}.")
        elif isinstance(node, ast.ClassDef):
            yield from _functions(node, f"{prefix}{node.name}.")
        else:
            yield from _functions(node, prefix)


def _function_lines() -> dict[str, int]:
    """Lines of every function of the package, from ``def`` to its last line."""
    out = {}
    for folder in SOURCES:
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            rel = path.relative_to(ROOT).as_posix()
            for name, node in _functions(tree):
                out[f"{rel}:{name}"] = node.end_lineno - node.lineno + 1
    return out


def test_the_function_finder_sees_methods_and_nested_functions():
    tree = ast.parse("def f():\n    def g():\n        pass\nclass C:\n    def m(self):\n"
                     "        return [x for x in ()]\n")
    assert [name for name, _ in _functions(tree)] == ["f", "f.g", "C.m"]


def test_no_function_is_over_60_lines_but_the_listed_survivors():
    lines = _function_lines()
    assert len(lines) > 1000  # the whole package was read
    long = {name: n for name, n in lines.items() if n > MAX_LINES}
    unlisted = {name: n for name, n in long.items() if name not in SURVIVORS}
    assert not unlisted, (f"functions over {MAX_LINES} lines: {unlisted}; split them into "
                          "named steps (or list one in SURVIVORS with its reason)")
    stale = sorted(name for name in SURVIVORS if name not in long)
    assert not stale, f"{stale} are gone or {MAX_LINES} lines or fewer now: take them off " \
                      "SURVIVORS"


def _ruff() -> str | None:
    return shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")


def test_the_complexity_limit_is_ruffs_c901_at_15():
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    lint = config["tool"]["ruff"]["lint"]
    assert "C90" in lint["select"] and lint["mccabe"]["max-complexity"] == 15


@pytest.mark.skipif(_ruff() is None, reason="ruff is not installed")
def test_no_function_is_over_complexity_15():
    """ruff's McCabe count (C901) with pyproject.toml's ``max-complexity``: no survivors."""
    done = subprocess.run([_ruff(), "check", "--select", "C901", "--output-format", "concise",
                           "--no-cache", *SOURCES], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.skipif(_ruff() is None, reason="ruff is not installed")
def test_the_complexity_check_can_fail(tmp_path):
    branches = "\n".join(f"    if x == {i}:\n        return {i}" for i in range(16))
    (tmp_path / "busy.py").write_text(f"def busy(x):\n{branches}\n    return -1\n")
    done = subprocess.run([_ruff(), "check", "--select", "C901", "--output-format", "concise",
                           "--no-cache", "--config", str(ROOT / "pyproject.toml"), "busy.py"],
                          cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 1 and "`busy` is too complex (17 > 15)" in done.stdout
