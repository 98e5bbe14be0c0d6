#!/usr/bin/env bash
# The test command: set up both environments and MakeHuman's data (the sculpts the accuracy tests compare with),
# lint with ruff, then run pytest (core and Blender tests) on Blender 5.0 (.venv: bpy 5.0.1, CPython 3.11, NumPy 1)
# and again on Blender 5.2 (.venv313: bpy 5.2.3, CPython 3.13, NumPy 2); each run also installs its Blender line's
# zip into a fresh Blender user folder. Both always run; the exit status is non-zero if either failed.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
bash scripts/setup_anny.sh
bash scripts/setup_env313.sh
bash scripts/setup_web.sh
bash scripts/setup_wine.sh
.venv/bin/python -m ruff check .
.venv/bin/python -m ruff format --check .
status=0
echo "== Blender 5.0 (bpy 5.0.1, CPython 3.11, NumPy 1)"
.venv/bin/python -m pytest -q "$@" || status=$?
echo "== Blender 5.2 (bpy 5.2.3, CPython 3.13, NumPy 2)"
.venv313/bin/python -m pytest -q "$@" || status=$?
exit "$status"
