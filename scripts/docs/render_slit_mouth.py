"""Close-ups of the mouth's feature points placed automatically on a head (docs/auto_placement_scan_mouth.png).

    .venv/bin/python -m scripts.docs.render_slit_mouth [--head ../shared/heads/leeperrysmith_scan.obj] [--out PNG]

The head is imported and placed as `scripts.docs.render_auto_placement` places it; Workbench renders the mouth from
the front and from the face's left, 45 degrees round, side by side. Marks: inner upper lip (2.2, 2.6, 2.7) red,
inner lower lip (2.3, 2.8, 2.9) blue, inner corners (2.4, 2.5) green, outer upper lip (8.1, 8.5, 8.6, 8.9, 8.10)
orange, outer lower lip (8.2, 8.7, 8.8) cyan, outer corners (8.3, 8.4) dark green. Run from another checkout with
that checkout's package first on the path (PYTHONPATH) to render its placement for comparison.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
from mathutils import Vector

import addon
from addon.blender import face_data
from scripts.docs.render_auto_placement import ROOT, aim, place, workbench_camera

SIZE = 700
MARK_SHARE = 0.006  # a mark's radius against the ear-to-ear width
GROUPS = {
    (0.9, 0.1, 0.05, 1.0): ("2.2", "2.6", "2.7"),
    (0.1, 0.2, 0.95, 1.0): ("2.3", "2.8", "2.9"),
    (0.1, 0.8, 0.1, 1.0): ("2.4", "2.5"),
    (1.0, 0.55, 0.0, 1.0): ("8.1", "8.5", "8.6", "8.9", "8.10"),
    (0.0, 0.8, 0.9, 1.0): ("8.2", "8.7", "8.8"),
    (0.0, 0.4, 0.1, 1.0): ("8.3", "8.4"),
}


def render(face, out: Path, scratch: str) -> None:
    scene = bpy.context.scene
    at = {fp_id: ob.matrix_world.translation.copy() for fp_id, ob in face_data.fp_empties(face).items()}
    left = (at["3.7"] - at["3.12"]).normalized()
    up = (0.5 * (at["3.7"] + at["3.12"]) - at["2.1"]).normalized()
    up = (up - left * up.dot(left)).normalized()
    forward = left.cross(up)
    width = (at["10.1"] - at["10.2"]).length
    centre = sum((at[k] for k in ("8.1", "8.2", "8.3", "8.4")), Vector()) / 4.0
    skin = bpy.data.materials.new("skin")
    skin.diffuse_color = (0.82, 0.78, 0.74, 1.0)
    for ob in bpy.data.objects:
        if ob.type == "MESH":
            ob.data.materials.clear()
            ob.data.materials.append(skin)
    for colour, fp_ids in GROUPS.items():
        material = bpy.data.materials.new("mark")
        material.diffuse_color = colour
        for fp_id in fp_ids:
            bpy.ops.mesh.primitive_uv_sphere_add(
                radius=MARK_SHARE * width, location=at[fp_id], segments=12, ring_count=8
            )
            bpy.context.active_object.data.materials.append(material)
    camera = workbench_camera(scene, SIZE, 0.5 * width, 100.0 * width)
    tiles = []
    for view, direction in {"front": forward, "left": (forward + left).normalized()}.items():
        aim(camera, centre + direction * 5.0 * width, direction, up)
        scene.render.filepath = str(Path(scratch) / f"{view}.png")
        bpy.ops.render.render(write_still=True)
        tiles.append(bpy.data.images.load(scene.render.filepath))
    pixels = [list(image.pixels) for image in tiles]
    joined = bpy.data.images.new("joined", 2 * SIZE, SIZE)
    rows = []
    for y in range(SIZE):
        for tile in pixels:
            rows.extend(tile[4 * SIZE * y : 4 * SIZE * (y + 1)])
    joined.pixels = rows
    joined.filepath_raw = str(out)
    joined.file_format = "PNG"
    joined.save()
    print(out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--head", type=Path, default=ROOT.parent / "shared" / "heads" / "leeperrysmith_scan.obj")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "auto_placement_scan_mouth.png")
    args = parser.parse_args()
    addon.register()
    try:
        face, _low, _seconds = place(args.head, None, ())
        if face is not None:
            with tempfile.TemporaryDirectory() as scratch:
                render(face, args.out, scratch)
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
