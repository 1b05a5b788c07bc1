#!/usr/bin/env bash
# The main job on the built-in face: the app when there is a display, else a summary of
# every expression's fields. Installs what it needs into .venv on first use.
# Arguments go to `wrinkle-vis` (e.g. `render -e frown -o frown.png`).
source "$(dirname "$0")/_env.sh" run
if [ $# -eq 0 ] && ! .venv/bin/python -c \
    "from wrinkle_vis.plotting.offscreen import display_available as d; raise SystemExit(not d())"
then
  echo "no display: printing every expression's fields instead of opening the app" >&2
  exec .venv/bin/wrinkle-vis summary
fi
exec .venv/bin/wrinkle-vis "$@"
