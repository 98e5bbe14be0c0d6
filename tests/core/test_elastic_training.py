"""Training of Elastic Bones (least squares, two linear stages) on a tiny synthetic case with a known answer."""

import numpy as np
import pytest

from addon.elastic.parameters import Parameters
from addon.elastic.pose import fp_transforms, pose_from_fps
from addon.elastic.skeleton import Bone, place_skeleton
from addon.elastic.skinning import linear_blend_skinning
from addon.elastic.training import affine_system, solve_bounded, train

FPS = {
    "7.1": np.array([0.0, 0.0, 0.0]),
    "11.4": np.array([0.0, 0.0, 0.2]),
    "3.7": np.array([0.05, 0.0, 0.1]),
    "3.12": np.array([-0.05, 0.0, 0.1]),
    "5.1": np.array([0.04, -0.08, 0.05]),
    "2.4": np.array([0.02, -0.09, 0.03]),
}
# a root, a bone following FP 2.4 and a bone with no FP of its own that only the elastic layer moves
BONES = (
    Bone("head", ("7.1",), ("11.4",), None, kind="root"),
    Bone("corner", ("2.4",), (), "head", ("2.4",)),
    Bone("cheek", ("5.1",), (), "head", (), ("corner",)),
)


def synthetic(params):
    skeleton = place_skeleton(FPS, bones=BONES)
    rng = np.random.default_rng(3)
    rest = rng.normal(scale=0.05, size=(30, 3))
    weights = rng.random((30, 3))
    # the corner's and the cheek's skin apart (stage 1 fits the gain with the elastic layer off, so the
    # cheek's elastic motion must not reach the vertices that measure the gain); some vertices head only
    weights[:10, 1:] = 0.0
    weights[10:20, 2] = 0.0
    weights[20:, 1] = 0.0
    weights /= weights.sum(axis=1, keepdims=True)
    units = []
    for motion in ([0.004, 0.001, 0.0], [-0.002, 0.0, 0.003], [0.0, -0.005, 0.001]):
        moved = dict(FPS, **{"2.4": FPS["2.4"] + motion})
        sculpted = linear_blend_skinning(rest, weights, pose_from_fps(skeleton, FPS, moved, params))
        units.append((moved, sculpted))
    return skeleton, weights, rest, units


def test_training_recovers_known_gain_and_elastic_weight():
    known = Parameters({"corner": 1.7}, {("cheek", "corner"): 0.6})
    skeleton, weights, rest, units = synthetic(known)
    trained = train(skeleton, weights, rest, units, lambda moved, gains: fp_transforms(skeleton, FPS, moved, gains))
    assert trained.gains == {"corner": pytest.approx(1.7, abs=1e-9)}
    assert trained.elastic == {("cheek", "corner"): pytest.approx(0.6, abs=1e-9)}
    # the same data without its elastic part: stage 2 finds nothing to explain
    skeleton, weights, rest, units = synthetic(known.without_elastic())
    trained = train(skeleton, weights, rest, units, lambda moved, gains: fp_transforms(skeleton, FPS, moved, gains))
    assert trained.elastic == {("cheek", "corner"): pytest.approx(0.0, abs=1e-9)}


def test_affine_least_squares_with_bounds():
    columns = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    base, cols = affine_system(lambda t: np.array([1.0, 0.0, 2.0]) + columns @ t, 2)
    np.testing.assert_allclose(cols, columns)
    target = base + columns @ [0.5, 3.0]
    np.testing.assert_allclose(solve_bounded([(base, cols, target)], (0.0, 10.0)), [0.5, 3.0], atol=1e-9)
    assert solve_bounded([(base, cols, target)], (0.0, 2.0))[1] == pytest.approx(2.0)
