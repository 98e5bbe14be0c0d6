"""Unfold Skin under Elastic Bones' skinning (`addon.elastic.membrane`): the pull-back through each vertex's blend
of the bone matrices, and a strip whose skinning turns faces over, opened and carried back under the skinning."""

import numpy as np
import pytest

from addon.deform import unfold
from addon.deform.folds import count_inverted
from addon.elastic.membrane import MIN_DETERMINANT, pull_back, skin_unfolded
from addon.elastic.skinning import apply_blended, blended_matrices, linear_blend_skinning


def test_pull_back_solves_each_vertexs_own_affine_map():
    # [A | t] with A = diag(2, 1, 0.5), t = (1, 0, 0): A r + t = (3, 2, 1) at r = (1, 2, 2)
    matrix = np.array([[[2.0, 0, 0, 1], [0, 1, 0, 0], [0, 0, 0.5, 0]]])
    rest, ok = pull_back(matrix, np.array([[3.0, 2.0, 1.0]]))
    assert ok.tolist() == [True]
    np.testing.assert_allclose(rest, [[1.0, 2.0, 2.0]])


def test_a_blend_that_cannot_be_inverted_is_left_out():
    flat = np.array([[[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, MIN_DETERMINANT / 2, 0]]])  # squashes z flat
    rest, ok = pull_back(flat, np.array([[0.0, 0.0, 1.0]]))
    assert ok.tolist() == [False] and np.isnan(rest).all()


def test_blended_matrices_are_the_skinning():
    rng = np.random.default_rng(1)
    rest = rng.normal(size=(20, 3))
    weights = rng.random((20, 3))
    weights /= weights.sum(axis=1, keepdims=True)
    transforms = np.tile(np.eye(4), (3, 1, 1))
    transforms[:, :3, :] += rng.normal(scale=0.1, size=(3, 3, 4))
    np.testing.assert_allclose(
        apply_blended(blended_matrices(weights, transforms), rest), linear_blend_skinning(rest, weights, transforms)
    )


def _strip(columns: int = 12, rows: int = 4):
    """A flat grid in the xy plane (1 unit squares, two triangles each), its vertices' x."""
    xs, ys = np.meshgrid(np.arange(columns, dtype=float), np.arange(rows, dtype=float))
    rest = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    index = np.arange(xs.size).reshape(rows, columns)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    triangles = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return rest, triangles


def _two_bones(rest: np.ndarray, shift: float):
    """Bone 0 holds the left half, bone 1 the right half moved by `shift` in x, a one-column blend between."""
    x = rest[:, 0]
    right = np.clip(x - 5.0, 0.0, 1.0)  # 0 up to x = 5, 1 from x = 6
    weights = np.stack([1.0 - right, right], axis=1)
    transforms = np.tile(np.eye(4), (2, 1, 1))
    transforms[1, 0, 3] = shift
    return weights, transforms


def test_folds_the_skinning_makes_are_opened_and_carried_back_under_it():
    rest, triangles = _strip()
    mesh = unfold.prepare(rest, triangles)
    owner = np.arange(len(triangles))
    weights, transforms = _two_bones(rest, -2.5)  # the right half pushed back over the blend column
    skinned = linear_blend_skinning(rest, weights, transforms)
    assert count_inverted(rest, skinned, triangles, owner) > 0  # the skinning alone folds the strip
    done = skin_unfolded(mesh, blended_matrices(weights, transforms), unfold.MAX_STEPS)
    assert done.left == 0 and count_inverted(rest, done.deformed, triangles, owner) == 0
    assert len(done.vertices)  # rest positions changed where the membrane moved the skin
    corrected = rest.copy()
    corrected[done.vertices] = done.rest
    # what an Armature modifier makes of the corrected rest is the membrane's result
    np.testing.assert_allclose(linear_blend_skinning(corrected, weights, transforms), done.deformed, atol=1e-12)
    untouched = np.setdiff1d(np.arange(len(rest)), done.vertices)
    np.testing.assert_array_equal(done.deformed[untouched], skinned[untouched])


@pytest.mark.parametrize("shift", [0.0, 0.5])
def test_a_skinning_without_folds_is_left_exactly_as_it_is(shift):
    rest, triangles = _strip()
    weights, transforms = _two_bones(rest, shift)
    done = skin_unfolded(unfold.prepare(rest, triangles), blended_matrices(weights, transforms), unfold.MAX_STEPS)
    assert len(done.vertices) == 0 and done.left == 0
    np.testing.assert_array_equal(done.deformed, linear_blend_skinning(rest, weights, transforms))
