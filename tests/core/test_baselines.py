"""Baseline deformers (RBF, feature-point weighted) and the METHODS registry."""

import numpy as np
import pytest

from addon.deform import METHODS, DeformError
from addon.deform.baselines import bind_fp_weighted, bind_rbf
from tests.core.test_planar_bones import icosahedron, sphere_points


@pytest.fixture(scope="module")
def setup():
    control, triangles = icosahedron()
    return sphere_points(1500), control, triangles


@pytest.mark.parametrize("name", sorted(METHODS))
def test_every_method_reproduces_rest_pose(setup, name):
    rest, control, triangles = setup
    deformer = METHODS[name](rest, control, triangles)
    assert np.abs(deformer.evaluate(control) - rest).max() < 1e-9
    out = np.empty_like(rest)
    assert deformer.evaluate(control, out=out) is out


def test_rbf_interpolates_feature_point_displacements(setup):
    _, control, triangles = setup
    rng = np.random.default_rng(0)
    binding = bind_rbf(control, control, triangles)
    moved = control + rng.normal(0.0, 0.01, control.shape)
    np.testing.assert_allclose(binding.evaluate(moved), moved, atol=1e-9)


def test_rbf_is_exact_for_affine_motion(setup):
    rest, control, triangles = setup
    linear = np.array([[1.1, 0.2, 0.0], [0.0, 0.9, 0.1], [0.05, 0.0, 1.2]])
    binding = bind_rbf(rest, control, triangles)
    np.testing.assert_allclose(binding.evaluate(control @ linear.T + 0.3), rest @ linear.T + 0.3, atol=1e-9)


def test_rbf_rejects_coincident_feature_points(setup):
    rest, control, triangles = setup
    doubled = np.concatenate([control, control[:1]])
    with pytest.raises(DeformError, match="control points 0 and 12 coincide"):
        bind_rbf(rest, doubled, np.concatenate([triangles, [[12, 1, 2]]]))


def test_rbf_rejects_coplanar_feature_points():
    flat = np.array([[x, y, 0.0] for x in range(3) for y in range(3)], dtype=float)
    with pytest.raises(DeformError, match="coplanar"):
        bind_rbf(np.zeros((1, 3)), flat)


def test_fp_weighted_moves_feature_point_vertex_by_its_displacement(setup):
    _, control, triangles = setup
    binding = bind_fp_weighted(control, control, triangles)
    moved = control.copy()
    moved[3] += [0.01, -0.02, 0.005]
    result = binding.evaluate(moved)
    np.testing.assert_allclose(result[3], moved[3], atol=1e-12)
    np.testing.assert_allclose(np.delete(result, 3, axis=0), np.delete(control, 3, axis=0), atol=1e-12)


def test_fp_weighted_attenuates_with_distance():
    control = np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.01, 0.01, 0.0]])
    rest = np.array([[0.005, 0.0, 0.0], [0.015, 0.0, 0.0]])  # on the segment FP 0 → FP 1
    binding = bind_fp_weighted(rest, control, np.array([[0, 1, 2]]))
    moved = control + [[0.0, 0.0, 0.01], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    # FP 0 and FP 1 see the vertices along their shared edge (θ_2 = 0): extent d_01 = 0.02. FP 2 has two
    # neighbours at the same distance 0.01·√2, so that is its extent whatever the angles.
    near = np.sin(np.pi / 2 * (1 - 0.005 / 0.02))
    far = np.sin(np.pi / 2 * (1 - 0.015 / 0.02))
    apex = np.sin(np.pi / 2 * (1 - (0.005**2 + 0.01**2) ** 0.5 / (0.01 * 2**0.5)))
    total = near + far + apex
    expected = [near**2 / total * 0.01, far**2 / total * 0.01]  # Σ W_j² ΔFP_j / Σ W_j, only FP 0 moves
    np.testing.assert_allclose(binding.evaluate(moved)[:, 2], expected, atol=1e-12)


def test_baselines_reject_nan(setup):
    rest, control, triangles = setup
    bad = control.copy()
    bad[0, 0] = np.nan
    for name in ("rbf", "fp_weighted"):
        with pytest.raises(DeformError, match="non-finite"):
            METHODS[name](rest, bad, triangles)
        deformer = METHODS[name](rest, control, triangles)
        with pytest.raises(DeformError, match="non-finite"):
            deformer.evaluate(bad)
