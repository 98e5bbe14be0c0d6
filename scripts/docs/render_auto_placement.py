"""Place the feature points automatically on the two third-party heads and render them (docs/auto_placement_*.png).

    .venv/bin/python -m scripts.docs.render_auto_placement [--heads ../shared/heads] [--out docs/]
        [--development HEAD.blend] [--extra HEAD.obj ...] [--only-extra]

The scan (`leeperrysmith_scan.obj`, imported Y-up as Blender's OBJ importer leaves it) and the full-body
character (`valid_rocketbox_male.glb`: its body mesh, with its eyeballs and teeth selected as parts) each
get Place Feature Points Automatically; Workbench renders front and three-quarter views show a sphere on
every FP, green when the placement is confident, red when it lists the point as low-confidence. The heads
are read from their folder, never copied into the repository. A head refused by the operator is reported
and not rendered. `--development` also renders a development head of `scripts.bench.placement_heads` (its
truth FP empties deleted first) as `auto_placement_development_*.png`; `--extra` renders other heads (an
OBJ's only mesh, e.g. ICT FaceKit's head with or without its sockets) as `auto_placement_<file name>_*.png`,
and `--only-extra` leaves the two third-party heads out.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

import addon
from addon.blender import auto_placement, face_data
from scripts import convert

ROOT = Path(__file__).resolve().parents[2]
SIZE = 800
MARK_SHARE = 0.012  # a mark's radius against the head's ear-to-ear width
HEADS = {
    # output name: (file, face object or None for the only mesh, part objects selected with it)
    "scan": ("leeperrysmith_scan.obj", None, ()),
    "rocketbox": ("valid_rocketbox_male.glb", "H_DDS_HighRes", ("h_L_eye", "h_R_eye", "h_TeethUp", "h_TeethDown")),
}
COLOURS = {"sure": (0.1, 0.75, 0.2, 1.0), "low": (0.9, 0.1, 0.05, 1.0), "skin": (0.82, 0.78, 0.74, 1.0)}


def _import(path: Path):
    if path.suffix == ".blend":
        bpy.ops.wm.open_mainfile(filepath=str(path))
        for ob in [ob for ob in bpy.data.objects if ob.type == "EMPTY" and "mpeg4_fp" in ob]:
            bpy.data.objects.remove(ob)
        bpy.context.view_layer.update()
        return
    bpy.ops.wm.read_homefile(use_empty=True)
    if path.suffix == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    else:
        bpy.ops.import_scene.gltf(filepath=str(path))


def _material(name: str) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    material.diffuse_color = COLOURS[name]
    return material


def place(path: Path, face_name: str | None, parts: tuple[str, ...]):
    _import(path)
    meshes = [ob for ob in bpy.data.objects if ob.type == "MESH"]
    for ob in meshes:
        # placement and set-up read a mesh's own rest shape, and the empties snap onto the shown one: a
        # skinned character is shown at rest (the Rocketbox rest mesh is in centimetres, its bones make
        # it metres)
        for modifier in ob.modifiers:
            if modifier.type == "ARMATURE":
                modifier.show_render = modifier.show_viewport = False
    face = bpy.data.objects[face_name] if face_name else meshes[0]
    convert.select_only(face)
    for name in parts:
        bpy.data.objects[name].select_set(True)
    start = time.perf_counter()
    try:
        result = bpy.ops.mpeg4.auto_place_feature_points()
    except RuntimeError as refused:
        print(f"{path.name}: refused: {refused}")
        return None, [], 0.0
    seconds = time.perf_counter() - start
    low = auto_placement.low_confidence(face)
    print(f"{path.name}: {result}, {seconds:.1f} s, {len(face.data.vertices)} vertices; low confidence: {low}")
    return face, low, seconds


def workbench_camera(scene, size: int, ortho_scale: float, clip_end: float) -> bpy.types.Object:
    """Square `size`-pixel Workbench stills in the materials' colours through a new orthographic camera."""
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "MATERIAL"
    scene.render.resolution_x = scene.render.resolution_y = size
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = ortho_scale
    camera.data.clip_end = clip_end
    return camera


def aim(camera, location: Vector, direction: Vector, up: Vector) -> None:
    """`camera` at `location` looking along -`direction`, the picture's up on the side of `up`."""
    camera.location = location
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    if (camera.matrix_world.to_3x3() @ Vector((0.0, 1.0, 0.0))).dot(up) < 0:
        camera.rotation_euler.rotate_axis("Z", np.pi)


def render(face, low: list[str], out: Path, name: str) -> None:
    scene = bpy.context.scene
    empties = face_data.fp_empties(face)
    at = {fp_id: ob.matrix_world.translation.copy() for fp_id, ob in empties.items()}
    left = (at["3.7"] - at["3.12"]).normalized()
    up = (0.5 * (at["3.7"] + at["3.12"]) - at["2.1"]).normalized()
    up = (up - left * up.dot(left)).normalized()
    forward = left.cross(up)
    width = (at["10.1"] - at["10.2"]).length
    centre = 0.5 * (at["11.4"] + at["2.1"]) + forward * 0.2 * width
    skin = _material("skin")
    for ob in bpy.data.objects:
        if ob.type == "MESH":
            ob.data.materials.clear()
            ob.data.materials.append(skin)
    marks = {kind: _material(kind) for kind in ("sure", "low")}
    for fp_id, position in at.items():
        bpy.ops.mesh.primitive_uv_sphere_add(radius=MARK_SHARE * width, location=position, segments=12, ring_count=8)
        bpy.context.active_object.data.materials.append(marks["low" if fp_id in low else "sure"])
    camera = workbench_camera(scene, SIZE, 1.6 * width, 100.0 * width)
    for view, direction in {"front": forward, "three_quarter": (forward + 0.8 * left).normalized()}.items():
        aim(camera, centre + direction * 5.0 * width, direction, up)
        scene.render.filepath = str(out / f"auto_placement_{name}_{view}.png")
        bpy.ops.render.render(write_still=True)
        print(scene.render.filepath)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--heads", type=Path, default=ROOT.parent / "shared" / "heads")
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--development", type=Path, help="a development head (.blend with a mesh named Head)")
    parser.add_argument(
        "--extra", type=Path, nargs="*", default=[], help="other heads (.obj, one mesh), rendered by file name"
    )
    parser.add_argument("--only-extra", action="store_true", help="render only the --development and --extra heads")
    args = parser.parse_args()
    heads = {name: (args.heads / file, face, parts) for name, (file, face, parts) in HEADS.items()}
    if args.only_extra:
        heads = {}
    if args.development:
        heads["development"] = (args.development, "Head", ())
    for path in args.extra:
        heads[path.stem] = (path, None, ())
    addon.register()
    try:
        for name, (path, face_name, parts) in heads.items():
            face, low, _seconds = place(path, face_name, parts)
            if face is not None:
                render(face, low, args.out, name)
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
