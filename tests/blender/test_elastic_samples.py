"""Elastic Bones core on the two sample faces' FP empties and meshes (read with bpy, computed bpy-free)."""

import numpy as np
import pytest

from addon.blender.face_data import group_weights, mesh_edges, mesh_fans
from addon.deform.folds import count_inverted
from addon.elastic.parameters import TRAINED, Parameters
from addon.elastic.pose import pose_from_faps, pose_from_fps
from addon.elastic.skeleton import BONES, place_skeleton
from addon.elastic.skinning import linear_blend_skinning, skin_weights
from addon.mpeg4.control_mesh import MASK_NAMES
from addon.mpeg4.faps import N_FAPS
from addon.mpeg4.fapu import compute_fapu
from scripts.bench.elastic_bones import fp_empties

from .helpers import ROOT

bpy = pytest.importorskip("bpy")
NAMES = tuple(b.name for b in BONES)


@pytest.mark.parametrize("blend", ["makehuman_head.blend", "makehuman_head_b.blend"])
def test_skeleton_and_weights_on_the_sample_faces(blend):
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / blend))
    head = bpy.data.objects["Head"]
    fps = fp_empties(head)
    skeleton = place_skeleton(fps)
    at = {name: i for i, name in enumerate(NAMES)}
    np.testing.assert_allclose(skeleton.heads[at["jaw"]], (fps["2.13"] + fps["2.14"]) / 2)
    np.testing.assert_allclose(skeleton.heads[at["lip_corner_l"]], fps["2.4"])
    np.testing.assert_allclose(skeleton.tails[at["eye_r"]], fps["3.6"])
    assert skeleton.heads[at["eye_l"]][1] > fps["3.5"][1]  # the eyeball centre lies behind the pupil (-Y is forward)

    rest = np.array([v.co for v in head.data.vertices], dtype=np.float64)
    masks = group_weights(head, MASK_NAMES)
    weights = skin_weights(rest, mesh_edges(head.data), skeleton, masks)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)
    # a side mask scales its bones' weights: nothing where it shuts out (the other lip), a taper where it
    # fades beyond the lip corners (no cut there, or the weights would jump from 1 to 0 and tear the skin)
    lower_lip, upper_lip = masks["upper_lip"] == 0.0, masks["lower_lip"] == 0.0
    assert lower_lip.any() and upper_lip.any()
    upper_bones = [at[n] for n in ("upper_lip", "upper_lip_l", "upper_lip_r")]
    lower_bones = [at[n] for n in ("lower_lip", "lower_lip_l", "lower_lip_r")]
    assert np.all(weights[np.ix_(lower_lip, upper_bones)] == 0.0)
    assert np.all(weights[np.ix_(upper_lip, lower_bones)] == 0.0)
    assert np.all(weights[:, upper_bones] <= masks["upper_lip"][:, None] + 1e-12)
    assert np.all(weights[:, lower_bones] <= masks["lower_lip"][:, None] + 1e-12)
    skinned = [at[b.name] for b in BONES if b.skinned]
    assert np.all(weights[:, skinned].max(axis=0) > 0.3)  # every skinned bone leads somewhere
    assert np.all(weights[:, [at["eye_l"], at["eye_r"]]] == 0.0)

    # the jaw drops: the chin vertices follow the chin FP, the forehead stays
    moved = dict(fps)
    for fp_id in ("2.1", "2.10", "2.11", "2.12", "2.3", "8.2"):
        moved[fp_id] = fps[fp_id] + [0.0, 0.003, -0.01]
    deformed = linear_blend_skinning(rest, weights, pose_from_fps(skeleton, fps, moved, Parameters()))
    chin = np.argmin(np.linalg.norm(rest - fps["2.1"], axis=1))
    brow = np.argmin(np.linalg.norm(rest - fps["4.3"], axis=1))
    assert deformed[chin][2] - rest[chin][2] == pytest.approx(-0.01, abs=0.002)
    np.testing.assert_allclose(deformed[brow], rest[brow], atol=1e-12)


OPEN_JAW = {3: 400.0}  # open_jaw, MNS
SMILE = {n: 150.0 for n in (6, 7, 12, 13, 53, 54, 59, 60)}  # stretch and raise the lip corners, inner and outer


@pytest.mark.parametrize("blend", ["makehuman_head.blend", "makehuman_head_b.blend"])
@pytest.mark.parametrize("faps", [OPEN_JAW, SMILE], ids=["open jaw", "smile"])
def test_an_open_jaw_and_a_smile_turn_no_face_over(blend, faps):
    # the lip-corner tears and the seam under the lower lip were faces turned over (4 and 12 on the first
    # sample with the opening cut along the masks' gradient beyond the lip corners and the root's (1 − Σ)²)
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / blend))
    head = bpy.data.objects["Head"]
    fps = fp_empties(head)
    skeleton = place_skeleton(fps)
    rest = np.array([v.co for v in head.data.vertices], dtype=np.float64)
    weights = skin_weights(rest, mesh_edges(head.data), skeleton, group_weights(head, MASK_NAMES))
    values = np.zeros(N_FAPS)
    values[np.array(list(faps)) - 1] = list(faps.values())
    deformed = linear_blend_skinning(rest, weights, pose_from_faps(skeleton, values, compute_fapu(fps), TRAINED))
    assert np.abs(deformed - rest).max() > 0.003  # it moved
    assert count_inverted(rest, deformed, *mesh_fans(head.data)) == 0
