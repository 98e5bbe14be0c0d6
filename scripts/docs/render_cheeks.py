"""Close-ups of the cheeks and the nose's base at mouth units, before and after the mouth's triangles stop at the
outline other parts' FPs hold (docs/cheeks_before_after.png).

    .venv/bin/python -m scripts.docs.render_cheeks [--out docs/cheeks_before_after.png] [--targets DIR]

Columns: smile (mouth-corner-puller), cheek raise (mouth-upward-retraction), upper lip raise (mouth-elevation),
lips pressed and pulled down (mouth-depression-retraction), lips pushed out (mouth-protusion), from the front about
the nose's base (FP 9.15). Rows, top to bottom: the sculpt, coloured by how far each vertex moved; before (the
add-on with `face_binding.stop_at_held_outline` left out), plain, coloured by motion and coloured by the error
against the sculpt; after (the checkout's code), the same three. Colour: dark blue still, through green and yellow
to red at the column's largest sculpted motion (`render_eyes_brows.motion_colours`). The FP empties move by the
unit's FP motion as `scripts.bench.evaluate` moves them; each tile's E against the sculpt, over the head and over
the cheeks' region, is printed. Workbench, 240 px tiles.
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
from scripts.docs.render_eyes_brows import motion_colours, paint, positions
from scripts.docs.render_unfold import unit_sculpts_and_motions

ROOT = Path(__file__).resolve().parents[2]
TILE = 240
UNITS = (
    "mouth-corner-puller",
    "mouth-upward-retraction",
    "mouth-elevation",
    "mouth-depression-retraction",
    "mouth-protusion",
)
CENTRE = "9.15"  # the FP the camera looks at
ORTHO = 0.1  # m across a tile


def render_add_on(sample, sculpts: dict, motions: dict, largest: dict, tmp: str, label: str) -> list[np.ndarray]:
    """Set Up Face on the sample head and render its three rows (plain, coloured by motion, by error)."""
    scene, head, _, controls, at_rest, rest = set_up_sample(sample.fp_ids)
    live = convert._addon("blender.live")
    camera = closeup_camera(scene, head, TILE, ORTHO)
    scene.display.shading.color_type = "VERTEX"
    cheeks = sample.region == evaluate.REGION_NAMES.index("cheeks")
    plain, moved, erred = [], [], []
    for name in UNITS:
        for ob, place, offset in zip(controls, at_rest, motions[name], strict=True):
            ob.location = place + Vector(offset)
        bpy.context.view_layer.update()
        live.apply_face(head, force=True)
        deformed = positions(head.data)
        error = np.linalg.norm(deformed - rest - sculpts[name], axis=1)
        e = evaluate.score(deformed, rest + sculpts[name], rest).e
        e_cheeks = error[cheeks].sum() / np.linalg.norm(sculpts[name][cheeks], axis=1).sum()
        print(f"{label}, {name}: E {e:.3f}, cheeks {e_cheeks:.3f}")
        aim_camera(camera, bpy.data.objects[f"FP {CENTRE}"].matrix_world.translation, 0.4, 0.0, 0.0)
        paint(head.data, None)
        plain.append(render_tile(scene, tmp))
        paint(head.data, motion_colours(np.linalg.norm(deformed - rest, axis=1), largest[name]))
        moved.append(render_tile(scene, tmp))
        paint(head.data, motion_colours(error, largest[name]))
        erred.append(render_tile(scene, tmp))
    return [plain, moved, erred]


def main(argv=None) -> int:
    args = unit_arguments(__doc__, ROOT / "docs" / "cheeks_before_after.png", argv)
    sample = evaluate.load_face(evaluate.DEFAULT_FACE)
    sculpts, motions = unit_sculpts_and_motions(sample, UNITS, args.targets)
    largest = {name: float(np.linalg.norm(sculpts[name], axis=1).max()) for name in UNITS}
    face_binding = convert._addon("deform.face_binding")
    stop = face_binding.stop_at_held_outline
    with tempfile.TemporaryDirectory() as tmp:
        face_binding.stop_at_held_outline = lambda binding, *_: binding
        try:
            before = render_add_on(sample, sculpts, motions, largest, tmp, "before")
        finally:
            face_binding.stop_at_held_outline = stop
        after = render_add_on(sample, sculpts, motions, largest, tmp, "after")
        # the sculpts, written over the last posed face (the same FPs: no re-evaluation)
        scene, head = bpy.context.scene, bpy.data.objects[evaluate.HEAD]
        rest = convert._addon("blender.rest_shape").stored_rest(head.data).astype(np.float64)
        camera = scene.camera
        sculpted_row = []
        for name in UNITS:
            sculpted = rest + sculpts[name]
            head.data.attributes["position"].data.foreach_set("vector", sculpted.astype(np.float32).ravel())
            paint(head.data, motion_colours(np.linalg.norm(sculpts[name], axis=1), largest[name]))
            aim_camera(camera, bpy.data.objects[f"FP {CENTRE}"].matrix_world.translation, 0.4, 0.0, 0.0)
            sculpted_row.append(render_tile(scene, tmp))
            print(f"{name}: largest sculpted motion {1e3 * largest[name]:.2f} mm")
    save_rows([sculpted_row, *before, *after], args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
