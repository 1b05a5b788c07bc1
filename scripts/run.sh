#!/usr/bin/env bash
# The main job: evaluate an expression on the built-in face and print its fields.
# Installs what it needs into .venv on first use. Arguments go to `wrinkle-vis`.
source "$(dirname "$0")/_env.sh" run
exec .venv/bin/wrinkle-vis "${@:-summary}"
