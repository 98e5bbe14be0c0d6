"""Still Skin Around Eyes: the brows' and lids' control triangles move only the skin near them (docs/eyes_brows.md)."""

import bpy
import numpy as np
import pytest

from addon.blender import binding_store, face_data
from addon.mpeg4.fapu import compute_fapu

from .helpers import positions, set_up_sample

BROW_FPS = ("4.1", "4.2", "4.3", "4.4", "4.5", "4.6")
STILL = 1e-4  # 0.1 mm


def moved_by(head, offsets: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) how far each vertex moves when the FP empties move by `offsets` (then put back)."""
    empties = face_data.fp_empties(head)
    rest = positions(head.data).astype(np.float64)
    for fp_id, offset in offsets.items():
        empties[fp_id].location += type(empties[fp_id].location)(offset)
    bpy.context.view_layer.update()
    moved = np.linalg.norm(positions(head.data) - rest, axis=1)
    for fp_id, offset in offsets.items():
        empties[fp_id].location -= type(empties[fp_id].location)(offset)
    bpy.context.view_layer.update()
    return moved


@pytest.fixture
def head():
    return set_up_sample()


def cheek_and_lower_lid(head) -> np.ndarray:
    """The skin nearest the cheek FPs (group 5) within ES0 / 2, and the lower lids (the upper lid's mask shuts
    them out)."""
    empties = face_data.fp_empties(head)
    rest = positions(head.data).astype(np.float64)
    es0 = compute_fapu({f: np.array(ob.location) for f, ob in empties.items()}).ES0
    ids = sorted(empties)
    points = np.array([empties[f].location for f in ids])
    distance = np.linalg.norm(rest[:, None] - points[None], axis=2)
    nearest = np.array(ids)[distance.argmin(axis=1)]
    cheek = np.char.startswith(nearest.astype(str), "5.") & (distance.min(axis=1) < 0.5 * es0)
    lower_lid = face_data.group_weights(head, ("upper_eyelid",))["upper_eyelid"] < 0.5
    return cheek | lower_lid


def test_a_brow_raise_leaves_the_cheek_and_the_lower_lid_still(head):
    raise_brows = {fp_id: np.array([0.0, 0.0, 0.005]) for fp_id in BROW_FPS}  # 5 mm up
    watched = cheek_and_lower_lid(head)
    assert watched.sum() > 100
    empties = face_data.fp_empties(head)
    brows = np.array([empties[fp_id].location for fp_id in BROW_FPS])
    rest = positions(head.data).astype(np.float64)
    distance = np.linalg.norm(rest[:, None] - brows[None], axis=2).min(axis=1)
    around = (distance > 0.02) & (distance < 0.05)  # forehead, temples, nose: 2 to 5 cm from the brows
    moved = moved_by(head, raise_brows)
    assert moved.max() > 0.004  # the brow itself rises
    assert moved[watched].max() < STILL
    assert moved[around].mean() < 0.5 * STILL
    head.mpeg4_face.still_upper_face = False  # the paper's cover: the brows' raised radii reach that skin
    assert moved_by(head, raise_brows)[around].mean() > STILL


def test_a_blink_is_the_lids_turn_alone_either_way(head):
    """The mid-lid FPs are held at rest for Planar Bones (their motion is the lids' turn), so the setting leaves a
    blink exactly as it was."""
    blink = {"3.1": np.array([0.0, 0.0, -0.008])}
    head.mpeg4_face.still_upper_face = True
    on = moved_by(head, blink)
    head.mpeg4_face.still_upper_face = False
    off = moved_by(head, blink)
    head.mpeg4_face.still_upper_face = True
    assert on.max() > 0.005
    np.testing.assert_array_equal(on, off)


def test_a_face_bound_before_the_setting_opens_with_it_off_and_plays_as_saved(tmp_path):
    head = set_up_sample()
    assert head.mpeg4_face.is_property_set("still_upper_face") and head.mpeg4_face.still_upper_face
    key = binding_store.stored_key(head)
    del head.mpeg4_face["still_upper_face"]  # as a file saved before the setting existed has it
    path = tmp_path / "older.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    head = bpy.data.objects["Head"]
    assert head.mpeg4_face.still_upper_face is False  # as its binding was made, not the default
    assert binding_store.stored_key(head) == key  # and nothing was rebound
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert bpy.data.objects["Head"].mpeg4_face.still_upper_face is False
