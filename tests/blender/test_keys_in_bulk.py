"""animation.set_keys: linear keys with flat runs left out evaluate exactly as one key per frame would, at the
frames and between them; an imported stream's keys are its decoded FP positions, and the digest kept for live
gains is the keys' own."""

import bpy
import numpy as np
import pytest

from addon.blender import animation, face_data, fap_io
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.feature_points import fp_index

from .helpers import DEMO_FAP, set_up_sample


def _curve(name: str):
    ob = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(ob)
    return animation.ensure_fcurve(ob, "location", 0, name)


def _every_frame(fcurve, frames, values) -> None:
    """The reference: one linear key per frame."""
    points = fcurve.keyframe_points
    points.add(len(frames))
    co = np.column_stack([frames, values]).astype(np.float32)
    points.foreach_set("co", co.ravel())
    points.foreach_set("interpolation", np.full(len(frames), animation.LINEAR, dtype=np.int32))
    fcurve.update()


@pytest.mark.parametrize(
    "values",
    [
        [0.0, 0.0, 0.0, 0.0, 0.3, 0.3, 0.3, 0.1, 0.1, 0.5, 0.5, 0.5, 0.5],  # flat runs at both ends and inside
        [0.1, 0.2, 0.2, 0.1, -0.4, 0.7, 0.7, 0.7],
        [2.5] * 9,  # a still point
        [1.0, 1.0],
        [0.25],
        [0.1, 0.1 + 1e-9, 0.1],  # equal once stored as float32
    ],
)
def test_set_keys_evaluates_as_one_key_per_frame(values):
    frames = 10.0 + 0.5 * np.arange(len(values))  # half frames, as a 60 fps stream on a 30 fps scene
    fcurve, reference = _curve("thinned"), _curve("reference")
    keys = animation.set_keys(fcurve, frames, np.array(values))
    _every_frame(reference, frames, values)
    read = np.empty(2 * len(fcurve.keyframe_points), dtype=np.float32)
    fcurve.keyframe_points.foreach_get("co", read)
    assert np.array_equal(read.reshape(-1, 2), keys)  # what set_keys says the curve holds
    assert len(keys) <= len(values) and keys[0, 0] == frames[0] and keys[-1, 0] == frames[-1]
    times = np.linspace(frames[0] - 1.0, frames[-1] + 1.0, 16 * len(values) + 33)
    assert [fcurve.evaluate(t) for t in times] == [reference.evaluate(t) for t in times]
    assert [fcurve.evaluate(f) for f in frames] == list(np.float32(values))


def test_set_keys_leaves_out_only_keys_inside_flat_runs():
    keys = animation.linear_keys(np.arange(8.0), np.array([0, 0, 0, 1, 1, 2, 2, 2], dtype=float))
    assert keys.tolist() == [[0, 0], [2, 0], [3, 1], [4, 1], [5, 2], [7, 2]]


def test_an_imported_stream_keys_its_fp_positions_and_remembers_their_digest():
    head = set_up_sample()
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=1, timing="SCENE") == {"FINISHED"}
    empties = face_data.fp_empties(head)
    options = fap_io.ImportOptions(start_frame=1, use_stream_fps=False)
    decoded = fap_io.decode_stream(bpy.context, head, read_fap(DEMO_FAP), options, DEMO_FAP.name)
    keyed = np.array(
        [
            [[animation.find_fcurve(ob, "location", axis).evaluate(f) for axis in range(3)] for f in decoded.frames]
            for ob in empties.values()
        ]
    )  # (FPs, frames, 3)
    expected = np.stack([decoded.points[:, fp_index(fp_id)] for fp_id in empties]).astype(np.float32)
    assert np.array_equal(keyed.astype(np.float32), expected)
    curves = fap_io._keyed_curves(head, empties, decoded.head is not None)
    assert sum(len(c.keyframe_points) for c in curves) < 0.5 * len(curves) * len(decoded.frames)  # most are flat
    assert head.mpeg4_face[fap_io.RECORD]["checksum"] == fap_io._checksum(fap_io._keys(curves))
