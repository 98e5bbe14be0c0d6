"""Each face variant set up and playing the demo stream: the face at rest, mid-stream and at the fullest blink, and
close-ups of the left eye at the blink and of the mouth mid-stream (Workbench), one row per variant.

    .venv/bin/python -m scripts.docs.render_variants DIR [--out docs/real_meshes_variants.png] [--tile 192]

DIR holds the variants (`python -m scripts.bench.variants DIR`), or is one .blend with FP empties placed; the
face is the object named Head, else the largest mesh. The rows come in the order of the files' names, printed
as the rows are made.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from scripts import convert
from scripts.bench.variants import HEAD
from scripts.docs.closeups import ROOT, closeup_camera, save_rows

DEMO = ROOT / "sample_blends" / "demo.fap"
MID = 200  # a frame of speech in the demo stream


def blink_frame(face) -> int:
    """The frame at which the left upper lid FP (3.1) is lowest along the face's up axis: the fullest blink."""
    face_data, animation = convert._addon("blender.face_data"), convert._addon("blender.animation")
    empty = face_data.fp_empties(face)["3.1"]
    frames = np.arange(bpy.context.scene.frame_start, bpy.context.scene.frame_end + 1, dtype=np.float64)
    track = np.stack([animation.sample(empty, "location", a, frames, empty.location[a]) for a in range(3)], axis=1)
    return int(frames[np.argmin(track @ np.array(face_data.face_axes(face))[1])])


def open_playing_demo(path: Path) -> tuple[bpy.types.Scene, bpy.types.Object]:
    """Open a variant's file, set up its face (the object named Head, else the largest mesh) and key the demo
    stream onto it, with the FP empties hidden from renders."""
    convert.addon_package()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    face = bpy.data.objects.get(HEAD) or max(
        (ob for ob in scene.objects if ob.type == "MESH"), key=lambda ob: len(ob.data.vertices)
    )
    convert.select_only(face)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO)) == {"FINISHED"}
    for ob in scene.objects:  # the FP empties and the control mesh stay out of the pictures
        if ob.type == "EMPTY":
            ob.hide_render = True
    return scene, face


def row(path: Path, tile: int, scratch: Path) -> np.ndarray:
    scene, face = open_playing_demo(path)
    convert.frame_face(scene, face, tile)
    whole = scene.camera.data.ortho_scale
    camera = closeup_camera(scene, face, tile, whole)
    camera.data.clip_start = 0.001 * whole  # a face a few millimetres tall (modelled in other units) too
    empties = convert._addon("blender.face_data").fp_empties(face)
    pupil, mouth = (empties[k].matrix_world.translation.copy() for k in ("3.5", "2.2"))
    separation = (empties["3.5"].matrix_world.translation - empties["3.6"].matrix_world.translation).length
    framed = camera.location.copy()
    blink = blink_frame(face)
    tiles = []
    for frame, centre, size in (
        (0, None, None),
        (MID, None, None),
        (blink, None, None),
        (blink, pupil, 0.8 * separation),
        (MID, mouth, 1.2 * separation),
    ):
        camera.location = framed if centre is None else (centre.x, framed.y, centre.z)
        camera.data.ortho_scale = size or whole
        tiles.append(convert.render_frame(scene, frame, scratch))
    print(f"{path.stem}: rest, frame {MID}, blink at frame {blink}, left eye, mouth")
    return np.concatenate(tiles, axis=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("variants", type=Path, help="folder of variant .blend files (or one .blend)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "real_meshes_variants.png")
    parser.add_argument("--tile", type=int, default=192)
    parser.add_argument("--only", nargs="*", help="these variants (file stems)")
    args = parser.parse_args(argv)
    found = sorted(args.variants.glob("*.blend")) if args.variants.is_dir() else [args.variants]
    files = [f for f in found if not args.only or f.stem in args.only]
    with tempfile.TemporaryDirectory() as tmp:
        rows = [row(path, args.tile, Path(tmp) / "tile.png") for path in files]
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
