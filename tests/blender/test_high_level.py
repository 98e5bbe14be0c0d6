"""FAP 1 (viseme) and FAP 2 (expression) in an imported stream play through the face tables."""

import bpy
import numpy as np

from addon.blender import face_data

from .helpers import set_up_sample

N_FAPS = 68


def _stream(path, frames):
    """frames: list of (viseme fields or None, expression fields or None)."""
    lines = [f"2.1 high 25 {len(frames)}"]
    for i, (viseme, expression) in enumerate(frames):
        mask = ["0"] * N_FAPS
        values = [str(i)]
        if viseme is not None:
            mask[0] = "1"
            values += [str(v) for v in viseme]
        if expression is not None:
            mask[1] = "1"
            values += [str(v) for v in expression]
        lines += [" ".join(mask), " ".join(values)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _gap(head, frame):
    bpy.context.scene.frame_set(frame)
    empties = face_data.fp_empties(head)
    return float(np.linalg.norm(np.array(empties["2.2"].location) - np.array(empties["2.3"].location)))


def test_visemes_open_and_close_the_mouth(tmp_path):
    head = set_up_sample()
    path = _stream(tmp_path / "v.fap", [((10, 0, 63, 0), None), ((1, 0, 63, 0), None), ((0, 0, 63, 0), None)])
    bpy.context.scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(path), start_frame=0) == {"FINISHED"}
    open_gap, closed_gap, neutral_gap = _gap(head, 0), _gap(head, 1), _gap(head, 2)
    assert open_gap > neutral_gap + 0.005  # AA: the jaw drops, the inner lips part by several mm
    assert closed_gap <= neutral_gap + 1e-6  # PP: the lips press together


def test_an_expression_moves_the_mouth_corners(tmp_path):
    head = set_up_sample()
    path = _stream(tmp_path / "e.fap", [(None, (1, 63, 0, 0, 0, 0)), (None, (0, 0, 0, 0, 0, 0))])
    bpy.context.scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(path), start_frame=0) == {"FINISHED"}
    corner = face_data.fp_empties(head)["8.3"]
    bpy.context.scene.frame_set(0)
    joy = np.array(corner.location)
    bpy.context.scene.frame_set(1)
    neutral = np.array(corner.location)
    assert np.linalg.norm(joy - neutral) > 0.001
