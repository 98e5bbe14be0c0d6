"""Close-ups of the mouth at the worst lip crossings, before and after the lips' stops (docs/lips_before_after.png).

    .venv/bin/python -m scripts.docs.render_lips [--out docs/lips_before_after.png] [--random 1000]

Columns, each seen from the front and from the left and below: the viseme x expression frame and the
random lip-FAP frame (`scripts/bench/lip_crossing.py`, seed 0) whose lips cross deepest before. Top rows
"before": decode stopping only the CLOSING_PAIRS where they meet, no lip guard. Bottom rows "after": decode
keeping the lip columns and corners in order, and `guard_lips` on the deformed head. Workbench, 360 px tiles.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from addon.deform.lips import guard_lips, lip_penetration
from addon.mpeg4 import decode
from addon.mpeg4.feature_points import FP_IDS, fp_index
from scripts import convert
from scripts.bench import evaluate, lip_crossing
from scripts.docs.closeups import aim_camera, closeup_camera, open_sample, save_rows

ROOT = Path(__file__).resolve().parents[2]
TILE = 360
VIEWS = ((0.0, 0.0), (55.0, 25.0))  # camera yaw and pitch (degrees) about the mouth: front, left and below


def old_stops(face_neutral: np.ndarray, pts: np.ndarray) -> None:
    """The stops as they were: only the CLOSING_PAIRS, each where its two points meet."""
    for upper, lower in decode.CLOSING_PAIRS:
        decode._meet(face_neutral, pts, upper, lower)


def deformed(face, deformer, neutral, fapu, lips, values: np.ndarray, after: bool) -> tuple[np.ndarray, float]:
    """The head's positions for one FAP frame, and how deep its lips cross (m)."""
    rows = [fp_index(fp_id) for fp_id in face.fp_ids]
    saved = decode._stop_at_closure
    decode._stop_at_closure = saved if after else old_stops
    try:
        points = decode.fap_to_fp(neutral, values[None], fapu)[0, rows]
    finally:
        decode._stop_at_closure = saved
    out = deformer.evaluate(points)
    triangles, upper, lower, guard = lips
    if after:
        guard_lips(guard, out, points)
    into_lower, into_upper = lip_penetration(out, triangles, upper, lower)
    return out, max(np.nanmax(into_lower), np.nanmax(into_upper))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "lips_before_after.png")
    parser.add_argument("--random", type=int, default=1000)
    args = parser.parse_args(argv)
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    empties = {o["mpeg4_fp"]: o for o in bpy.data.collections[f"{evaluate.HEAD} FPs"].objects if "mpeg4_fp" in o}
    neutral = np.array([empties[fp_id].location for fp_id in FP_IDS], dtype=np.float64)
    fapu = evaluate.compute_fapu({fp_id: np.array(o.location) for fp_id, o in empties.items()})
    params = face.bind_params("planar_bones", 1.0, 2.0, "face")
    deformer = evaluate.METHODS["planar_bones"](face.rest, face.control_rest, face.triangles, **params)
    lips = lip_crossing.sample_lips(face, neutral)
    worst = []
    for frames in (lip_crossing.viseme_expression_frames(), lip_crossing.random_frames(args.random, 0)):
        depth = [deformed(face, deformer, neutral, fapu, lips, row, after=False)[1] for row in frames]
        worst.append(frames[int(np.argmax(depth))])
    scene, head = open_sample()
    camera = closeup_camera(scene, head, TILE, 0.055)
    mouth = Vector(bpy.data.objects["FP 2.2"].matrix_world.translation)
    distance = (camera.location - mouth).length
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        convert.render_frame(scene, scene.frame_current, Path(tmp) / "tile.png")  # the first render shows rest
        for after in (False, True):
            for yaw, pitch in VIEWS:
                aim_camera(camera, mouth, distance, yaw, pitch)
                tiles = []
                for values in worst:
                    positions, depth = deformed(face, deformer, neutral, fapu, lips, values, after)
                    head.data.attributes["position"].data.foreach_set("vector", positions.astype(np.float32).ravel())
                    head.data.update()
                    bpy.context.view_layer.update()
                    print(f"{'after' if after else 'before'} yaw {yaw:g}: crossing {1e3 * depth:.3f} mm")
                    tiles.append(convert.render_frame(scene, scene.frame_current, Path(tmp) / "tile.png"))
                rows.append(np.concatenate(tiles, axis=1))
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
