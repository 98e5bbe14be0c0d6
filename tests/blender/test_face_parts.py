"""Face parts (fields filled by name, eyes about their fitted centres, lashes on the lids), masks made from the
FPs for a face without them, the lids' turn in playback, and Remove leaving the file as it was."""

import bmesh
import bpy
import numpy as np
import pytest
from mathutils import Matrix, Vector

from addon.blender import animation, eyelid_rig, face_data, fap_io, followers
from addon.mpeg4.fap_file import read_fap

from .helpers import DEMO_FAP, SAMPLE, evaluated_positions, positions, select
from .test_hardening import snapshot, unset_sample

MASKS = ("upper_lip", "lower_lip", "upper_eyelid", "lower_eyelid")


def _frame_of(stream, index):
    scene = bpy.context.scene
    return round(scene.frame_start + stream.frame_numbers[index] / stream.fps * scene.render.fps)


def test_set_up_fills_the_part_fields_by_name():
    head = unset_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    s = head.mpeg4_face
    names = {name: getattr(s, name).name if getattr(s, name) else None for name in followers.PARTS}
    assert names == {
        "left_eye": "Eye L",
        "right_eye": "Eye R",
        "upper_teeth": "Teeth Upper",
        "lower_teeth": "Teeth Lower",
        "tongue": "Tongue",
        "lashes": None,
        "brows": None,
    }


def test_a_field_the_user_set_wins_over_the_name():
    head = unset_sample()
    tongue = bpy.data.objects["Tongue"]
    tongue.name = "Blob"
    assert followers.find_followers(head)["tongue"] is None
    head.mpeg4_face.tongue = tongue
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert followers.DRIVER_TAG in tongue and tongue.animation_data.drivers


def test_a_missing_part_is_named_when_a_stream_needs_it():
    head = unset_sample()
    bpy.data.objects["Eye L"].name = "Ball"  # not found by name: the left eye field stays empty
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert head.mpeg4_face.left_eye is None
    options = fap_io.ImportOptions(start_frame=1)
    decoded = fap_io.decode_stream(bpy.context, head, read_fap(DEMO_FAP), options, "demo.fap")
    text = " | ".join(str(n) for n in decoded.notes)
    assert "no Left Eye set in Face Parts" in text and "FAP 23, 25" in text
    assert "Right Eye" not in text and "Tongue" not in text  # present, or not needed by the demo


def _shift_origin(ob, offset):
    """Move an object's origin by `offset` (its local axes) without moving its mesh in the world."""
    ob.data.transform(Matrix.Translation(-Vector(offset)))
    ob.location += Vector(offset)


def test_an_off_centre_eyeball_turns_about_its_centre():
    head = unset_sample()
    eye = bpy.data.objects["Eye L"]
    centre_before = np.array(eye.matrix_world @ Vector(np.mean([v.co for v in eye.data.vertices], axis=0)))
    _shift_origin(eye, (0.0, 0.02, 0.01))  # origin 22 mm behind and above the centre
    bpy.context.view_layer.update()
    before = snapshot()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    np.testing.assert_allclose(followers.eye_centre(head, eye), centre_before - np.array(head.location), atol=1e-6)
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    stream = read_fap(DEMO_FAP)
    look = int(np.argmax(np.abs(stream.values[:, 22]) + np.abs(stream.values[:, 24])))  # left eye yaw/pitch
    bpy.context.scene.frame_set(_frame_of(stream, look))
    assert abs(eye.delta_rotation_euler.z) > 0.1  # it turned...
    expressions = [d.driver.expression for d in eye.animation_data.drivers]
    assert all(d.driver.is_valid for d in eye.animation_data.drivers) and "np." not in "".join(expressions)
    mesh = evaluated_positions(eye)
    world = np.array(eye.matrix_world)
    centre = world[:3, :3] @ mesh.mean(axis=0) + world[:3, 3]
    np.testing.assert_allclose(centre, centre_before, atol=1e-5)  # ...about its centre, which stayed put
    bpy.context.scene.frame_end = before["scene"][1]  # the import extended it
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    bpy.context.view_layer.update()
    assert snapshot() == before


def _add_lashes(head):
    """A small strip of 'lashes' along the left upper lid margin, a child of the head."""
    empties = face_data.fp_empties(head)
    lid, inner, outer = (np.array(empties[f].location) for f in ("3.1", "3.11", "3.7"))
    mesh = bpy.data.meshes.new("Lashes")
    bm = bmesh.new()
    verts = [bm.verts.new(p + (0.0, -0.0005, dz)) for p in (inner, lid, outer) for dz in (0.0, 0.002)]
    bm.faces.new((verts[0], verts[2], verts[3], verts[1]))
    bm.faces.new((verts[2], verts[4], verts[5], verts[3]))
    bm.to_mesh(mesh)
    bm.free()
    lashes = bpy.data.objects.new("Lashes", mesh)
    bpy.context.scene.collection.objects.link(lashes)
    lashes.parent = head
    return lashes


def test_lashes_ride_on_the_lids_and_remove_takes_them_off():
    head = unset_sample()
    lashes = _add_lashes(head)
    bpy.context.view_layer.update()
    before = snapshot()
    select(head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert head.mpeg4_face.lashes == lashes
    assert lashes.modifiers[0].type == "SURFACE_DEFORM" and lashes.modifiers[0].is_bound
    rest = evaluated_positions(lashes)
    np.testing.assert_allclose(rest, positions(lashes.data), atol=1e-6)
    face_data.fp_empties(head)["3.1"].location.z -= 0.004  # close the left upper lid 4 mm
    bpy.context.view_layer.update()
    moved = evaluated_positions(lashes)
    assert moved[2, 2] < rest[2, 2] - 0.002  # the middle of the margin came down with the lid
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert snapshot() == before


def test_masks_are_made_for_a_face_without_them_and_removed_again():
    head = unset_sample()
    for name in MASKS:
        head.vertex_groups.remove(head.vertex_groups[name])
    before = snapshot()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert {g.name for g in head.vertex_groups} == set(MASKS)
    assert head.mpeg4_face.made_masks == ",".join(sorted(MASKS))
    from .test_panel import draw

    assert any("Masks made from the feature points" in text for text in draw().labels)
    # the jaw side holds the chin, not the forehead
    weights = face_data.group_weights(head, ["lower_lip"])["lower_lip"]
    empties = face_data.fp_empties(head)
    rest = positions(head.data)
    near = lambda fp: int(np.argmin(np.linalg.norm(rest - np.array(empties[fp].location), axis=1)))  # noqa: E731
    assert weights[near("2.10")] == pytest.approx(1.0) and weights[near("4.1")] == 0.0
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}  # again: the groups are now the user's to edit
    assert head.mpeg4_face.made_masks == ",".join(sorted(MASKS))
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert snapshot() == before and not head.vertex_groups


def test_automatic_masks_score_within_ten_percent_of_the_hand_made_ones():
    from scripts.bench.auto_masks import UNITS, compare

    if not UNITS.is_dir():
        pytest.skip("the MakeHuman expression units are not installed")
    pooled = compare(SAMPLE, UNITS)
    assert pooled["auto"] <= 1.1 * pooled["hand"]


def test_a_blink_closes_the_lid_in_playback_and_gaze_moves_the_lids():
    head = unset_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    empties = face_data.fp_empties(head)
    rig = eyelid_rig.current(head)
    assert rig is not None
    upper, lower = (np.array(empties[f].location) for f in ("3.1", "3.3"))
    rest = positions(head.data).copy()
    mid = int(np.argmin(np.linalg.norm(rest - upper, axis=1)))
    # a blink: the upper lid FP down to the lower one (and past it: the lid stops there)
    empties["3.1"].location.z = lower[2] - 0.003
    bpy.context.view_layer.update()
    closed = positions(head.data)
    assert closed[mid, 2] < upper[2] - 0.006  # the lid came down most of the 9 mm opening
    assert closed[mid, 2] > lower[2] - 0.0015  # and stopped at the lower lid, not 3 mm past it
    empties["3.1"].location = upper
    bpy.context.view_layer.update()
    np.testing.assert_allclose(positions(head.data), rest, atol=1e-6)
    # gaze down alone (only the pupil moves): the upper lid follows
    pupil = empties["3.5"]
    pupil.location.z -= 0.004
    bpy.context.view_layer.update()
    assert positions(head.data)[mid, 2] < rest[mid, 2] - 0.001


@pytest.mark.parametrize("stream", ["demo.fap", "philippedax_vreng/eyes.fap", "philippedax_vreng/jag.fap"])
def test_streams_that_folded_the_lids_play_with_no_face_turned_over(stream):
    """The lids' weights are made fold-free at set-up: the demo's blink turned 4 faces over at the eye corners,
    VREng's eyes.fap and jag.fap raising the upper lid 26 and 24 faces above it, before."""
    from scripts.bench import evaluate_folds, live_folds

    path = DEMO_FAP if stream == "demo.fap" else evaluate_folds.INTEROP / stream
    if not path.is_file():
        pytest.skip(f"{path} is not here")
    assert max(c["folds"] for c in live_folds.play(path, lip_guard=True)) == 0


def _one_fap_stream(path, number, value):
    mask = ["0"] * 68
    mask[number - 1] = "1"
    lines = ["2.1 one 25 2", " ".join(mask), "0 0", " ".join(mask), f"1 {value}"]
    path.write_text("\n".join(lines) + "\n")
    return path


def _keyed_drop(head, fp_id):
    """How far the imported stream moves an FP empty down from its first key to its second (face-local z)."""
    empty = face_data.fp_empties(head)[fp_id]
    z = animation.sample(empty, "location", 2, np.array([1.0, 2.0]), empty.location[2])
    return z[0] - z[1]


def test_group_gains_and_soft_ranges_apply_at_import(tmp_path):
    head = unset_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    mns = fap_io.face_fapu(head).unit("MNS")
    stream = _one_fap_stream(tmp_path / "jaw.fap", 3, 600)
    assert bpy.ops.mpeg4.import_fap(filepath=str(stream), timing="SCENE") == {"FINISHED"}
    assert _keyed_drop(head, "2.1") == pytest.approx(600 * mns, rel=1e-5)  # within range: as given
    head.mpeg4_face.gain_jaw = 0.5
    assert bpy.ops.mpeg4.import_fap(filepath=str(stream), timing="SCENE") == {"FINISHED"}
    assert _keyed_drop(head, "2.1") == pytest.approx(300 * mns, rel=1e-5)
    head.mpeg4_face.gain_jaw = 1.0
    wide = _one_fap_stream(tmp_path / "wide.fap", 3, 5000)  # a jaw dropped by five MNS0
    assert bpy.ops.mpeg4.import_fap(filepath=str(wide), timing="SCENE") == {"FINISHED"}
    assert 880 * mns < _keyed_drop(head, "2.1") <= 1100 * mns * (1 + 1e-6)  # eased into the range
    head.mpeg4_face.use_soft_limits = False
    assert bpy.ops.mpeg4.import_fap(filepath=str(wide), timing="SCENE") == {"FINISHED"}
    assert _keyed_drop(head, "2.1") == pytest.approx(5000 * mns, rel=1e-5)
