"""Elastic Bones' mouth lining (issue 27): behind the lower lip it follows the jaw, behind the upper lip the
skull, so that a wide open jaw turns no face over inside the mouth (sample heads read with bpy, the core
computed bpy-free)."""

import numpy as np
import pytest

from addon.blender.face_data import group_weights, mesh_edges, mesh_fans
from addon.deform.folds import count_inverted
from addon.elastic.parameters import TRAINED
from addon.elastic.pose import pose_from_faps
from addon.elastic.skeleton import place_skeleton
from addon.elastic.skinning import cut_openings, edge_of_lips, linear_blend_skinning, mouth_lining, skin_weights
from addon.mpeg4.control_mesh import MASK_NAMES
from addon.mpeg4.faps import N_FAPS
from addon.mpeg4.fapu import compute_fapu
from scripts.bench.elastic_bones import fp_empties

from .helpers import ROOT

bpy = pytest.importorskip("bpy")
JAW_TREE = ("jaw", "chin", "lower_lip", "lower_lip_l", "lower_lip_r")
SKULL_TREE = ("head", "upper_lip", "upper_lip_l", "upper_lip_r", "nose")


def sample_face(blend: str):
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / blend))
    head = bpy.data.objects["Head"]
    fps = fp_empties(head)
    rest = np.array([v.co for v in head.data.vertices], dtype=np.float64)
    return head, fps, place_skeleton(fps), rest, group_weights(head, MASK_NAMES)


def test_the_lining_is_the_mouth_pocket_and_follows_jaw_and_skull():
    head, fps, skeleton, rest, masks = sample_face("makehuman_head.blend")
    edges = mesh_edges(head.data)
    lining = mouth_lining(rest, cut_openings(edges, masks, {"upper_lip": edge_of_lips(rest, skeleton)}), skeleton)
    inside = lining == 1.0
    # the pocket behind the lips: 417 vertices, all behind the inner lip contour's FPs (-Y is forward), none
    # on the outer skin (the outer lip contour's middle, the chin, the nose, the cheeks)
    assert np.count_nonzero(inside) == 417
    assert np.all(rest[inside, 1] > min(fps[f][1] for f in ("2.2", "2.3")) - 1e-9)
    for fp_id in ("8.1", "8.2", "2.10", "9.3", "5.1", "5.2"):
        assert lining[np.argmin(np.linalg.norm(rest - fps[fp_id], axis=1))] == 0.0

    weights = skin_weights(rest, edges, skeleton, masks)
    rows = skeleton.rows
    jaw_tree = weights[:, [rows[n] for n in JAW_TREE]].sum(axis=1)
    skull_tree = weights[:, [rows[n] for n in SKULL_TREE]].sum(axis=1)
    lower, upper = inside & (masks["upper_lip"] == 0.0), inside & (masks["lower_lip"] == 0.0)
    assert np.count_nonzero(lower) == 77 and np.count_nonzero(upper) == 282
    # before, the head held the lining behind the lower lip (jaw and lower lip 0.26 on average there,
    # 0.006 at the least) and the lining folded between the dropping lower lip and the still skull
    assert jaw_tree[lower].mean() > 0.45
    assert jaw_tree[lower].min() > 0.05
    assert skull_tree[upper].mean() > 0.9


@pytest.mark.parametrize("open_jaw", [600.0, 1000.0, 1200.0])
def test_a_wide_open_jaw_turns_no_face_over(open_jaw):
    # FAP 3 open_jaw (MNS): 12, 20 and 24 mm at the chin; with the lining held by the head it turned 2, 14
    # and 14 faces over behind the lower lip on this head
    head, fps, skeleton, rest, masks = sample_face("makehuman_head.blend")
    weights = skin_weights(rest, mesh_edges(head.data), skeleton, masks)
    values = np.zeros(N_FAPS)
    values[2] = open_jaw
    deformed = linear_blend_skinning(rest, weights, pose_from_faps(skeleton, values, compute_fapu(fps), TRAINED))
    chin = np.argmin(np.linalg.norm(rest - fps["2.1"], axis=1))
    assert np.linalg.norm(deformed[chin] - rest[chin]) > 0.9 * open_jaw * 0.02 / 1000.0  # it opened
    assert count_inverted(rest, deformed, *mesh_fans(head.data)) == 0
