#!/usr/bin/env bash
# Create (or reuse) the project's virtual environment .venv from the pinned requirements.
# Needs only Python 3.11 (bpy 5.0.1 wheels exist for CPython 3.11 only).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3.11}"
command -v "$PYTHON" >/dev/null 2>&1 || PYTHON=python3
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "error: Python 3.11 is needed (found $("$PYTHON" --version 2>&1)); set PYTHON=/path/to/python3.11" >&2
    exit 2
fi
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r requirements.txt
# The compiled Planar Bones kernel (addon/deform/fused.py), built for this machine with Zig's C compiler (ziglang,
# pinned above) and installed into .venv; without it the add-on and the tests use the numpy path.
.venv/bin/python -m scripts.build_kernel --install >/dev/null || echo "warning: no compiled kernel; using the numpy path" >&2
