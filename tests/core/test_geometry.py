"""Delaunay triangulation and cylindrical projection."""

import numpy as np
import pytest

from addon.geometry.cylindrical import cylindrical_projection
from addon.geometry.delaunay import TriangulationError, delaunay


def test_square_with_centre():
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], float)
    tris = delaunay(pts)
    assert sorted(map(lambda t: tuple(sorted(t)), tris)) == [(0, 1, 4), (0, 3, 4), (1, 2, 4), (2, 3, 4)]


@pytest.mark.parametrize("seed", range(5))
def test_random_points_are_delaunay_and_counter_clockwise(seed):
    pts = np.random.default_rng(seed).random((60, 2))
    tris = delaunay(pts)
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(cross > 0)
    # empty circumcircle: no input point strictly inside any triangle's circumcircle
    for t in tris:
        m = np.array([[*pts[k], pts[k] @ pts[k], 1.0] for k in t])
        for q in pts:
            if any(np.array_equal(q, pts[k]) for k in t):
                continue
            det = np.linalg.det(np.vstack([m, [*q, q @ q, 1.0]]))
            assert det <= 1e-12
    # a planar triangulation of n points with h hull points has 2n - 2 - h triangles; slivers may be missing
    assert len(tris) >= 2 * 60 - 2 - 20


def test_bad_input():
    with pytest.raises(TriangulationError, match="coincident"):
        delaunay(np.array([[0, 0], [1, 0], [0, 0], [0, 1]], float))
    with pytest.raises(TriangulationError, match="collinear"):
        delaunay(np.array([[0, 0], [1, 0], [2, 0]], float))
    with pytest.raises(TriangulationError, match="finite"):
        delaunay(np.array([[0, 0], [1, np.nan], [2, 0]], float))


def test_cylindrical_projection_unrolls_a_cylinder():
    # Blender frame: up = +Z, forward = -Y; points on a radius-0.1 cylinder around the Z axis
    angles = np.array([0.0, 0.5, -0.5, 1.5])
    pts = np.stack([0.1 * np.sin(angles), -0.1 * np.cos(angles), np.array([0.0, 0.1, -0.2, 0.3])], axis=1)
    uv = cylindrical_projection(pts, centre=np.zeros(3), radius=0.1)
    np.testing.assert_allclose(uv[:, 0], 0.1 * angles, atol=1e-15)  # angle 0 straight ahead, + toward the left
    np.testing.assert_allclose(uv[:, 1], pts[:, 2], atol=1e-15)
