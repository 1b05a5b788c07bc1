"""``wrinkle_vis.core.foldguard`` as of a git revision, imported beside this tree's (the
fold guard's benches time a baseline revision's guard on the same frames).

Up to stop 39 the guard is one file, ``core/foldguard.py``; from stop 40 a package,
``core/foldguard/``. Either is written to a temporary folder and imported as
``wrinkle_vis.core.<name>`` (inside the package, so its relative imports of the core's other
modules resolve to this tree's).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

_ROOT = Path(__file__).resolve().parents[1]
_PATH = "wrinkle_vis/core/foldguard"


def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(_ROOT), *args], check=True, capture_output=True,
                          text=True).stdout


def foldguard_at(ref: str, name: str = "foldguard_baseline"):
    """The fold guard module (or package) of revision ``ref``, imported as
    ``wrinkle_vis.core.<name>``."""
    tmp = Path(tempfile.mkdtemp())
    core = _git("ls-tree", "--name-only", f"{ref}:wrinkle_vis/core/").split()
    files = _git("ls-tree", "--name-only", f"{ref}:{_PATH}/").split() \
        if "foldguard" in core else []
    if files:  # a package: its modules in a folder named after it
        folder = tmp / name
        folder.mkdir()
        for f in files:
            (folder / f).write_text(_git("show", f"{ref}:{_PATH}/{f}"))
        spec = importlib.util.spec_from_file_location(
            f"wrinkle_vis.core.{name}", folder / "__init__.py",
            submodule_search_locations=[str(folder)])
    else:
        path = tmp / f"{name}.py"
        path.write_text(_git("show", f"{ref}:{_PATH}.py"))
        spec = importlib.util.spec_from_file_location(f"wrinkle_vis.core.{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
