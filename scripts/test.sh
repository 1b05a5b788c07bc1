#!/usr/bin/env bash
# The whole test suite: lint (ruff, import-linter), types (mypy on core), then pytest under Xvfb.
# Installs what it needs: Debian packages for Xvfb and Qt (when root), then .venv.
set -euo pipefail
pkgs="xvfb xauth libgl1 libegl1 libxrender1 libxkbcommon-x11-0 libxcb-cursor0 libxcb-icccm4
 libxcb-keysyms1 libxcb-image0 libxcb-render-util0 libxcb-xkb1 libxcb-shape0 libxcb-randr0
 libxcb-xinerama0 libdbus-1-3 libfontconfig1"
missing=$(for p in $pkgs; do dpkg -s "$p" >/dev/null 2>&1 || echo "$p"; done)
if [ -n "$missing" ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
  else
    echo "warning: missing Debian packages (run as root to install): $missing" >&2
  fi
fi
source "$(dirname "$0")/_env.sh" test
.venv/bin/ruff check .
.venv/bin/python scripts/lint_imports.py --no-logo
.venv/bin/mypy
exec .venv/bin/python -m pytest "$@"
