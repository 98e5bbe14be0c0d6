"""Close-ups of a face's mouth at chosen frames of the demo stream (Workbench), one row per face: the mouth from the
front and each inner corner (2.4, 2.5, where the stream puts them) from its side, where a wide mouth folds skin.

    .venv/bin/python -m scripts.docs.render_variant_mouth FACE.blend ... [--frames 0 120] [--out OUT.png]
        [--tile 256]

Each face (the object named Head, else the largest mesh) is set up and plays the demo stream; per frame the row
holds the mouth (1.2 eye separations across) and its two inner corners (0.2 across). The rows come in the
order given, printed as they are made.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from scripts import convert
from scripts.docs.closeups import ROOT, aim_camera, closeup_camera, save_rows
from scripts.docs.render_variants import open_playing_demo

CORNER_VIEWS = (("2.5", -40.0), ("2.4", 40.0))  # each inner corner, seen from its own side (yaw, degrees)


def row(path: Path, frames: list[int], tile: int, scratch: Path) -> np.ndarray:
    scene, face = open_playing_demo(path)
    empties = convert._addon("blender.face_data").fp_empties(face)
    separation = (empties["3.5"].matrix_world.translation - empties["3.6"].matrix_world.translation).length
    camera = closeup_camera(scene, face, tile, 1.2 * separation)
    camera.data.clip_start = 0.001 * separation
    tiles = []
    for frame in frames:
        scene.frame_set(frame)  # the corners where the stream puts them
        at = {k: empties[k].matrix_world.translation.copy() for k in ("2.2", "2.4", "2.5")}
        aim_camera(camera, at["2.2"], 4.0 * separation, 0.0, 0.0)
        camera.data.ortho_scale = 1.2 * separation
        tiles.append(convert.render_frame(scene, frame, scratch))
        for fp_id, yaw in CORNER_VIEWS:
            aim_camera(camera, at[fp_id], 4.0 * separation, yaw, 10.0)
            camera.data.ortho_scale = 0.2 * separation
            tiles.append(convert.render_frame(scene, frame, scratch))
    print(f"{path.stem}: frames {frames}, the mouth, its right and left inner corners")
    return np.concatenate(tiles, axis=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="+", type=Path, help=".blend files with FP empties placed")
    parser.add_argument("--frames", nargs="+", type=int, default=[0, 120])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "real_meshes_mouth_corner.png")
    parser.add_argument("--tile", type=int, default=256)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [row(path, args.frames, args.tile, Path(tmp) / "tile.png") for path in args.faces]
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
