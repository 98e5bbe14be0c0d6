"""Close-ups of a mouth corner at the mouth units whose skin passed through itself there (docs/mouth_corner_*.png).

    .venv/bin/python -m scripts.docs.render_mouth_corner [--out docs/mouth_corner_after.png] [--targets DIR]

Columns: compression, corner puller (smile), upward retraction, each seen from the front and from the side
below the corner (FP 8.4). Rows, top to bottom: the sculpt; the add-on with Keep Lips Apart off; with it on (as the
checkout's code builds it). The FP empties move by the unit's FP motion as `scripts.bench.evaluate` moves them.
Triangles passing through another (`overlaps.crossing_pairs`, with a corner moved) are red, the rest grey; the
count per tile is printed. Workbench, 300 px tiles.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from scripts import convert
from scripts.bench import evaluate
from scripts.docs.closeups import aim_camera, closeup_camera, render_tile, save_rows, set_up_sample, unit_arguments
from scripts.docs.render_eyes_brows import positions
from scripts.docs.render_unfold import RED, unit_sculpts_and_motions

ROOT = Path(__file__).resolve().parents[2]
TILE = 300
UNITS = ("mouth-compression", "mouth-corner-puller", "mouth-upward-retraction")
VIEWS = ((0.0, 0.0), (-60.0, -30.0))  # camera yaw and pitch (degrees) about the corner: front, and side from below
ORTHO = 0.016  # m across a tile


def paint_crossings(head, rest: np.ndarray, deformed: np.ndarray) -> int:
    """Colour the polygons with a triangle passing through another red, the rest grey; how many pairs cross."""
    face_data = convert._addon("blender.face_data")
    overlaps = convert._addon("deform.overlaps")
    mesh = head.data
    triangles, polygon_of = face_data.mesh_fans(mesh)
    pairs = overlaps.crossing_pairs(deformed, triangles, np.any(deformed != rest, axis=1))
    crossed = np.zeros(len(mesh.polygons), bool)
    crossed[polygon_of[pairs.ravel()]] = True
    sizes = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_total", sizes)
    colours = np.where(np.repeat(crossed, sizes)[:, None], RED, (0.8, 0.8, 0.8, 1.0)).astype(np.float32)
    name = "Crossings"
    attribute = mesh.color_attributes.get(name) or mesh.color_attributes.new(name, "FLOAT_COLOR", "CORNER")
    attribute.data.foreach_set("color", colours.reshape(-1))
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.find(name)
    return len(pairs)


def main(argv=None) -> int:
    args = unit_arguments(__doc__, ROOT / "docs" / "mouth_corner_after.png", argv)
    sample = evaluate.load_face(evaluate.DEFAULT_FACE)
    sculpts, motions = unit_sculpts_and_motions(sample, UNITS, args.targets)
    scene, head, _empties, controls, at_rest, rest = set_up_sample(sample.fp_ids)
    live = convert._addon("blender.live")
    camera = closeup_camera(scene, head, TILE, ORTHO)
    scene.display.shading.color_type = "VERTEX"

    def show(name, guarded):
        head.mpeg4_face.keep_lips_apart = guarded
        for ob, place, offset in zip(controls, at_rest, motions[name], strict=True):
            ob.location = place + Vector(offset)
        bpy.context.view_layer.update()
        live.apply_face(head, force=True)
        return positions(head.data)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for row in ("sculpt", "Keep Lips Apart off", "Keep Lips Apart on"):
            tiles = []
            for name in UNITS:
                deformed = show(name, row != "Keep Lips Apart off")
                if row == "sculpt":
                    deformed = rest + sculpts[name]
                    head.data.attributes["position"].data.foreach_set("vector", deformed.astype(np.float32).ravel())
                    head.data.update()
                print(f"{name}, {row}: {paint_crossings(head, rest, deformed)} crossing pairs")
                for yaw, pitch in VIEWS:
                    corner = bpy.data.objects["FP 8.4"].matrix_world.translation  # where the unit moved it
                    aim_camera(camera, corner, 0.4, yaw, pitch)
                    tiles.append(render_tile(scene, tmp))
            rows.append(tiles)
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
