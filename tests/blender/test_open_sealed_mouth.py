"""Open Sealed Mouth on the sample with its lips welded shut (its inner lip rims merged into one line, as a mesh
that seals the mouth has them): the cut is shown, made on the user's word, parts the lips under an open jaw, is
undone by Undo, and bad input is refused with the scene unchanged."""

import bmesh
import bpy
import numpy as np
import pytest

from addon.blender import binding_store, face_data, face_setup, rest_shape
from addon.deform.overlaps import crossing_pairs
from scripts.bench.variant_playback import played_positions

from .helpers import DEMO_FAP, positions
from .test_hardening import unset_sample

pytest.importorskip("scipy")

OPEN_JAW_FRAMES = (64, 75)  # demo frames with the jaw open (75: wide)


def _rim(vertices, neighbours, start: int, direction, stop: int) -> list[int]:
    """An inner lip rim as an edge loop: from `start` on, always the edge straightest ahead, to `stop`."""
    chain, ahead = [start], np.asarray(direction, dtype=np.float64)
    while chain[-1] != stop and len(chain) < 100:
        options = [n for n in neighbours[chain[-1]] if n not in chain]
        steps = [vertices[n] - vertices[chain[-1]] for n in options]
        steps = [step / np.linalg.norm(step) for step in steps]
        best = int(np.argmax([step @ ahead for step in steps]))
        chain.append(options[best])
        ahead = steps[best]
    assert chain[-1] == stop
    return chain


def _along(vertices, chain) -> np.ndarray:
    x = np.abs(vertices[chain, 0] - vertices[chain[0], 0])
    return x / x[-1]


def weld_lips(head) -> int:
    """Weld the sample's upper inner lip rim (2.4-2.2-2.5) to its lower one (2.4-2.3-2.5): each rim gets a vertex
    where the other has one (the upper rim has 12 edges a side, the lower 7), then they are merged pairwise onto
    the upper rim. Returns how many vertices the mesh lost."""
    mesh = head.data
    before = len(mesh.vertices)
    vertices = positions(mesh).astype(np.float64)
    fps = face_data.local_positions(head, face_data.fp_empties(head))
    nearest = {k: int(np.argmin(np.linalg.norm(vertices - fps[k], axis=1))) for k in ("2.2", "2.3", "2.4", "2.5")}
    neighbours = [[] for _ in vertices]
    for a, b in face_data.mesh_edges(mesh).tolist():
        neighbours[a].append(b)
        neighbours[b].append(a)
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.verts.ensure_lookup_table()
    targets = {}
    halves = []
    for corner, x in (("2.4", 1.0), ("2.5", -1.0)):
        rims = [_rim(vertices, neighbours, nearest[m], (x, 0, 0), nearest[corner]) for m in ("2.2", "2.3")]
        halves.append(([_along(vertices, rim) for rim in rims], [[bm.verts[v] for v in rim] for rim in rims]))
    for params, rims in halves:
        filled = []
        for k, (verts, t) in enumerate(zip(rims, params, strict=True)):
            other = params[1 - k]
            chain = [(float(tv), vert) for tv, vert in zip(t, verts, strict=True)]
            for t_new in sorted(other[1:-1]):
                if np.isclose(t, t_new).any():
                    continue
                i = int(np.searchsorted([tc for tc, _v in chain], t_new)) - 1
                (t0, v0), (t1, v1) = chain[i], chain[i + 1]
                _edge, vert = bmesh.utils.edge_split(bm.edges.get((v0, v1)), v0, (t_new - t0) / (t1 - t0))
                chain.insert(i + 1, (float(t_new), vert))
            filled.append([vert for _t, vert in chain])
        upper, lower = filled
        assert len(upper) == len(lower)
        targets.update({lo: up for up, lo in zip(upper[1:-1], lower[1:-1], strict=True)})
        targets[lower[0]] = upper[0]  # the middle (2.3's vertex onto 2.2's), met from both sides
    bmesh.ops.weld_verts(bm, targetmap=targets)
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()
    return before - len(mesh.vertices)


def sealed_sample():
    """The sample welded shut, without lip masks (a mesh that seals its mouth has none painted to part the lips:
    set-up makes them from the FPs, on either side of the cut once it is made)."""
    head = unset_sample()
    assert weld_lips(head) > 0
    for name in ("upper_lip", "lower_lip"):
        head.vertex_groups.remove(head.vertex_groups[name])
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
    bpy.context.scene.frame_set(75)
    now = played_positions(mesh)
    gap = np.linalg.norm(now[copies] - now[_sources(rest, copies)], axis=1)
    assert gap.max() > 0.003, gap.max()  # the lower lip's side of the cut came 3 mm and more off the upper's


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
