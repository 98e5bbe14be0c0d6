"""ICT FaceKit's sculpted ARKit shapes over ours on the ICT head (docs/arkit_ict.png), and the feature points
Place Feature Points Automatically put on it.

    .venv/bin/python -m scripts.bench.arkit_ict --ict DIR --blend /tmp/ict_head.blend
    .venv/bin/python -m scripts.docs.render_arkit_ict --ict DIR --blend /tmp/ict_head.blend [--out docs/arkit_ict.png]

The first command sets the ICT head up as a user would and saves it with our ARKit keys; this one adds ICT's
sculpts to it as keys of their own and renders, per shape, ICT's sculpt (top) over ours (below), Workbench, front
view; the first column is the neutral head with the placed feature points as small spheres.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from addon.blender import face_data
from scripts import convert
from scripts.bench.arkit_ict import FACE_AREA, SKIN, arkit_name, read_obj
from scripts.docs.render_speech import Captions, grid

ROOT = Path(__file__).resolve().parents[2]
SHAPES = (
    "jawOpen",
    "mouthSmileLeft",
    "mouthLeft",
    "mouthPucker",
    "mouthFunnel",
    "eyeBlinkLeft",
    "browDownLeft",
    "browInnerUp",
    "noseSneerLeft",
    "cheekPuff",
)


def _ict_key(head, folder: Path, name: str, neutral: np.ndarray) -> None:
    offsets = np.zeros((len(SKIN), 3))
    for path in folder.glob("*.obj"):
        if arkit_name(path.stem) == name:
            offsets += (read_obj(path) - neutral)[SKIN.start : SKIN.stop]
    offsets[FACE_AREA:] = 0.0  # compared on the face area only
    block = head.shape_key_add(name=f"ICT {name}", from_mix=False)
    block.value = 0.0
    base = np.empty(3 * len(SKIN), np.float32)
    head.data.shape_keys.reference_key.data.foreach_get("co", base)
    block.data.foreach_set("co", (base.reshape(-1, 3) + offsets).astype(np.float32).ravel())


def _markers(head) -> None:
    """A small sphere at each FP empty (empties do not render)."""
    mesh = bpy.data.meshes.new("FP marker")
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=8, v_segments=6, radius=0.0015)
    bm.to_mesh(mesh)
    bm.free()
    material = bpy.data.materials.new("FP marker")
    material.diffuse_color = (0.9, 0.1, 0.1, 1.0)
    mesh.materials.append(material)
    for fp_id, empty in face_data.fp_empties(head).items():
        ob = bpy.data.objects.new(f"marker {fp_id}", mesh)
        ob.location = empty.matrix_world.translation
        bpy.context.scene.collection.objects.link(ob)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ict", type=Path, required=True)
    parser.add_argument("--blend", type=Path, required=True, help="the head arkit_ict saved")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "arkit_ict.png")
    parser.add_argument("--tile", type=int, default=240)
    args = parser.parse_args(argv)
    convert.addon_package()
    bpy.ops.wm.open_mainfile(filepath=str(args.blend))
    scene, head = bpy.context.scene, bpy.data.objects["Head"]
    head.mpeg4_face.control_object.hide_render = True  # (the FP empties stay at rest: the keys alone show)
    neutral = read_obj(args.ict / "generic_neutral_mesh.obj")
    for name in SHAPES:
        _ict_key(head, args.ict, name, neutral)
    blocks = head.data.shape_keys.key_blocks
    convert.frame_face(scene, head, args.tile)
    convert.set_engine(scene, "WORKBENCH")
    scene.render.resolution_x = scene.render.resolution_y = args.tile
    writer = Captions(args.tile)
    columns = []
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "tile.png"

        def shot(caption: str) -> np.ndarray:
            picture = convert.render_frame(scene, scene.frame_current, scratch)
            return np.concatenate([writer.render(caption, Path(tmp) / "caption.png"), picture], axis=0)

        _markers(head)
        neutral_tile = shot("feature points")
        markers = [ob for ob in scene.objects if ob.name.startswith("marker ")]
        for ob in markers:
            ob.hide_render = True
        columns.append((neutral_tile, shot("neutral")))
        for name in SHAPES:
            for block in blocks:
                block.value = 0.0
            blocks[f"ICT {name}"].value = 1.0
            top = shot(f"ICT {name}")
            blocks[f"ICT {name}"].value = 0.0
            blocks[name].value = 1.0
            columns.append((top, shot(f"ours {name}")))
            blocks[name].value = 0.0
    bpy.data.scenes.remove(writer.scene)
    images = [top for top, _ in columns] + [bottom for _, bottom in columns]
    convert.save_png(grid(images, len(columns)), args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
