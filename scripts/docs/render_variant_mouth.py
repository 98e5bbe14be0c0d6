"""Close-ups of a face's mouth at chosen frames of the demo stream (Workbench), one row per face: the mouth from the
front and each inner corner (2.4, 2.5, where the stream puts them) from its side, where a wide mouth folds skin.

    .venv/bin/python -m scripts.docs.render_variant_mouth FACE.blend ... [--frames 0 120] [--out OUT.png]
        [--tile 256] [--crossings] [--at FP|N|crossing]

Each face (the object named Head, else the largest mesh) is set up and plays the demo stream; per frame the row
holds the mouth (1.2 eye separations across) and its two inner corners (0.2 across). The rows come in the
order given, printed as they are made. `--crossings` paints the polygons of the skin's crossing triangle pairs
(`overlaps.crossing_pairs`, pairs crossing at rest left out) red and prints how many pairs each frame has, so a
crossing hidden inside the lips is found in the picture. `--at FP` centres the corner tiles on another FP (`--at
N`: on vertex N as the frame put it; `--at crossing`, with `--crossings`: on the first crossing pair, 2.2 where
none crosses) and adds a tile looking straight down on it with everything more than SECTION eye separations above
it cut away (the upper lip off the lower one: where the lips press, the lower lip's inner surface).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy  # noqa: F401 (before mathutils, which bpy provides)
import numpy as np
from mathutils import Vector

from addon.deform.overlaps import crossing_pairs
from scripts import convert
from scripts.bench.variant_playback import played_positions
from scripts.docs.closeups import ROOT, aim_camera, closeup_camera, save_rows
from scripts.docs.render_variants import open_playing_demo

CORNER_VIEWS = (("2.5", -40.0), ("2.4", 40.0))  # each inner corner, seen from its own side (yaw, degrees)


CROSSING_RED = (0.9, 0.1, 0.1, 1.0)
MARKS = "crossings"  # the corner colour attribute `--crossings` paints
CROSSING = "crossing"  # `--at crossing`: the close-ups look at the first crossing pair (with --crossings)
SECTION = 0.02  # x the eye separation: `--at`'s view from above keeps what lies less than this above the FP


def mark_crossings(face, rest: np.ndarray, at_rest: np.ndarray, fans: tuple) -> tuple[int, Vector | None]:
    """Paint the polygons of the face's crossing triangle pairs red (the rest light grey) in MARKS, shown by the
    Workbench's attribute colours; how many pairs cross (those crossing at rest left out), and the first pair's
    centre in the world (None when none cross)."""
    now = played_positions(face.data)
    pairs = crossing_pairs(now, fans[0], np.any(now != rest, axis=1))
    if len(at_rest) and len(pairs):
        span = int(max(pairs.max(), at_rest.max())) + 1
        pairs = pairs[~np.isin(pairs[:, 0] * span + pairs[:, 1], at_rest[:, 0] * span + at_rest[:, 1])]
    red = np.zeros(len(face.data.polygons), bool)
    red[fans[1][pairs.ravel()]] = True
    sizes = np.array([p.loop_total for p in face.data.polygons])
    colours = np.where(np.repeat(red, sizes)[:, None], CROSSING_RED, (0.8, 0.8, 0.8, 1.0))
    face.data.color_attributes[MARKS].data.foreach_set("color", colours.astype(np.float32).ravel())
    first = None if not len(pairs) else face.matrix_world @ Vector(now[fans[0][pairs[0]]].reshape(-1, 3).mean(axis=0))
    return len(pairs), first


def looked_at(face, empties, at: str) -> Vector:
    """Where `--at` looks in the world: an FP's empty, or a vertex (its index) where the frame put it."""
    if at.isdigit():
        return face.matrix_world @ Vector(played_positions(face.data)[int(at)])
    return empties[at].matrix_world.translation.copy()


def row(path: Path, frames: list[int], tile: int, scratch: Path, crossings: bool, at_fp: str | None) -> np.ndarray:
    scene, face = open_playing_demo(path)
    face_data = convert._addon("blender.face_data")
    empties = face_data.fp_empties(face)
    if crossings:
        rest = convert._addon("blender.rest_shape").reference_positions(face.data).astype(np.float64)
        fans = face_data.mesh_fans(face.data)
        at_rest = crossing_pairs(rest, fans[0])
        face.data.color_attributes.new(MARKS, "FLOAT_COLOR", "CORNER")
        face.data.color_attributes.active_color_name = MARKS
    separation = (empties["3.5"].matrix_world.translation - empties["3.6"].matrix_world.translation).length
    camera = closeup_camera(scene, face, tile, 1.2 * separation)
    camera.data.clip_start = 0.001 * separation
    if crossings:
        scene.display.shading.color_type = "VERTEX"  # after the camera's engine settings, which set MATERIAL
    tiles = []
    for frame in frames:
        scene.frame_set(frame)  # the corners where the stream puts them
        at = {k: empties[k].matrix_world.translation.copy() for k in ("2.2", "2.4", "2.5")}
        at[at_fp] = at["2.2"] if at_fp in (None, CROSSING) else looked_at(face, empties, at_fp)
        if crossings:
            count, first = mark_crossings(face, rest, at_rest, fans)
            print(f"{path.stem}, frame {frame}: {count} crossing pairs")
            at[at_fp] = at[at_fp] if first is None or at_fp != CROSSING else first
        aim_camera(camera, at["2.2"], 4.0 * separation, 0.0, 0.0)
        camera.data.ortho_scale = 1.2 * separation
        tiles.append(convert.render_frame(scene, frame, scratch))
        for fp_id, yaw in CORNER_VIEWS if at_fp is None else ((at_fp, -40.0), (at_fp, 40.0)):
            aim_camera(camera, at[fp_id], 4.0 * separation, yaw, 10.0)
            camera.data.ortho_scale = 0.2 * separation
            tiles.append(convert.render_frame(scene, frame, scratch))
        if at_fp is not None:  # straight down on it, all above it by more than SECTION cut away: the lip under it
            aim_camera(camera, at[at_fp], 4.0 * separation, 0.0, -90.0)
            camera.data.ortho_scale = 0.4 * separation
            camera.data.clip_start = (4.0 - SECTION) * separation
            tiles.append(convert.render_frame(scene, frame, scratch))
            camera.data.clip_start = 0.001 * separation
    looked = at_fp or "its right and left inner corners"
    print(f"{path.stem}: frames {frames}, the mouth, then {looked} from each side (and from above, cut)")
    return np.concatenate(tiles, axis=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="+", type=Path, help=".blend files with FP empties placed")
    parser.add_argument("--frames", nargs="+", type=int, default=[0, 120])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "real_meshes_mouth_corner.png")
    parser.add_argument("--tile", type=int, default=256)
    parser.add_argument("--crossings", action="store_true", help="paint crossing triangle pairs red")
    parser.add_argument("--at", help="the FP the close-ups look at from either side (default: each inner corner)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [row(p, args.frames, args.tile, Path(tmp) / "tile.png", args.crossings, args.at) for p in args.faces]
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
