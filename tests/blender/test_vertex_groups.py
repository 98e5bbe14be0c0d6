"""Reading vertex-group weights (face_data.group_weights): the node-tree path equals the vertex loop."""

import bpy
import numpy as np

from addon.blender import binding_store, face_data

from .helpers import open_sample


def _by_loop(ob, names) -> dict[str, np.ndarray]:
    index = {g.index: g.name for g in ob.vertex_groups if g.name in names}
    out = {name: np.zeros(len(ob.data.vertices)) for name in index.values()}
    for v in ob.data.vertices:
        for g in v.groups:
            if g.group in index:
                out[index[g.group]][v.index] = g.weight
    return out


def test_the_weights_equal_a_loop_over_the_vertices_and_nothing_is_left_behind():
    head = open_sample()
    head.vertex_groups["upper_lip"].add([0, 1, 2], 0.25, "REPLACE")  # a fractional weight, too
    objects, trees = len(bpy.data.objects), len(bpy.data.node_groups)
    users = head.data.users
    got = face_data.group_weights(head, binding_store.MASK_NAMES)
    want = _by_loop(head, binding_store.MASK_NAMES)
    assert set(got) == set(want) == set(binding_store.MASK_NAMES)
    for name in want:
        np.testing.assert_array_equal(got[name], want[name])
    assert got["upper_lip"][1] == 0.25 and got["lower_lip"].max() > 0.0
    assert (len(bpy.data.objects), len(bpy.data.node_groups), head.data.users) == (objects, trees, users)


def test_without_node_trees_the_vertex_loop_gives_the_same(monkeypatch):
    head = open_sample()

    def broken(*_args):
        raise RuntimeError("no geometry nodes here")

    monkeypatch.setattr(face_data, "_group_weights_by_nodes", broken)
    got = face_data.group_weights(head, binding_store.MASK_NAMES)
    for name, want in _by_loop(head, binding_store.MASK_NAMES).items():
        np.testing.assert_array_equal(got[name], want)


def test_a_face_without_the_groups_reads_nothing():
    head = open_sample()
    for name in binding_store.MASK_NAMES:
        head.vertex_groups.remove(head.vertex_groups[name])
    assert face_data.group_weights(head, binding_store.MASK_NAMES) == {}
