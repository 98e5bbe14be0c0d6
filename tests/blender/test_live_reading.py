"""The per-frame read of the FP empties (face_data.FpReader) and the hidden control mesh (live._show_control)."""

import bpy
import numpy as np
from mathutils import Matrix

from addon.blender import face_data, live

from .helpers import set_up_sample


def _control_ids(head) -> list[str]:
    return list(head.mpeg4_face.control_object.data[face_data.FP_IDS_PROP])


def _reference(head, ids) -> np.ndarray:
    """The one-by-one reading (is_plain_child, else through the world matrices)."""
    empties = face_data.fp_empties(head)
    return np.array(list(face_data.local_positions(head, {i: empties[i] for i in ids}).values()))


def test_the_fast_read_equals_the_one_by_one_read_for_plain_children():
    head = set_up_sample()
    ids = _control_ids(head)
    reader = face_data.FpReader(ids)
    np.testing.assert_array_equal(reader.read(head), _reference(head, ids))


def test_a_moved_empty_is_read_before_the_depsgraph_has_evaluated_it():
    head = set_up_sample()
    ids = _control_ids(head)
    reader = face_data.FpReader(ids)
    reader.read(head)
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.z -= 0.01  # the world matrix is stale until the next evaluation
    got = reader.read(head)
    assert got[ids.index("2.1"), 2] == np.float32(chin.location.z)
    np.testing.assert_array_equal(got, _reference(head, ids))


def test_an_empty_with_a_constraint_or_an_offset_parent_inverse_is_read_in_face_space():
    head = set_up_sample()
    ids = _control_ids(head)
    reader = face_data.FpReader(ids)
    empties = face_data.fp_empties(head)
    nose = empties["9.3"]
    nose.matrix_parent_inverse = Matrix.Translation((0.0, 0.02, 0.0))
    corner = empties["8.3"]
    corner.constraints.new("LIMIT_LOCATION").use_min_z = True
    corner.constraints[0].min_z = 10.0  # world z: far above the face
    bpy.context.view_layer.update()
    got = reader.read(head)
    np.testing.assert_allclose(got, _reference(head, ids), atol=1e-6)
    assert abs(got[ids.index("9.3"), 1] - (nose.location.y + 0.02)) < 1e-6
    face_z = (head.matrix_world.inverted() @ corner.matrix_world.translation).z
    assert abs(got[ids.index("8.3"), 2] - face_z) < 1e-6


def test_an_object_not_read_that_disagrees_with_its_location_changes_nothing():
    """Only some of the collection's empties are read; another one off its plain-child place (a constraint) takes
    the slow check but changes none of the positions read."""
    head = set_up_sample()
    ids = [i for i in _control_ids(head) if i != "8.3"]
    reader = face_data.FpReader(ids)
    corner = face_data.fp_empties(head)["8.3"]
    corner.constraints.new("LIMIT_LOCATION").use_min_z = True
    corner.constraints[0].min_z = 10.0
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(reader.read(head), _reference(head, ids))


def test_a_replaced_empty_is_found_again_and_a_deleted_one_is_named():
    head = set_up_sample()
    ids = _control_ids(head)
    reader = face_data.FpReader(ids)
    reader.read(head)
    old = face_data.fp_empties(head)["2.1"]
    new = old.copy()
    new.location.z += 0.005
    collections = list(old.users_collection)
    bpy.data.objects.remove(old)
    for coll in collections:
        coll.objects.link(new)
    assert reader.read(head)[ids.index("2.1"), 2] == np.float32(new.location.z)
    bpy.data.objects.remove(new)
    try:
        reader.read(head)
    except LookupError as exc:
        assert "2.1" in str(exc)
    else:
        raise AssertionError("a missing FP empty must be named")


def test_the_control_mesh_is_hidden_after_set_up_and_follows_once_shown():
    head = set_up_sample()
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}  # the sample keeps its cage shown; a new set-up hides it
    control = head.mpeg4_face.control_object
    assert not control.visible_get()
    rest = np.asarray(control.data[face_data.REST_PROP]).reshape(-1, 3)
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.z -= 0.01
    assert live.apply_face(head)
    row = _control_ids(head).index("2.1")
    now = np.empty(len(control.data.vertices) * 3, np.float32)
    control.data.attributes["position"].data.foreach_get("vector", now)
    assert now.reshape(-1, 3)[row, 2] == rest[row, 2]  # hidden: not written
    control.hide_set(False)
    assert live.apply_face(head)  # nothing moved since, yet the shown cage catches up
    control.data.attributes["position"].data.foreach_get("vector", now)
    assert now.reshape(-1, 3)[row, 2] == np.float32(chin.location.z)
