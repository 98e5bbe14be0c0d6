"""Group gains apply live: changing one keys the last imported stream again (fap_io.apply_gains)."""

import bpy
import numpy as np
import pytest

from addon.blender import animation, face_data, fap_io

from .helpers import DEMO_FAP, set_up_sample


def _keys(ob) -> np.ndarray:
    """(K, 4): each frame an axis has a key on (set_keys leaves flat runs out), then x, y, z there."""
    curves = [animation.find_fcurve(ob, "location", axis) for axis in range(3)]
    frames = np.unique(np.concatenate([[point.co.x for point in fcurve.keyframe_points] for fcurve in curves]))
    return np.column_stack([frames, *([fcurve.evaluate(f) for f in frames] for fcurve in curves)]).astype(np.float32)


@pytest.fixture
def imported():
    head = set_up_sample()
    head.mpeg4_face.use_soft_limits = False  # gains then scale FAP values exactly
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=1) == {"FINISHED"}
    return head


def test_a_gain_scales_the_keyed_motion_and_going_back_restores_it(imported):
    head = imported
    empties = face_data.fp_empties(head)
    chin = empties["2.1"]  # moved by the jaw FAPs only (open_jaw, thrust_jaw, shift_jaw, depress_chin)
    brow = empties["4.1"]  # moved by brow FAPs only
    neutral_chin = np.array(chin[face_data.EMPTY_REST_PROP])
    chin_before, brow_before = _keys(chin), _keys(brow)
    assert np.abs(chin_before[:, 1:] - neutral_chin).max() > 1e-3  # the demo opens the jaw

    head.mpeg4_face.gain_jaw = 0.5
    chin_half, brow_half = _keys(chin), _keys(brow)
    assert np.array_equal(chin_half[:, 0], chin_before[:, 0])  # same frames
    np.testing.assert_allclose(chin_half[:, 1:] - neutral_chin, 0.5 * (chin_before[:, 1:] - neutral_chin), atol=2e-7)
    assert np.array_equal(brow_half, brow_before)  # another group: untouched

    head.mpeg4_face.gain_jaw = 1.0
    assert np.array_equal(_keys(chin), chin_before)  # bit for bit as imported


def test_the_shown_frame_follows_the_new_gain(imported):
    head = imported
    chin = face_data.fp_empties(head)["2.1"]
    scene = bpy.context.scene
    keys = _keys(chin)
    neutral = np.array(chin[face_data.EMPTY_REST_PROP])
    frame = keys[np.argmax(np.abs(keys[:, 1:] - neutral).max(axis=1)), 0]
    scene.frame_set(round(frame))  # between keys: linear keys scale with their values
    before = np.array(chin.location) - neutral
    head.mpeg4_face.gain_jaw = 0.25
    np.testing.assert_allclose(np.array(chin.location) - neutral, 0.25 * before, atol=1e-6)


def test_edited_keys_are_kept_and_the_change_is_reported(imported):
    head = imported
    chin = face_data.fp_empties(head)["2.1"]
    fcurve = animation.find_fcurve(chin, "location", 2)
    fcurve.keyframe_points[10].co.y += 0.01  # the user's edit
    edited = _keys(chin)
    head.mpeg4_face.gain_jaw = 0.5
    assert np.array_equal(_keys(chin), edited)
    assert "were changed since it was imported" in head.mpeg4_face.status


def test_a_stream_remembered_by_an_earlier_version_is_kept_and_reported(imported):
    head = imported
    chin = face_data.fp_empties(head)["2.1"]
    head.mpeg4_face[fap_io.RECORD]["checksum"] = [1.0, 2.0, 3.0]  # the key sums versions before the digest kept
    before = _keys(chin)
    head.mpeg4_face.gain_jaw = 0.5
    assert np.array_equal(_keys(chin), before)
    assert "imported by an earlier version" in head.mpeg4_face.status


def test_a_stream_added_on_top_is_not_keyed_again(imported):
    head = imported
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=1, mode="ADD") == {"FINISHED"}
    assert head.mpeg4_face.get(fap_io.RECORD) is None
    chin = face_data.fp_empties(head)["2.1"]
    before = _keys(chin)
    head.mpeg4_face.gain_jaw = 0.5
    assert np.array_equal(_keys(chin), before)
    assert head.mpeg4_face.status == ""


def test_remove_leaves_no_record(imported):
    head = imported
    assert head.mpeg4_face.get(fap_io.RECORD) is not None
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert head.mpeg4_face.get(fap_io.RECORD) is None


def test_elastic_bones_keys_are_baked_again():
    from addon.blender import elastic_rig

    head = set_up_sample()
    head.mpeg4_face.use_soft_limits = False
    assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC) == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=1) == {"FINISHED"}
    arm = elastic_rig.skeleton_object(head)
    jaw = f'pose.bones["{elastic_rig.BONE_PREFIX}jaw"].rotation_quaternion'
    action = arm.animation_data.action
    before = np.array([animation.find_fcurve(arm, jaw, 1).evaluate(f) for f in range(1, 200)])
    head.mpeg4_face.gain_jaw = 0.5
    assert arm.animation_data.action == action  # the same action, keyed again
    after = np.array([animation.find_fcurve(arm, jaw, 1).evaluate(f) for f in range(1, 200)])
    assert np.abs(before).max() > 1e-3 and np.abs(after).max() < 0.75 * np.abs(before).max()
    head.mpeg4_face.gain_jaw = 1.0
    again = np.array([animation.find_fcurve(arm, jaw, 1).evaluate(f) for f in range(1, 200)])
    np.testing.assert_allclose(again, before, atol=1e-6)
