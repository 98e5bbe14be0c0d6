"""Unfold Skin in the live effect: a full smile that turns the skin over at the lip corners plays with no face
turned over; off gives Planar Bones' own output; the frames after a repaired one are what a fresh evaluation
gives (nothing of the repair is left behind by the frame-to-frame playback)."""

import bpy
import numpy as np
import pytest

from addon.blender import elastic_skin, face_data, live, rest_shape, skin_view
from addon.deform.folds import count_inverted, inverted_faces

from .helpers import positions
from .test_hardening import unset_sample

# the lip corners up and back as in MakeHuman's mouth-corner-puller at 1.5 times its size (head-local metres)
SMILE = {"8.3": (0.0073, 0.0044, 0.0156), "8.4": (-0.0073, 0.0044, 0.0156)}


def _set_up():
    head = unset_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    empties = face_data.fp_empties(head)
    rest = {fp_id: np.array(ob.location) for fp_id, ob in empties.items()}
    return head, empties, rest


def _pose(empties, rest, offsets, scale=1.0):
    for fp_id, ob in empties.items():
        ob.location = rest[fp_id] + scale * np.asarray(offsets.get(fp_id, (0.0, 0.0, 0.0)))
    bpy.context.view_layer.update()


def _folds(head):
    fans = face_data.mesh_fans(head.data)
    rest = rest_shape.stored_rest(head.data).astype(np.float64)
    return count_inverted(rest, positions(head.data).astype(np.float64), *fans)


def _fresh(head):
    """The face as a state made afresh evaluates it (no playback history)."""
    live.forget(head)
    live.apply_face(head, force=True)
    return positions(head.data).copy()


def test_a_full_smile_turns_no_face_over_with_unfold_skin_and_some_without():
    head, empties, rest = _set_up()
    head.mpeg4_face.unfold_skin = False
    _pose(empties, rest, SMILE)
    raw = positions(head.data).copy()
    assert _folds(head) > 0  # Planar Bones alone: the lip corner passes the nose wing-cheek line
    head.mpeg4_face.unfold_skin = True
    repaired = positions(head.data).copy()
    assert _folds(head) == 0
    moved = np.linalg.norm(repaired - raw, axis=1) > 1e-6  # more than a micrometre
    assert 0 < moved.sum() < 0.2 * len(raw)  # only the skin around the folds:
    skin = rest_shape.stored_rest(head.data).astype(np.float64)
    triangles = face_data.mesh_fans(head.data)[0]
    folded = np.unique(triangles[inverted_faces(skin, raw.astype(np.float64), triangles)])
    far = np.min(np.linalg.norm(skin[:, None] - skin[folded][None], axis=2), axis=1) > 0.04
    assert not np.any(moved & far)  # nothing 4 cm from every folded face moves
    head.mpeg4_face.unfold_skin = False
    np.testing.assert_array_equal(positions(head.data), raw)  # off: Planar Bones' output again


def test_frames_after_a_repaired_one_equal_a_fresh_evaluation():
    """Played one after another (the playback writes only the groups that moved, and Unfold Skin then looks only
    there), each frame is what a state made afresh gives (a whole look)."""
    head, empties, rest = _set_up()
    scales = (1.0, 0.4, 1.0, 1.2, 0.0, 0.7, 0.9)  # folding, not folding, folding, rest, in between
    played = []
    for scale in scales:
        _pose(empties, rest, SMILE, scale)
        played.append(positions(head.data).copy())
        assert _folds(head) == 0
    for scale, frame in zip(scales, played, strict=True):
        _pose(empties, rest, SMILE, scale)
        np.testing.assert_array_equal(frame, _fresh(head))


def test_the_setting_is_undone_with_the_file():
    head, empties, rest = _set_up()
    _pose(empties, rest, SMILE)
    bpy.ops.ed.undo_push(message="smile")
    head.mpeg4_face.unfold_skin = False
    bpy.ops.ed.undo_push(message="unfold off")
    name = head.name
    assert _folds(head) > 0
    bpy.ops.ed.undo()
    head = bpy.data.objects[name]
    assert head.mpeg4_face.unfold_skin
    live.apply_face(head, force=True)
    assert _folds(head) == 0


@pytest.mark.parametrize("stream", ["thuhcsi_Crystal.TTVS/interpolation_emot.fap"])
def test_the_stream_that_still_folded_plays_with_no_face_turned_over(stream):
    """interpolation_emot.fap turned 5 faces over at the sample head's outer eye corners before Unfold Skin."""
    from scripts.bench import evaluate_folds, live_folds

    path = evaluate_folds.INTEROP / stream
    if not path.is_file():
        pytest.skip(f"{path} is not here")
    assert max(c["folds"] for c in live_folds.play(path, lip_guard=True, unfold_skin=False)) > 0
    assert max(c["folds"] for c in live_folds.play(path, lip_guard=True)) == 0


def test_the_narrow_look_finds_a_fold_whenever_a_whole_look_does(monkeypatch):
    """After a fold-free frame Unfold Skin looks only at the groups the playback wrote, less the lids' groups where
    the lids held still: over smiles, blinks, rest and jumps between them, that look finds a fold exactly when a
    look at every face does."""
    from addon.deform import unfold

    head, empties, rest = _set_up()
    original = unfold.open_folds
    verdicts = []

    def checked(mesh, positions, look=None, **kwargs):
        whole = bool(unfold.turned_over(mesh, positions.astype(np.float64)).any())
        if look is not None:
            verdicts.append((len(look.turned_corners(positions)) > 0, whole))
        return original(mesh, positions, look, **kwargs)

    monkeypatch.setattr(unfold, "open_folds", checked)
    lid_drop = rest["3.1"][2] - rest["3.3"][2]
    # (smile, blink, skin around the eye squeezed: 3.9 up and 3.13 down by 6 mm times this, which folds faces of
    # the lids' groups with the lids still)
    frames = [(0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.2, 0.0, 0.0), (0.3, 0.0, 0.0),
              (1.0, 0.5, 0.0), (1.0, 1.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 0.0), (1.3, 0.0, 0.0),
              (1.3, 0.0, 0.0), (0.6, 0.0, 0.0), (0.0, 0.0, 0.0), (1.1, 0.2, 0.0), (0.2, 0.0, 0.0), (0.0, 0.0, 0.5),
              (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.3), (0.5, 0.0, 1.5), (0.0, 0.5, 1.0)]  # fmt: skip
    for smile, blink, squeeze in frames:
        offsets = {fp_id: np.asarray(v) * smile for fp_id, v in SMILE.items()}
        offsets["3.1"] = (0.0, 0.0, -blink * lid_drop)
        offsets["3.9"], offsets["3.13"] = (0.0, 0.0, 0.006 * squeeze), (0.0, 0.0, -0.006 * squeeze)
        _pose(empties, rest, offsets)
    assert verdicts and all(narrow == whole for narrow, whole in verdicts)
    assert any(whole for _, whole in verdicts) and not all(whole for _, whole in verdicts)


def test_a_fold_the_lids_make_on_skin_the_deformer_left_at_rest_is_found(monkeypatch):
    """The lids turn skin after the playback, which may have left it at rest (a gaze alone moves no control point):
    the narrow look must see it. A stand-in for the turn pushes one of the lids' vertices 6 mm sideways, which turns
    faces over. (The lip guard's skin is flagged the same way when the guard moves it; there the playback has always
    summed it too, as the guard runs only when a lip's control point moved.)"""
    from addon.blender import eyelid_rig

    head, empties, rest = _set_up()
    pose = {"2.1": (0.0, 0.0, -0.001)}
    _pose(empties, rest, pose)  # a frame through the playback, the eyes at rest
    state = live._states[head.session_uid]
    vertex = int(eyelid_rig.turned_vertices(head, state.binding)[0])
    playback = state.playback
    assert playback.off_rest[playback.layout.vertex_group[vertex]] == 0
    real = eyelid_rig.apply

    def stand_in(face, binding, out, fps):
        real(face, binding, out, fps)
        out[vertex, 0] += 0.006
        return True

    monkeypatch.setattr(eyelid_rig, "apply", stand_in)
    head.mpeg4_face.unfold_skin = False
    _pose(empties, rest, pose, 2.0)
    assert _folds(head) > 0
    head.mpeg4_face.unfold_skin = True
    _pose(empties, rest, pose, 3.0)
    assert _folds(head) == 0


def test_the_skins_kept_for_unfolding_are_those_of_faces_still_in_the_file():
    head, empties, rest = _set_up()
    _pose(empties, rest, SMILE)
    assert set(skin_view._views) == {head.session_uid}
    copy = head.copy()
    copy.data = head.data.copy()
    bpy.context.scene.collection.objects.link(copy)
    skin_view._views[copy.session_uid] = skin_view._views[head.session_uid]  # as if the copy had played too
    bpy.data.objects.remove(copy)
    live.forget(head)
    kept = skin_view._views[head.session_uid]
    skin_view._views[head.session_uid] = (kept[0] + 1.0, *kept[1:])  # made for another rest shape: made again
    live.apply_face(head, force=True)
    assert set(skin_view._views) == {head.session_uid} and skin_view._views[head.session_uid][3] is not None


def test_the_corners_read_from_the_attribute_are_those_of_the_loops():
    head, _empties, _rest = _set_up()
    mesh = head.data
    sizes, corners = face_data.mesh_corners(mesh)
    loops = np.empty(len(mesh.loops), np.int64)
    mesh.loops.foreach_get("vertex_index", loops)
    totals = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_total", totals)
    assert mesh.attributes.get(face_data.CORNER_VERT) is not None  # Blender 4.x and 5.x keep it
    assert np.array_equal(corners, loops) and np.array_equal(sizes, totals)


def test_both_engines_share_one_view_of_the_skin():
    """Planar Bones' membrane and Elastic Bones' take the same `unfold.SkinMesh` for the same rest shape."""
    head, empties, rest = _set_up()
    _pose(empties, rest, SMILE)
    view = skin_view._views[head.session_uid][3]
    made = elastic_skin._skin(head, [])
    assert made.mesh is view
