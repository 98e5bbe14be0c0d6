"""Close-ups of the eyelids before and after the lids turn over the eyeballs (docs/eyes_before_after.png).

    .venv/bin/python -m scripts.docs.render_eyes [--out docs/eyes_before_after.png]

Columns: rest, half blink, full blink, lids overlapping (upper 1024 and lower 700 IRISD: more than the
opening), gaze up, gaze down. Top row "before": Planar Bones moving the mid-lid FPs as given (the lids
pinch into a V, cross into an X, and stay put when the eyes turn). Bottom row "after": the add-on as it is
(FAPs stop where the lids meet, the lids turn about the eyeball centres and follow the gaze in part).
Workbench, 300 px tiles of the left eye.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from scripts import convert
from scripts.docs.closeups import closeup_camera, open_sample

ROOT = Path(__file__).resolve().parents[2]
TILE = 300
POSES = (  # FAP number -> value
    {},
    {19: 512, 20: 512},
    {19: 1024, 20: 1024},
    {19: 1024, 20: 1024, 21: 700, 22: 700},
    {25: -30000, 26: -30000},
    {25: 30000, 26: 30000},
)
MOVED = ("3.1", "3.2", "3.3", "3.4", "3.5", "3.6")


def pose(face, values: dict[int, float]) -> None:
    """Put the lid and pupil FP empties where the FAP values send them."""
    fap_io, decode = convert._addon("blender.fap_io"), convert._addon("mpeg4.decode")
    fp_index = convert._addon("mpeg4.feature_points").fp_index
    face_data = convert._addon("blender.face_data")
    empties = face_data.fp_empties(face)
    row = np.zeros((1, 68))
    for number, value in values.items():
        row[0, number - 1] = value
    neutral = face_data.neutral_positions(empties)
    points = decode.fap_to_fp(neutral, row, fap_io.face_fapu(face), eye_pivots=fap_io.eye_pivots(face))[0]
    for fp_id in MOVED:
        empties[fp_id].location = points[fp_index(fp_id)]
    bpy.context.view_layer.update()
    convert._addon("blender.live").apply_face(face, force=True)


def before_mode(on: bool, saved={}) -> None:  # noqa: B006 (the originals, kept across calls)
    """Turn the lids' own turn and the stop at closure off (on=True) or back on."""
    rig, decode = convert._addon("blender.eyelid_rig"), convert._addon("mpeg4.decode")
    if not saved:
        saved.update(hold=rig.hold, apply=rig.apply, stop=decode._stop_at_closure)
    rig.hold = (lambda face, binding, ids, points: points) if on else saved["hold"]
    rig.apply = (lambda face, binding, out, fps: None) if on else saved["apply"]
    decode._stop_at_closure = (lambda neutral, pts: None) if on else saved["stop"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "eyes_before_after.png")
    args = parser.parse_args(argv)
    scene, face = open_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    camera = closeup_camera(scene, face, TILE, 0.035)
    pupil = bpy.data.objects["FP 3.5"].matrix_world.translation
    camera.location.x, camera.location.z = pupil.x, pupil.z + 0.002
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for before in (True, False):
            before_mode(before)
            tiles = []
            for values in POSES:
                pose(face, values)
                tiles.append(convert.render_frame(scene, scene.frame_current, Path(tmp) / "tile.png"))
            rows.append(np.concatenate(tiles, axis=1))
    convert.save_png(np.concatenate(rows[::-1], axis=0), args.out)  # image rows go bottom-up: first row on top
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
