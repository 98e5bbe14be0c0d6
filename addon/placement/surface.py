"""A user's mesh as placement reads it: triangles, loose parts, closest surface points (numpy + scipy).

Polygons of any size are fanned into triangles first (`deform.folds.fan_triangles`). Closest points are
found on the triangles around the nearest few vertices (a k-d tree of the vertices), which is exact when
the mesh's edges are short against the query's distance and close otherwise; placement only asks about
points already near the surface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..deform.loose_parts import loose_parts as edge_pieces
from ..geometry.normals import vertex_normals
from .scipy_modules import cKDTree

NEAR_VERTICES = 6  # vertices whose triangles are searched for a closest point


def loose_parts(n_vertices: int, triangles: np.ndarray) -> np.ndarray:
    """(N,) label of each vertex's connected piece (vertices in no triangle get their own label)."""
    t = np.asarray(triangles, dtype=np.int64)
    return edge_pieces(n_vertices, np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]))


def triangle_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[triangles[:, j]] for j in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def closest_on_triangles(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest point of triangle (a, b, c) to each point (all (K, 3)); Ericson, Real-Time Collision
    Detection 5.1.5, by Voronoi region of the triangle's corners, edges and face."""
    ab, ac, ap = b - a, c - a, points - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = points - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = points - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denominator = va + vb + vc
    denominator = np.where(np.abs(denominator) > 1e-300, denominator, 1e-300)
    v = vb / denominator
    w = vc / denominator
    result = a + ab * v[:, None] + ac * w[:, None]

    # each region's point computed on its own rows only (the same numbers, fewer of them); later regions
    # overwrite earlier ones, as Ericson's tests return in this order reversed
    # an edge's region needs the edge to have length (its squared length is the fraction's denominator):
    # a triangle with two corners in one place (a UV sphere's pole) is its other two edges
    with np.errstate(divide="ignore", invalid="ignore"):
        length = (d4 - d3) + (d5 - d6)
        rows = np.flatnonzero((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0) & (length > 0))  # edge bc
        result[rows] = b[rows] + (c[rows] - b[rows]) * ((d4[rows] - d3[rows]) / length[rows])[:, None]
        rows = np.flatnonzero((vb <= 0) & (d2 >= 0) & (d6 <= 0) & (d2 - d6 > 0))  # edge ac
        result[rows] = a[rows] + ac[rows] * (d2[rows] / (d2[rows] - d6[rows]))[:, None]
        rows = np.flatnonzero((vc <= 0) & (d1 >= 0) & (d3 <= 0) & (d1 - d3 > 0))  # edge ab
        result[rows] = a[rows] + ab[rows] * (d1[rows] / (d1[rows] - d3[rows]))[:, None]
    for corner, at in ((c, (d6 >= 0) & (d5 <= d6)), (b, (d3 >= 0) & (d4 <= d3)), (a, (d1 <= 0) & (d2 <= 0))):
        result[at] = corner[at]
    return result


@dataclass
class Surface:
    """Vertices (N, 3) and triangles (T, 3) with the look-ups placement needs."""

    vertices: np.ndarray
    triangles: np.ndarray

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float64)
        self.triangles = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        self.tree = cKDTree(self.vertices)
        self.normals = vertex_normals(self.vertices, self.triangles)
        # each vertex's triangles, padded with -1 to the largest fan
        order = np.argsort(self.triangles.ravel(), kind="stable")
        vertex = self.triangles.ravel()[order]
        counts = np.bincount(vertex, minlength=len(self.vertices))
        width = max(int(counts.max()) if len(counts) else 1, 1)
        starts = np.cumsum(counts) - counts
        slot = np.arange(len(order)) - starts[vertex]
        self.vertex_triangles = np.full((len(self.vertices), width), -1, dtype=np.int64)
        self.vertex_triangles[vertex, slot] = order // 3

    def locate(self, points: np.ndarray, near: int = NEAR_VERTICES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For `points` (K, 3): their closest surface points (K, 3), the triangles holding them (K,) and their
        barycentric weights there (K, 3)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        k = min(near, len(self.vertices))
        _d, nearest = self.tree.query(points, k=k)
        candidates = self.vertex_triangles[nearest.reshape(len(points), k)].reshape(len(points), -1)
        valid = (candidates >= 0) & ~_repeated(candidates)
        query, slot = np.nonzero(valid)
        triangle = candidates[query, slot]
        t = self.triangles[triangle]
        q = closest_on_triangles(points[query], *(self.vertices[t[:, j]] for j in range(3)))
        distance = np.full(candidates.shape, np.inf)
        distance[query, slot] = ((q - points[query]) ** 2).sum(1)
        chosen = np.full(candidates.shape, -1, dtype=np.int64)
        chosen[query, slot] = np.arange(len(query))
        row = chosen[np.arange(len(points)), distance.argmin(axis=1)]
        best, best_triangle = q[row], triangle[row]
        corners = self.triangles[best_triangle]
        weights = _barycentric(best, *(self.vertices[corners[:, j]] for j in range(3)))
        return best, best_triangle, weights

    def closest(self, points: np.ndarray, near: int = NEAR_VERTICES) -> tuple[np.ndarray, np.ndarray]:
        """(closest surface points (K, 3), their interpolated unit normals (K, 3)) of `points` (K, 3)."""
        best, triangle, weights = self.locate(points, near)
        normal = np.einsum("kj,kjd->kd", weights, self.normals[self.triangles[triangle]])
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        return best, normal / np.where(length > 0, length, 1.0)


def _repeated(rows: np.ndarray) -> np.ndarray:
    """(K, C) True where a value already occurs earlier in its row: neighbouring vertices share most of their
    triangles, and a triangle measured once per query gives the same closest point (the first of equally
    near slots is the one kept, as before)."""
    order = np.argsort(rows, axis=1, kind="stable")  # equal values keep their slot order
    ranked = np.take_along_axis(rows, order, axis=1)
    seen = np.zeros(rows.shape, dtype=bool)
    seen[:, 1:] = ranked[:, 1:] == ranked[:, :-1]
    repeated = np.empty_like(seen)
    np.put_along_axis(repeated, order, seen, axis=1)
    return repeated


def _barycentric(p, a, b, c) -> np.ndarray:
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    denominator = d00 * d11 - d01 * d01
    denominator = np.where(np.abs(denominator) > 1e-300, denominator, 1.0)
    v = (d11 * d20 - d01 * d21) / denominator
    w = (d00 * d21 - d01 * d20) / denominator
    return np.clip(np.stack([1.0 - v - w, v, w], axis=1), 0.0, 1.0)


def area_samples(vertices: np.ndarray, triangles: np.ndarray, count: int, seed: int = 0):
    """`count` points spread over the surface by area, and their triangles' unit normals (seeded: the same
    mesh gives the same samples)."""
    areas = triangle_areas(vertices, triangles)
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(triangles), size=count, p=areas / areas.sum())
    r1, r2 = rng.random(count), rng.random(count)
    flip = r1 + r2 > 1
    r1[flip], r2[flip] = 1 - r1[flip], 1 - r2[flip]
    t = triangles[chosen]
    a, b, c = vertices[t[:, 0]], vertices[t[:, 1]], vertices[t[:, 2]]
    normals = np.cross(b - a, c - a)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    return a + (b - a) * r1[:, None] + (c - a) * r2[:, None], normals
