"""Close-ups of feature points placed automatically on a head (docs/auto_placement_scan_mouth.png).

    .venv/bin/python -m scripts.docs.render_slit_mouth [--head ../shared/heads/leeperrysmith_scan.obj] [--out PNG]
        [--region mouth|nose|chin]

The head (.obj, .glb with its only mesh, or a .blend with a mesh named Head, its FP empties replaced) is imported
and placed as `scripts.docs.render_auto_placement` places it; Workbench renders the region from the front and from
the face's left (45 degrees round for the mouth, 90 for the nose's base and the chin: their points lie along the
profile), side by side. Mouth marks: inner upper lip (2.2, 2.6, 2.7) red, inner lower lip (2.3, 2.8, 2.9) blue,
inner corners (2.4, 2.5) green, outer upper lip (8.1, 8.5, 8.6, 8.9, 8.10) orange, outer lower lip (8.2, 8.7, 8.8)
cyan, outer corners (8.3, 8.4) dark green. Nose marks: the base's edges 9.4/9.5 red, the subnasale 9.15 blue, the
nostril borders 9.1/9.2 green, the tip 9.3 orange, the upper lip's middle 8.1 cyan. Chin marks: the chin boss
2.10 red, the chin's bottom 2.1 blue, its corners 2.11/2.12 green, the jaw's corners 2.13/2.14 orange, the lower
lip's middle 8.2 and corners 8.3/8.4 cyan. Run from another checkout with that checkout's package first on the
path (PYTHONPATH) to render its placement for comparison.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import bpy
from mathutils import Vector

import addon
from addon.blender import face_data
from scripts.docs.render_auto_placement import HEADS, ROOT, aim, place, workbench_camera

SIZE = 700
MARK_SHARE = 0.006  # a mark's radius against the ear-to-ear width
RED, BLUE, GREEN, ORANGE, CYAN = (
    (0.9, 0.1, 0.05, 1.0),
    (0.1, 0.2, 0.95, 1.0),
    (0.1, 0.8, 0.1, 1.0),
    (1.0, 0.55, 0.0, 1.0),
    (0.0, 0.8, 0.9, 1.0),
)
# per region: {colour: FPs}, the FPs whose mean is the picture's centre, the side view's angle from the front
REGIONS = {
    "mouth": (
        {
            RED: ("2.2", "2.6", "2.7"),
            BLUE: ("2.3", "2.8", "2.9"),
            GREEN: ("2.4", "2.5"),
            ORANGE: ("8.1", "8.5", "8.6", "8.9", "8.10"),
            CYAN: ("8.2", "8.7", "8.8"),
            (0.0, 0.4, 0.1, 1.0): ("8.3", "8.4"),
        },
        ("8.1", "8.2", "8.3", "8.4"),
        45.0,
    ),
    "nose": (
        {RED: ("9.4", "9.5"), BLUE: ("9.15",), GREEN: ("9.1", "9.2"), ORANGE: ("9.3",), CYAN: ("8.1",)},
        ("9.1", "9.2", "9.15", "8.1"),
        90.0,
    ),
    "chin": (
        {
            RED: ("2.10",),
            BLUE: ("2.1",),
            GREEN: ("2.11", "2.12"),
            ORANGE: ("2.13", "2.14"),
            CYAN: ("8.2", "8.3", "8.4"),
        },
        ("2.10", "2.1", "2.11", "2.12"),
        90.0,
    ),
}


def render(face, out: Path, scratch: str, region: str = "mouth") -> None:
    groups, middle, angle = REGIONS[region]
    scene = bpy.context.scene
    at = {fp_id: ob.matrix_world.translation.copy() for fp_id, ob in face_data.fp_empties(face).items()}
    left = (at["3.7"] - at["3.12"]).normalized()
    up = (0.5 * (at["3.7"] + at["3.12"]) - at["2.1"]).normalized()
    up = (up - left * up.dot(left)).normalized()
    forward = left.cross(up)
    width = (at["10.1"] - at["10.2"]).length
    centre = sum((at[k] for k in middle), Vector()) / len(middle)
    skin = bpy.data.materials.new("skin")
    skin.diffuse_color = (0.82, 0.78, 0.74, 1.0)
    for ob in bpy.data.objects:
        if ob.type == "MESH":
            ob.data.materials.clear()
            ob.data.materials.append(skin)
    for colour, fp_ids in groups.items():
        material = bpy.data.materials.new("mark")
        material.diffuse_color = colour
        for fp_id in fp_ids:
            bpy.ops.mesh.primitive_uv_sphere_add(
                radius=MARK_SHARE * width, location=at[fp_id], segments=12, ring_count=8
            )
            bpy.context.active_object.data.materials.append(material)
    camera = workbench_camera(scene, SIZE, 0.5 * width, 100.0 * width)
    tiles = []
    side = math.cos(math.radians(angle)) * forward + math.sin(math.radians(angle)) * left
    for view, direction in {"front": forward, "left": side}.items():
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
    parser.add_argument("--region", choices=sorted(REGIONS), default="mouth")
    args = parser.parse_args()
    addon.register()
    try:
        known = {file: (face_name, parts) for file, face_name, parts in HEADS.values()}  # the shared heads' parts
        face_name, parts = known.get(args.head.name, ("Head" if args.head.suffix == ".blend" else None, ()))
        face, _low, _seconds = place(args.head, face_name, parts)
        if face is not None:
            with tempfile.TemporaryDirectory() as scratch:
                render(face, args.out, scratch, args.region)
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
