"""Open Sealed Mouth on the sample with its lips welded shut (its inner lip rims merged into one line, as a mesh
that seals the mouth has them): the cut is shown, made on the user's word, parts the lips under an open jaw, is
undone by Undo, and bad input is refused with the scene unchanged."""

import bpy
import numpy as np
import pytest

from addon.blender import binding_store, face_data, face_setup, rest_shape
from addon.deform.overlaps import crossing_pairs
from scripts.bench.sealed_mouth import seal
from scripts.bench.variant_playback import played_positions

from .helpers import DEMO_FAP, positions
from .test_hardening import unset_sample

pytest.importorskip("scipy")

OPEN_JAW_FRAMES = (21, 25, 29)  # the demo's widest jaw (25: the inner lip FPs 16 mm apart)


def sealed_sample():
    """The sample welded shut, without lip masks (a mesh that seals its mouth has none painted to part the lips:
    set-up makes them from the FPs, on either side of the cut once it is made)."""
    head = unset_sample()
    seal(head)
    return head


def _state(head):
    mesh = head.data
    return len(mesh.vertices), len(mesh.polygons), positions(mesh).copy(), binding_store.is_bound(head)


def test_a_welded_mouth_is_named_by_set_up_and_cut_open_on_the_users_word():
    head = sealed_sample()
    notes = face_setup.plan(head).notes
    assert any("no opening at the lips (FP 2.2, 2.3)" in note and "Open Sealed Mouth" in note for note in notes)
    count, polygons, rest, _bound = _state(head)
    # shown first: its edges selected, nothing cut
    assert bpy.ops.mpeg4.open_sealed_mouth(show_only=True) == {"FINISHED"}
    assert len(head.data.vertices) == count
    selected = np.array([e.select for e in head.data.edges])
    assert 20 <= selected.sum() <= 40, selected.sum()
    bpy.ops.ed.undo_push(message="shown")
    assert bpy.ops.mpeg4.open_sealed_mouth() == {"FINISHED"}
    added = len(head.data.vertices) - count
    assert added == selected.sum() - 1  # a copy of each inner vertex of the cut; the corners stay one
    assert len(head.data.polygons) == polygons
    assert not any("no opening at the lips" in note for note in face_setup.plan(head).notes)
    # set up and played: the lips part under the open jaw, with no triangle crossing another
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    mesh = head.data
    rest = rest_shape.reference_positions(mesh).astype(np.float64)
    triangles = face_data.mesh_fans(mesh)[0]
    at_rest = set(map(tuple, crossing_pairs(rest, triangles).tolist()))
    copies = np.arange(count, count + added)
    for frame in OPEN_JAW_FRAMES:
        bpy.context.scene.frame_set(frame)
        now = played_positions(mesh)
        crossed = [p for p in crossing_pairs(now, triangles).tolist() if tuple(p) not in at_rest]
        assert crossed == [], (frame, len(crossed))
    bpy.context.scene.frame_set(25)
    now = played_positions(mesh)
    gap = np.linalg.norm(now[copies] - now[_sources(rest, copies)], axis=1)
    fps = face_data.local_positions(head, face_data.fp_empties(head))
    opening = float(np.linalg.norm(fps["2.2"] - fps["2.3"]))
    assert opening > 0.01
    assert gap.max() > 0.5 * opening, (gap.max(), opening)  # the cut's sides part as the inner lips' FPs do


def _sources(rest, copies):
    """Each copy's twin: the other vertex at its place at rest."""
    others = [np.flatnonzero(np.all(rest == rest[c], axis=1) & (np.arange(len(rest)) != c)) for c in copies]
    return np.array([int(found[0]) for found in others])


def test_the_cut_is_undone_by_undo():
    head = sealed_sample()
    count = len(head.data.vertices)
    bpy.ops.ed.undo_push(message="sealed")
    assert bpy.ops.mpeg4.open_sealed_mouth() == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Open Sealed Mouth")  # as the window manager pushes an UNDO operator's step
    assert len(bpy.data.objects["Head"].data.vertices) > count
    bpy.ops.ed.undo()
    assert len(bpy.data.objects["Head"].data.vertices) == count


def test_an_open_mouth_a_set_up_face_and_missing_fps_are_refused_and_nothing_changes():
    head = unset_sample()  # the sample's own lips: open
    before = _state(head)
    with pytest.raises(RuntimeError, match="opening between the lips already"):
        bpy.ops.mpeg4.open_sealed_mouth()
    head = sealed_sample()
    bpy.data.objects.remove(face_data.fp_empties(head)["2.8"])
    before = _state(head)
    with pytest.raises(RuntimeError, match=r"feature points missing: FP 2\.8"):
        bpy.ops.mpeg4.open_sealed_mouth()
    after = _state(head)
    assert after[:2] == before[:2] and np.array_equal(after[2], before[2])
    head = sealed_sample()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert not bpy.ops.mpeg4.open_sealed_mouth.poll()
    with pytest.raises(RuntimeError, match="is set up: Remove Set-Up first"):
        bpy.ops.mpeg4.open_sealed_mouth()
