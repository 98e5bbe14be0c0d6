"""2D Delaunay triangulation (Bowyer-Watson) for the few dozen feature points of a face.

Set-up runs inside Blender, which ships numpy but not scipy, so the control mesh of an incomplete
feature point set is triangulated here. O(n^2) is fine for n <= 84. With a finite super-triangle a
sliver on the convex hull can be missing (about one input in a few hundred); every triangle returned
is Delaunay, and the face's control mesh only needs its interior.
"""

from __future__ import annotations

import numpy as np

from ..errors import Mpeg4Error


class TriangulationError(Mpeg4Error):
    """Points that cannot be triangulated (too few, all on a line)."""


def _circumcircle(p: np.ndarray, tri: tuple[int, int, int]) -> tuple[np.ndarray, float]:
    a, b, c = p[list(tri)]
    d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if d == 0.0:
        return np.array([np.inf, np.inf]), np.inf
    sa, sb, sc = a @ a, b @ b, c @ c
    centre = (
        np.array(
            [
                sa * (b[1] - c[1]) + sb * (c[1] - a[1]) + sc * (a[1] - b[1]),
                sa * (c[0] - b[0]) + sb * (a[0] - c[0]) + sc * (b[0] - a[0]),
            ]
        )
        / d
    )
    return centre, float(np.sum((a - centre) ** 2))


def delaunay(points: np.ndarray) -> np.ndarray:
    """(n, 2) points -> (T, 3) counter-clockwise triangles of their Delaunay triangulation."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise TriangulationError("need at least 3 points in 2D to triangulate")
    if not np.all(np.isfinite(pts)):
        raise TriangulationError("points must be finite")
    if len(np.unique(pts, axis=0)) != len(pts):
        raise TriangulationError("coincident points cannot be triangulated")
    n = len(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-12))
    mid = 0.5 * (lo + hi)
    # a super-triangle far outside everything; removed at the end
    p = np.vstack([pts, mid + span * np.array([[-3e3, -3e3], [3e3, -3e3], [0.0, 3e3]])])
    triangles = {(n, n + 1, n + 2): _circumcircle(p, (n, n + 1, n + 2))}
    for i in range(n):
        bad = [t for t, (c, r2) in triangles.items() if np.sum((p[i] - c) ** 2) < r2 * (1 + 1e-12)]
        edges: dict[tuple[int, int], int] = {}
        for t in bad:
            for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                key = (min(e), max(e))
                edges[key] = edges.get(key, 0) + 1
            del triangles[t]
        for (a, b), count in edges.items():
            if count == 1:
                t = (a, b, i)
                triangles[t] = _circumcircle(p, t)
    out = np.array([t for t in triangles if max(t) < n], dtype=np.int64).reshape(-1, 3)
    if len(out) == 0:
        raise TriangulationError("the points are collinear")
    a, b, c = pts[out[:, 0]], pts[out[:, 1]], pts[out[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    out[cross < 0] = out[cross < 0][:, [0, 2, 1]]
    return out[np.abs(cross) > 1e-15 * span * span]
