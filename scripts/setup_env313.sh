#!/usr/bin/env bash
# Create (or reuse) .venv313, the second test environment: bpy 5.2.3 (Blender 5.2, CPython 3.13, NumPy 2) from the
# pinned requirements313.txt, with the compiled kernel. Python 3.13 comes from $PYTHON313, else python3.13 on the
# path, else pyenv's newest 3.13; where there is none it says what to install and exits 2.
set -euo pipefail
cd "$(dirname "$0")/.."
is_313() { [ -n "$1" ] && "$1" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 13))' 2>/dev/null; }
PYTHON="${PYTHON313:-}"
if ! is_313 "$PYTHON"; then
    PYTHON=$(command -v python3.13 || true)
fi
if ! is_313 "$PYTHON"; then
    PYENV_ROOT="${PYENV_ROOT:-$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")}"
    PYTHON=$(ls -d "$PYENV_ROOT"/versions/3.13.*/bin/python3.13 2>/dev/null | sort -V | tail -n 1 || true)
fi
if ! is_313 "$PYTHON"; then
    echo "error: Python 3.13 is needed for the Blender 5.2 tests (bpy 5.2.3 has CPython 3.13 wheels only) and none" \
        "was found. Install it, e.g. \`pyenv install 3.13.0\`, Debian 13's \`apt-get install python3.13-venv\`, or" \
        "python.org's installer, then run again (or set PYTHON313=/path/to/python3.13)." >&2
    exit 2
fi
if [ ! -x .venv313/bin/python ]; then
    "$PYTHON" -m venv .venv313
fi
.venv313/bin/python -m pip install --quiet --disable-pip-version-check -r requirements313.txt
.venv313/bin/python -m scripts.build_kernel --install >/dev/null || echo "warning: no compiled kernel in .venv313; using the numpy path" >&2
