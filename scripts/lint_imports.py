"""The import contracts (pyproject.toml's ``[tool.importlinter]``) on the package as installed.

``widgets/`` and ``datasets/`` are installed as ``wrinkle_vis.widgets`` and
``wrinkle_vis.datasets`` (``[tool.setuptools.package-dir]``), but import-linter finds a
package's modules by walking its folder, and ``wrinkle_vis/`` holds neither: a bare
``lint-imports`` skips their (optional) layers. This lays out the installed tree as symbolic
links in a temporary folder and runs ``lint-imports`` from there, so that every layer is
checked; it fails if a mapped package is missing from the tree. Arguments go to
``lint-imports``.

    .venv/bin/python scripts/lint_imports.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "wrinkle_vis"


def mapped_packages() -> dict[str, Path]:
    """The subpackages of :data:`PACKAGE` that live outside its folder, by their last name."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    mapping = config["tool"]["setuptools"]["package-dir"]
    return {name.rpartition(".")[2]: ROOT / folder for name, folder in mapping.items()
            if name.rpartition(".")[0] == PACKAGE}


def installed_tree(folder: Path) -> Path:
    """``folder / PACKAGE``: links to the package's own files and to its mapped subpackages."""
    package = folder / PACKAGE
    package.mkdir()
    for entry in (ROOT / PACKAGE).iterdir():
        if entry.name != "__pycache__":
            (package / entry.name).symlink_to(entry)
    for name, source in mapped_packages().items():
        if not (source / "__init__.py").is_file():
            raise SystemExit(f"{source} has no __init__.py; check "
                             "[tool.setuptools.package-dir] in pyproject.toml")
        (package / name).symlink_to(source, target_is_directory=True)
    return package


def main(args: list[str]) -> int:
    """Run ``lint-imports`` (with ``args``) on the installed tree; its exit status."""
    lint = Path(sys.executable).with_name("lint-imports")
    with tempfile.TemporaryDirectory(prefix="wrinkle-vis-imports-") as tmp:
        installed_tree(Path(tmp))
        # lint-imports puts its working folder first on sys.path: there, the tree is found
        return subprocess.run([str(lint), "--no-cache", str(ROOT / "pyproject.toml"), *args],
                              cwd=tmp).returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
