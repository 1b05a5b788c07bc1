#!/usr/bin/env bash
# The documentation site: HTML under docs/_build/html. Installs what it needs into .venv first
# (the project with its docs and jupyter extras, once per pyproject), then runs Sphinx with
# warnings as errors. Arguments go to sphinx-build (e.g. -E for a clean build).
source "$(dirname "$0")/_env.sh" docs
# render off screen; through EGL when no X display opens (VTK would try X first)
if [ -z "${DISPLAY:-}" ] && [ -z "${VTK_DEFAULT_OPENGL_WINDOW:-}" ]; then
  export VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow
fi
exec .venv/bin/python -m sphinx -W --keep-going -b html -d docs/_build/doctrees "$@" docs docs/_build/html
