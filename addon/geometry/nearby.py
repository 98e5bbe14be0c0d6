"""Which triangles of a mesh can hold the surface point nearest to given points (to search only those)."""

from __future__ import annotations

import numpy as np


def triangles_near(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Indices of the triangles that can hold the surface point nearest to any of `points` (K, 3).

    The nearest surface point of p is no farther than p's nearest vertex (distance d). A point of a
    triangle lies within the triangle's longest edge L of each of its corners, so a triangle holding a
    point within d of p has all three corners within d + L of p: the triangles kept are exactly those, with
    L the mesh's longest edge. Searching only them finds the same nearest point as searching all.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points) or not len(triangles):
        return np.zeros(0, dtype=np.intp)
    corners = vertices[triangles]
    longest = np.sqrt(max(float(((corners - np.roll(corners, 1, axis=1)) ** 2).sum(axis=2).max()), 0.0))
    # squared distances by |v|^2 - 2 v.p + |p|^2 (one matrix product), relative to the points' centre
    centre = points.mean(axis=0)
    v, p = vertices - centre, points - centre
    d2 = np.maximum((v * v).sum(axis=1)[:, None] - 2.0 * (v @ p.T) + (p * p).sum(axis=1)[None, :], 0.0)
    reach = np.sqrt(d2.min(axis=0)) + longest
    margin = 1e-9 * float((v * v).sum(axis=1).max() + (p * p).sum(axis=1).max()) + 1e-12  # the product's rounding
    near = (d2 <= reach * reach + margin).any(axis=1)
    return np.flatnonzero(near[triangles].all(axis=1))
