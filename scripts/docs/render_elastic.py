"""Workbench renders of Elastic Bones on the sample head, for the README.

    .venv/bin/python -m scripts.docs.render_elastic [--out docs/elastic_bones.png] [--skeleton PNG]

`elastic_bones.png`: the demo stream on the sample head with the Elastic Bones engine, close-ups of the mouth at
rest, with the jaw open, in a pout and in a smile (the peak frames of the stream's first scenes), each tile
400 px. `elastic_skeleton.png`: the skeleton the engine builds on the sample's feature points, front and
three-quarter views, the bones drawn as octahedra (Workbench renders no armature, so a throw-away mesh stands
in for it) through the half-transparent head; the jaw and eye bones (the rotating ones) in blue, the others red.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from scripts import convert
from scripts.docs.closeups import closeup_camera, open_sample
from scripts.docs.render_demo_closeups import PEAK

ROOT = Path(__file__).resolve().parents[2]
TILE = 400
FRAMES = (0, PEAK[0], PEAK[1], PEAK[2])  # rest, jaw, pout, smile


def bone_mesh(arm) -> bpy.types.Object:
    """The armature's bones at rest as octahedra (Blender's own bone shape), one mesh, a material per kind."""
    verts, faces, kinds = [], [], []
    for bone in arm.data.bones:
        head, tail = bone.head_local, bone.tail_local
        axis = tail - head
        length = axis.length
        side = axis.orthogonal().normalized() * min(max(0.15 * length, 0.0025), 0.004)  # stubs stay visible
        other = axis.normalized().cross(side)
        waist = head + 0.1 * axis
        k = len(verts)
        verts += [head, waist + side, waist + other, waist - side, waist - other, tail]
        for i in range(4):
            a, b = k + 1 + i, k + 1 + (i + 1) % 4
            faces += [(k, b, a), (a, b, k + 5)]
            kinds += [bone.name.endswith(("jaw", "eye_l", "eye_r"))] * 2
    mesh = bpy.data.meshes.new("Bones")
    mesh.from_pydata([tuple(v) for v in verts], [], faces)
    for name, colour in (("Bone", (0.85, 0.1, 0.08, 1.0)), ("Rotating Bone", (0.1, 0.3, 0.9, 1.0))):
        material = bpy.data.materials.new(name)
        material.diffuse_color = colour
        mesh.materials.append(material)
    mesh.polygons.foreach_set("material_index", np.array(kinds, dtype=np.int32))
    ob = bpy.data.objects.new("Bones", mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.parent = arm.parent  # armature space is the face's space
    return ob


def render_skeleton(scene, face, arm, path: Path) -> None:
    bones = bone_mesh(arm)
    bones.show_in_front = True
    scene.display.shading.show_xray = True
    scene.display.shading.xray_alpha = 0.35
    camera = scene.camera
    centre = face.matrix_world @ Vector(np.mean([b.head_local for b in arm.data.bones], axis=0))
    camera.data.ortho_scale = 0.26
    tiles = []
    with tempfile.TemporaryDirectory() as tmp:
        for turn in (0.0, math.radians(35.0)):
            distance = 1.0
            camera.location = centre + Vector((distance * math.sin(turn), -distance * math.cos(turn), 0.0))
            camera.rotation_euler = (math.pi / 2, 0.0, turn)
            tiles.append(convert.render_frame(scene, 0, Path(tmp) / "tile.png"))
    convert.save_png(np.concatenate(tiles, axis=1), path)
    scene.display.shading.show_xray = False
    bpy.data.objects.remove(bones)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "elastic_bones.png")
    parser.add_argument("--skeleton", type=Path, default=ROOT / "docs" / "elastic_skeleton.png")
    args = parser.parse_args(argv)
    scene, face = open_sample()
    bpy.ops.mpeg4.set_engine(engine="ELASTIC_BONES")
    scene.render.fps = 25
    bpy.ops.mpeg4.import_fap(filepath=str(ROOT / "sample_blends" / "demo.fap"))
    camera = closeup_camera(scene, face, TILE, 0.11)
    centre = bpy.data.objects["FP 8.1"].matrix_world.translation
    camera.location.x, camera.location.z = centre.x, centre.z - 0.01
    with tempfile.TemporaryDirectory() as tmp:
        tiles = [convert.render_frame(scene, f, Path(tmp) / "tile.png") for f in FRAMES]
    convert.save_png(np.concatenate(tiles, axis=1), args.out)
    print(args.out)
    scene.display.shading.color_type = "MATERIAL"
    render_skeleton(scene, face, face.get("mpeg4_elastic_skeleton"), args.skeleton)
    print(args.skeleton)
    return 0


if __name__ == "__main__":
    sys.exit(main())
