#!/usr/bin/env bash
# The main job: convert the bundled example FAP stream on the bundled sample head into out/
# (Alembic, PC2 point cache, MP4 preview and PNG contact sheet). The log stays short: the result line and a
# progress bar (a few lines when not on a terminal); Blender's own lines, one per frame, go to out/demo.log.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
.venv/bin/python -m scripts.convert --face sample_blends/makehuman_head.blend sample_blends/demo.fap -o out "$@"
