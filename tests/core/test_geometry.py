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


def _grid(n: int, bump: float = 0.0):
    """An n x n grid of unit squares (two triangles each) on z = bump * sin(x) cos(y)."""
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), bump * np.sin(x.ravel()) * np.cos(y.ravel())], axis=1)
    k = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    triangles = np.concatenate([np.stack([k, k + n + 1, k + 1], 1), np.stack([k + 1, k + n + 1, k + n + 2], 1)])
    return vertices, triangles


def test_triangles_near_keeps_the_nearest_and_drops_the_far():
    from addon.geometry.nearby import triangles_near

    vertices, triangles = _grid(20)
    kept = triangles_near(vertices, triangles, np.array([[5.25, 7.5, 0.3]]))
    # the point's foot (5.25, 7.5) lies in the square [5, 6] x [7, 8]: both its triangles are kept
    square = [t for t, tri in enumerate(triangles) if set(tri) <= {5 * 21 + 7, 5 * 21 + 8, 6 * 21 + 7, 6 * 21 + 8}]
    assert set(square) <= set(kept.tolist())
    # nearest vertex at distance sqrt(0.25^2 + 0.5^2 + 0.3^2) ~ 0.63, longest edge sqrt(2): nothing beyond 2.05
    corners = vertices[triangles[kept]]
    assert np.linalg.norm(corners[..., :2] - [5.25, 7.5], axis=2).max() <= 0.63 + np.sqrt(2) + 1e-9
    assert 0 < len(kept) < len(triangles) / 20


def test_triangles_near_finds_the_same_nearest_point_as_the_whole_mesh():
    pytest.importorskip("bpy")  # mathutils comes with it
    from mathutils import bvhtree

    from addon.geometry.nearby import triangles_near

    vertices, triangles = _grid(30, bump=0.8)
    points = np.random.default_rng(3).uniform([0, 0, -2], [30, 30, 2], size=(40, 3))
    whole = bvhtree.BVHTree.FromPolygons(vertices.tolist(), triangles.tolist())
    part = bvhtree.BVHTree.FromPolygons(
        vertices.tolist(), triangles[triangles_near(vertices, triangles, points)].tolist()
    )
    for p in points:
        assert np.allclose(whole.find_nearest(p)[0], part.find_nearest(p)[0], atol=1e-6)
