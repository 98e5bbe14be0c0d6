"""Make the web player's stand-in `.glb`: the sample head with a jaw bone that opens the mouth and closes it again.

    .venv/bin/python -m scripts.web.make_test_glb OUT.glb [--face sample_blends/makehuman_head.blend]

A stand-in for development and the browser test until `scripts/convert.py --glb` exports the Elastic Bones
engine: two bones (`head`, and `jaw` from the jaw joint to the chin, FP 2.1) skin the head, eyes, teeth and
tongue, and the jaw turns from closed (frame 1, time 0 s) to OPEN_ANGLE open (frame OPEN_FRAME) and back
(frame CLOSE_FRAME). The jaw weights are simple distance ramps, masked by the lip groups: below the mouth line
and in front of the jaw joint, the lower lip all jaw, the upper lip none. Exported with Blender's own glTF
exporter, so the file has the layout the real export will have: skinned meshes, one skin, one animation.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

ROOT = Path(__file__).resolve().parents[2]
FACE = ROOT / "sample_blends" / "makehuman_head.blend"
FPS = 24
OPEN_FRAME = 13
CLOSE_FRAME = 25
OPEN_SECONDS = (OPEN_FRAME - 1) / FPS  # the export starts the animation at 0 s
OPEN_ANGLE = math.radians(14.0)
# Width of the ramps, metres: from the mouth line down, and from the jaw joint forwards
MOUTH_RAMP = 0.015
JOINT_RAMP = 0.03
JAW_FOLLOWERS = ("Teeth Lower", "Tongue")
HEAD_FOLLOWERS = ("Eye L", "Eye R", "Teeth Upper")
COLOURS = {  # base colour (linear), roughness
    "Head": ((0.60, 0.38, 0.29), 0.55),
    "Eye L": ((0.80, 0.80, 0.78), 0.2),
    "Eye R": ((0.80, 0.80, 0.78), 0.2),
    "Teeth Lower": ((0.85, 0.82, 0.72), 0.35),
    "Teeth Upper": ((0.85, 0.82, 0.72), 0.35),
    "Tongue": ((0.55, 0.16, 0.16), 0.5),
}


def fp(name: str) -> Vector:
    return bpy.data.objects[f"FP {name}"].matrix_world.translation.copy()


def smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def jaw_weights(head) -> np.ndarray:
    """Per vertex of the face mesh, the jaw bone's share (the head bone takes the rest, so they sum to 1)."""
    world = np.array(head.matrix_world)
    co = np.array([v.co[:] for v in head.data.vertices]) @ world[:3, :3].T + world[:3, 3]
    mouth_z = 0.5 * (fp("8.3").z + fp("8.4").z)  # the lip corners
    joint_y = 0.5 * (fp("10.7").y + fp("10.8").y)  # the ear lobes, just behind the jaw joint; the face looks down -Y
    weight = smoothstep((mouth_z - co[:, 2]) / MOUTH_RAMP) * smoothstep((joint_y - co[:, 1]) / JOINT_RAMP)
    lip = {name: np.zeros(len(co)) for name in ("upper_lip", "lower_lip")}
    for vertex in head.data.vertices:
        for element in vertex.groups:
            name = head.vertex_groups[element.group].name
            if name in lip:
                lip[name][vertex.index] = element.weight
    return np.maximum(weight, lip["lower_lip"]) * (1.0 - lip["upper_lip"])


def add_rig():
    """An armature `Head Rig` with bones `head` and `jaw`, the jaw turning about the joint below the ears."""
    data = bpy.data.armatures.new("Head Rig")
    rig = bpy.data.objects.new("Head Rig", data)
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    head = data.edit_bones.new("head")
    head.head, head.tail = fp("2.1") + Vector((0, 0.1, 0)), fp("11.4")
    jaw = data.edit_bones.new("jaw")
    jaw.head = Vector((0.0, 0.5 * (fp("10.7").y + fp("10.8").y), 0.5 * (fp("10.7").z + fp("10.8").z)))
    jaw.tail = fp("2.1")
    jaw.parent = head
    bpy.ops.object.mode_set(mode="OBJECT")
    return rig


def skin(obj, rig, jaw: np.ndarray) -> None:
    for name, weights in (("head", 1.0 - jaw), ("jaw", jaw)):
        group = obj.vertex_groups.new(name=name)
        for index, weight in enumerate(weights):
            if weight > 0.0:
                group.add([index], float(weight), "REPLACE")
    obj.modifiers.new("Armature", "ARMATURE").object = rig
    world = obj.matrix_world.copy()
    obj.parent = rig
    obj.matrix_world = world


def animate(rig) -> None:
    """Keys on the jaw's local X rotation, with the sign that moves the chin down."""
    bone = rig.pose.bones["jaw"]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler.x = OPEN_ANGLE
    bpy.context.view_layer.update()
    sign = 1.0 if (rig.matrix_world @ bone.tail).z < fp("2.1").z else -1.0
    for frame, angle in ((1, 0.0), (OPEN_FRAME, sign * OPEN_ANGLE), (CLOSE_FRAME, 0.0)):
        bone.rotation_euler.x = angle
        bone.keyframe_insert("rotation_euler", index=0, frame=frame)
    rig.animation_data.action.name = "open_jaw"
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    scene.frame_start, scene.frame_end = 1, CLOSE_FRAME


def paint(obj) -> None:
    colour, roughness = COLOURS[obj.name]
    material = bpy.data.materials.new(obj.name)
    principled = material.node_tree.nodes["Principled BSDF"]
    principled.inputs["Base Color"].default_value = (*colour, 1.0)
    principled.inputs["Metallic"].default_value = 0.0
    principled.inputs["Roughness"].default_value = roughness
    obj.data.materials.clear()
    obj.data.materials.append(material)


def make(out: Path, face: Path = FACE) -> None:
    bpy.ops.wm.open_mainfile(filepath=str(face))
    head = bpy.data.objects["Head"]
    rig = add_rig()
    skin(head, rig, jaw_weights(head))
    for name in (*JAW_FOLLOWERS, *HEAD_FOLLOWERS):
        obj = bpy.data.objects[name]
        skin(obj, rig, np.full(len(obj.data.vertices), 1.0 if name in JAW_FOLLOWERS else 0.0))
    animate(rig)
    bpy.ops.object.select_all(action="DESELECT")
    for obj in (rig, *(bpy.data.objects[name] for name in COLOURS)):
        obj.select_set(True)
    for name in COLOURS:
        paint(bpy.data.objects[name])
    out.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.export_scene.gltf(
        filepath=str(out),
        export_format="GLB",
        use_selection=True,
        export_animations=True,
        export_anim_slide_to_zero=True,  # frame 1 plays at 0 s
        export_yup=True,
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the .glb to write")
    parser.add_argument("--face", type=Path, default=FACE, help="the set-up sample head (.blend)")
    args = parser.parse_args(argv)
    make(args.out.resolve(), args.face.resolve())
    seconds = (CLOSE_FRAME - 1) / FPS
    print(f"{args.out}: {args.out.stat().st_size} bytes, mouth open at {OPEN_SECONDS:g} s of {seconds:g} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
