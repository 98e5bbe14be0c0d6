"""Close-up Workbench renders of the demo stream on the sample head, for the README.

    .venv/bin/python -m scripts.docs.render_demo_closeups [--out docs/demo_closeups.png]

One row of the mouth (rest, jaw, pout, smile) and one of the upper face (rest, brows, blink, gaze),
each tile 400 px, at the peak frame of each scene of `sample_blends/demo.fap`.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from scripts import convert
from scripts.docs.closeups import closeup_camera, open_sample, save_rows
from scripts.sample.make_demo_fap import FPS, SCENES

ROOT = Path(__file__).resolve().parents[2]

TILE = 400


def scene_peaks() -> list[int]:
    """The middle (peak) frame of each scene of the demo stream."""
    peaks, start = [], 0
    for seconds, _ in SCENES:
        n = int(round(seconds * FPS))
        peaks.append(start + (n - 1) // 2)
        start += n
    return peaks


PEAK = scene_peaks()  # jaw, pout, smile, cheeks, brows, blink, gaze, head
ROWS = (  # (FP the camera centres on, vertical offset in m, frames: rest and the peaks of the scenes)
    ("8.1", -0.01, (0, PEAK[0], PEAK[1], PEAK[2])),
    ("9.12", 0.02, (0, PEAK[4], PEAK[5], PEAK[6])),
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "demo_closeups.png")
    args = parser.parse_args(argv)
    scene, face = open_sample()
    scene.render.fps = 25
    bpy.ops.mpeg4.import_fap(filepath=str(ROOT / "sample_blends" / "demo.fap"))
    camera = closeup_camera(scene, face, TILE, 0.11)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fp_id, offset, frames in ROWS:
            centre = bpy.data.objects[f"FP {fp_id}"].matrix_world.translation
            camera.location.x, camera.location.z = centre.x, centre.z + offset
            tiles = [convert.render_frame(scene, f, Path(tmp) / "tile.png") for f in frames]
            rows.append(np.concatenate(tiles, axis=1))
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
