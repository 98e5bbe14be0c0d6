"""Render the sample head with its 84 feature points labelled (`docs/fp_front.png`, `fp_three_quarter.png`).

    .venv/bin/python -m scripts.docs.render_fp_docs [--blend sample_blends/makehuman_head.blend] [--out docs/]

Workbench renders (about 1200 x 1200) of the sample file with a small sphere on every FP and its id
as a text object next to it, facing the camera.
"""

import argparse
import math
import sys
from pathlib import Path

import bpy
from mathutils import Vector

ROOT = Path(__file__).resolve().parents[2]
SIZE = 1200
SPHERE_RADIUS = 0.0012  # m
LABEL_SIZE = 0.0032  # m
VIEWS = {
    # name: (direction from the head to the camera in head-local coordinates, orthographic scale in m)
    "fp_front": (Vector((0.0, -1.0, 0.0)), 0.27),
    "fp_three_quarter": (Vector((0.75, -1.0, 0.1)), 0.27),
}
SKIN = (0.82, 0.78, 0.74, 1.0)
MARK = (0.85, 0.1, 0.05, 1.0)
LABEL = (0.05, 0.1, 0.6, 1.0)


def _material(name: str, colour) -> bpy.types.Material:
    material = bpy.data.materials.new(name)
    material.diffuse_color = colour
    return material


def decorate(head: bpy.types.Object, camera_direction: Vector) -> list[bpy.types.Object]:
    """Spheres and labels for every FP empty; returns the objects made (to remove between views)."""
    made = []
    mark, label = _material("FP mark", MARK), _material("FP label", LABEL)
    sphere = bpy.data.meshes.new("FP sphere")
    _uv_sphere(sphere, SPHERE_RADIUS)
    sphere.materials.append(mark)
    to_camera = camera_direction.normalized()
    right = Vector((0.0, 0.0, 1.0)).cross(to_camera).normalized() * -1.0
    up = to_camera.cross(right).normalized() * -1.0
    rotation = to_camera.to_track_quat("Z", "Y").to_euler()
    for empty in head.children_recursive:
        if "mpeg4_fp" not in empty:
            continue
        world = empty.matrix_world.translation
        dot = bpy.data.objects.new(f"mark {empty.name}", sphere)
        dot.location = world + to_camera * 0.002
        text = bpy.data.curves.new(f"label {empty.name}", "FONT")
        text.body = empty["mpeg4_fp"]
        text.size = LABEL_SIZE
        text.materials.append(label)
        caption = bpy.data.objects.new(f"label {empty.name}", text)
        side = 1.0 if empty.matrix_world.translation.x >= head.matrix_world.translation.x - 1e-6 else -1.0
        caption.location = world + to_camera * 0.02 + right * (0.0016 * side) + up * 0.0005
        if side < 0:
            text.align_x = "RIGHT"
        caption.rotation_euler = rotation
        for obj in (dot, caption):
            bpy.context.scene.collection.objects.link(obj)
            made.append(obj)
    return made


def _uv_sphere(mesh: bpy.types.Mesh, radius: float, rings: int = 8, segments: int = 12) -> None:
    vertices = [(0.0, 0.0, radius)]
    for i in range(1, rings):
        polar = math.pi * i / rings
        for j in range(segments):
            azimuth = 2 * math.pi * j / segments
            ring = radius * math.sin(polar)
            vertices.append((ring * math.cos(azimuth), ring * math.sin(azimuth), radius * math.cos(polar)))
    vertices.append((0.0, 0.0, -radius))
    faces = [(0, 1 + (j + 1) % segments, 1 + j) for j in range(segments)]
    for i in range(rings - 2):
        a, b = 1 + i * segments, 1 + (i + 1) * segments
        faces += [(a + j, a + (j + 1) % segments, b + (j + 1) % segments, b + j) for j in range(segments)]
    last, bottom = 1 + (rings - 2) * segments, len(vertices) - 1
    faces += [(last + j, last + (j + 1) % segments, bottom) for j in range(segments)]
    mesh.from_pydata(vertices, [], faces)


def render(blend: Path, out: Path) -> None:
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    head = bpy.data.objects["Head"]
    skin = _material("skin", SKIN)
    for obj in [head, *head.children]:
        if obj.type == "MESH" and not obj.name.endswith(("Control", "Reference")):
            obj.data.materials.clear()
            obj.data.materials.append(skin)
        if obj.name.endswith("Control"):
            obj.hide_render = True
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "MATERIAL"
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.film_transparent = False
    camera = bpy.data.objects.new("FP camera", bpy.data.cameras.new("FP camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.data.type = "ORTHO"
    centre = head.matrix_world @ Vector((0.0, -0.05, 0.04))
    for name, (direction, scale) in VIEWS.items():
        made = decorate(head, direction)
        camera.data.ortho_scale = scale
        camera.location = centre + direction.normalized() * 1.0
        camera.rotation_euler = direction.normalized().to_track_quat("Z", "Y").to_euler()
        scene.render.filepath = str(out / f"{name}.png")
        bpy.ops.render.render(write_still=True)
        for obj in made:
            bpy.data.objects.remove(obj)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", default=str(ROOT / "sample_blends" / "makehuman_head.blend"))
    parser.add_argument("--out", default=str(ROOT / "docs"))
    args = parser.parse_args()
    render(Path(args.blend), Path(args.out))


if __name__ == "__main__":
    sys.exit(main())
