#!/usr/bin/env bash
# The documentation site: HTML under docs/_build/html. Installs what it needs into .venv first
# (the project with its docs and jupyter extras, once per pyproject), then runs Sphinx with
# warnings as errors. Arguments go to sphinx-build (e.g. -E for a clean build).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
  .venv/bin/python -m pip install --quiet --upgrade pip
fi
stamp=".venv/.installed-$(cat pyproject.toml tests/plugins/*/pyproject.toml | sha256sum | cut -c1-16)-docs"
if [ ! -f "$stamp" ]; then
  # the gallery's plug-in example uses the example plug-in
  PYTHONWARNINGS=ignore .venv/bin/python -m pip install --quiet -e ".[docs,jupyter]" \
    -e tests/plugins/wrinkle_vis_ring
  touch "$stamp"
fi
# render off screen; through EGL when no X display opens (VTK would try X first)
if [ -z "${DISPLAY:-}" ] && [ -z "${VTK_DEFAULT_OPENGL_WINDOW:-}" ]; then
  export VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow
fi
exec .venv/bin/python -m sphinx -W --keep-going -b html -d docs/_build/doctrees "$@" docs docs/_build/html
