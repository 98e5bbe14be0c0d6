"""Close-ups of the faces Planar Bones turns over, without and with Unfold Skin (docs/unfold_before_after.png).

    .venv/bin/python -m scripts.docs.render_unfold [--out docs/unfold_before_after.png] [--targets DIR]

Columns: MakeHuman's mouth-corner-puller at 1.5 times its FP motion (the lip corner passes the line from the nose
wing to the cheek point and the control triangle between them turns over), seen from the front and from the left;
mouth-open at 1.5 seen from below (the fade to rest under the chin). The FP empties are moved by the unit's FP
motion as `scripts.bench.evaluate` moves them. Top row without Unfold Skin, bottom row with it; the faces turned
over are painted red. Workbench, 300 px tiles.
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
from scripts.docs.closeups import aim_camera, closeup_camera, save_rows, set_up_sample, unit_arguments

ROOT = Path(__file__).resolve().parents[2]
TILE = 300
# (unit, its FP motion times, the FP the camera looks at, camera yaw and pitch in degrees, ortho scale)
SHOTS = (
    ("mouth-corner-puller", 1.5, "8.4", 0.0, 0.0, 0.05),
    ("mouth-corner-puller", 1.5, "8.4", -60.0, 0.0, 0.05),
    ("mouth-open", 1.5, "2.10", 0.0, -70.0, 0.09),
)
RED = (1.0, 0.05, 0.05, 1.0)


def unit_motion(face: evaluate.SampleFace, name: str, folder: Path) -> np.ndarray:
    """(M, 3) offsets of the control FPs in the unit `name`."""
    path = next(p for p in folder.iterdir() if p.name.startswith(name + "."))
    return evaluate.target_motion(path, face)[1]


def unit_sculpts_and_motions(face: evaluate.SampleFace, names, folder: Path) -> tuple[dict, dict]:
    """For each unit in `names`: the sculpt's (N, 3) vertex offsets and the control FPs' (M, 3) offsets."""
    files = {evaluate.target_name(p): p for p in evaluate.target_files(folder)}
    sculpts = {name: evaluate.target_motion(files[name], face)[0] for name in names}
    return sculpts, {name: unit_motion(face, name, folder) for name in names}


def paint_folds(head, rest: np.ndarray) -> int:
    """Colour the faces turned over against the rest pose red (a face-corner colour attribute); their count."""
    face_data = convert._addon("blender.face_data")
    folds = convert._addon("deform.folds")
    mesh = head.data
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes["position"].data.foreach_get("vector", positions)
    turned = folds.inverted_faces(rest, positions.reshape(-1, 3).astype(np.float64), *face_data.mesh_fans(mesh))
    name = "Folds"
    attribute = mesh.color_attributes.get(name) or mesh.color_attributes.new(name, "FLOAT_COLOR", "CORNER")
    sizes = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_total", sizes)
    colours = np.where(np.repeat(turned, sizes)[:, None], RED, (0.8, 0.8, 0.8, 1.0)).astype(np.float32)
    attribute.data.foreach_set("color", colours.reshape(-1))
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.find(name)
    return int(turned.sum())


def main(argv=None) -> int:
    args = unit_arguments(__doc__, ROOT / "docs" / "unfold_before_after.png", argv)
    sample = evaluate.load_face(evaluate.DEFAULT_FACE)
    motions = {name: unit_motion(sample, name, args.targets) for name, *_ in SHOTS}
    scene, head, empties, controls, at_rest, rest = set_up_sample(sample.fp_ids)
    live = convert._addon("blender.live")
    camera = closeup_camera(scene, head, TILE, SHOTS[0][-1])
    scene.display.shading.color_type = "VERTEX"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for unfold_skin in (False, True):
            head.mpeg4_face.unfold_skin = unfold_skin
            tiles = []
            for name, scale, target, yaw, pitch, ortho in SHOTS:
                for ob, place, offset in zip(controls, at_rest, motions[name], strict=True):
                    ob.location = place + Vector(scale * offset)
                bpy.context.view_layer.update()
                live.apply_face(head, force=True)
                count = paint_folds(head, rest)
                print(f"{name} x{scale}, Unfold Skin {'on' if unfold_skin else 'off'}: {count} faces turned over")
                camera.data.ortho_scale = ortho
                aim_camera(camera, bpy.data.objects[f"FP {target}"].matrix_world.translation, 0.4, yaw, pitch)
                tiles.append(convert.render_frame(scene, scene.frame_current, Path(tmp) / "tile.png"))
            rows.append(np.concatenate(tiles, axis=1))
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
