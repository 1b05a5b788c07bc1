# Sourced by run.sh, test.sh and docs.sh: make .venv with the project installed (once per pyproject).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
PY=${PYTHON:-python3.11}
command -v "$PY" >/dev/null 2>&1 || PY=python3
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
  .venv/bin/python -m pip install --quiet --upgrade pip
fi
stamp=".venv/.installed-$(cat pyproject.toml tests/plugins/*/pyproject.toml | sha256sum | cut -c1-16)-${1:-run}"
if [ ! -f "$stamp" ]; then
  if [ "${1:-run}" = test ]; then
    PYTHONWARNINGS=ignore .venv/bin/python -m pip install --quiet -e ".[test]" \
      -e tests/plugins/wrinkle_vis_ring
  elif [ "${1:-run}" = docs ]; then  # the gallery's plug-in example uses the example plug-in
    PYTHONWARNINGS=ignore .venv/bin/python -m pip install --quiet -e ".[docs,jupyter]" \
      -e tests/plugins/wrinkle_vis_ring
  else
    PYTHONWARNINGS=ignore .venv/bin/python -m pip install --quiet -e .
  fi
  touch "$stamp"
fi
