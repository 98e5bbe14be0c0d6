"""Which triangles of a mesh can hold the surface point nearest to given points (to search only those)."""

from __future__ import annotations

import numpy as np

SAMPLE = 2048  # vertices whose distances bound each point's nearest-vertex distance from above


def triangles_near(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Indices of the triangles that can hold the surface point nearest to any of `points` (K, 3).

    The nearest surface point q of p is no farther than p's nearest vertex (distance d). Every corner c of
    a triangle holding q lies within the triangle's longest edge of q, so within d + L(c) of p, L(c) being
    the longest edge of the triangles around c: the triangles kept are those whose corners all pass that
    test for some point. Searching only them finds the same nearest point as searching all.

    d is found among the vertices within u + L of p along x (a slab of the vertices sorted by x; u >= d is
    p's distance to the nearest of a few sampled vertices, L the mesh's longest edge), so no distance to a
    far vertex is taken.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points) or not len(triangles):
        return np.zeros(0, dtype=np.intp)
    edge = np.zeros(len(triangles))
    for j in range(3):
        step = vertices[triangles[:, (j + 1) % 3]] - vertices[triangles[:, j]]
        np.maximum(edge, np.sqrt((step * step).sum(axis=1)), out=edge)
    around = np.zeros(len(vertices))  # L(c)
    for j in range(3):
        np.maximum.at(around, triangles[:, j], edge)
    around *= 1.0 + 1e-9  # rounding of the distances below
    sample = vertices[:: max(1, len(vertices) // SAMPLE)]
    upper = np.sqrt(((sample[None, :, :] - points[:, None, :]) ** 2).sum(axis=2).min(axis=1))
    order = np.argsort(vertices[:, 0], kind="stable")
    xs = vertices[order, 0]
    longest = edge.max()
    near = np.zeros(len(vertices), dtype=bool)
    for p, u in zip(points, upper, strict=True):
        reach = u + longest
        start, stop = np.searchsorted(xs, p[0] - reach, side="left"), np.searchsorted(xs, p[0] + reach, side="right")
        slab = order[start:stop]  # every vertex within `reach` >= d + L(c) of p, the nearest one among them
        distance = np.sqrt(((vertices[slab] - p) ** 2).sum(axis=1))
        near[slab[distance <= distance.min() + around[slab]]] = True
    return np.flatnonzero(near[triangles].all(axis=1))
