#!/usr/bin/env bash
# The main job on the built-in face: the app when there is a display, else a summary of
# every expression's fields. Installs what it needs into .venv on first use.
# Arguments go to `wrinkle-vis` (e.g. `render -e frown -o frown.png`).
source "$(dirname "$0")/_env.sh" run
exec .venv/bin/wrinkle-vis "$@"
