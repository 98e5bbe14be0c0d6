"""2D Delaunay triangulation of unrolled feature points (Qhull through scipy) and barycentric location in it.

Used by the missing-FP step (§3.1.1) on the given FPs and by the texture and calibration steps (§3.2,
§3.3) on the expanded FP set. Points are labelled (FP ids, or "2.1 (copy left)") so an error names them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .errors import CoincidentFeaturePointsError, FeaturePointError, FoldError
from .spatial import spatial

if TYPE_CHECKING:
    from scipy.spatial import Delaunay

# Points closer than this fraction of the set's extent are one point to the triangulation.
SAME_POINT_FRACTION = 1e-9
# A triangle folds when its signed area, turned to the reference orientation, is below -FOLD_FRACTION
# times its longest edge squared. Only triangles whose height on their longest edge is at least
# SLIVER_FRACTION of it in the reference are checked: slivers (the inner lip points, the eyelids over the
# pupil) flip with ordinary differences in shape. Measured on the sample head against 386 MakeHuman
# shape targets with all and with random halves of the FPs: 4 of 1,544 flag a fold (the nose tip
# pulled below the nostrils, the inner lip crossing the outer), while 30 of the 31 swapped mirror pairs
# of surface FPs (all but the ear lobes' 10.7/10.8), a mirrored face and a nose tip on the chin are caught.
FOLD_FRACTION = 0.01
SLIVER_FRACTION = 0.1


def triangulate(points: np.ndarray, labels: Sequence[str], what: str) -> Delaunay:
    """Delaunay triangulation of (n, 2) points; refuses fewer than 3, repeated or collinear points."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 3:
        raise FeaturePointError(
            f"{what}: {len(points)} point(s) ({', '.join(labels)}); at least 3 not on one line are needed"
        )
    span = float(np.linalg.norm(np.ptp(points, axis=0)))
    scipy_spatial = spatial()
    pairs = sorted(scipy_spatial.cKDTree(points).query_pairs(SAME_POINT_FRACTION * span))
    if pairs:
        names = "; ".join(f"{labels[a]} and {labels[b]}" for a, b in pairs)
        raise CoincidentFeaturePointsError(f"{what}: these fall on the same point of the unrolled face: {names}")
    try:
        triangulation = scipy_spatial.Delaunay(points)
    except scipy_spatial.QhullError:
        raise FeaturePointError(
            f"{what}: the points {', '.join(labels)} lie on one line of the unrolled face; nothing to triangulate"
        ) from None
    if len(triangulation.coplanar):
        dropped = ", ".join(labels[int(k)] for k in triangulation.coplanar[:, 0])
        raise CoincidentFeaturePointsError(f"{what}: {dropped} coincide with other points of the unrolled face")
    return triangulation


def signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T,) twice the signed area of each triangle (positive = counter-clockwise)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def folded_triangles(reference: np.ndarray, points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Indices of the non-sliver `triangles` whose orientation in (n, 2) `points` opposes that in `reference`."""
    reference_area = signed_areas(reference, triangles)
    area = np.sign(reference_area) * signed_areas(points, triangles)
    shaped = np.abs(reference_area) >= SLIVER_FRACTION * _longest_squared(reference, triangles)
    return np.flatnonzero(shaped & (area < -FOLD_FRACTION * _longest_squared(points, triangles)))


def refuse_folds(reference: np.ndarray, points: np.ndarray, triangles: np.ndarray, ids, what: str, why: str) -> None:
    """FoldError naming (up to six of) the triangles folded in `points` relative to `reference`.

    `what` says what folds ("the given FPs fold the face"), `why` what the triangles are mirrored relative to and
    the likely cause ("the generic face (are left and right swapped, ...)")."""
    folded = folded_triangles(reference, points, triangles)
    if len(folded):
        names = "; ".join(", ".join(ids[k] for k in triangles[t]) for t in folded[:6])
        more = f" and {len(folded) - 6} more" if len(folded) > 6 else ""
        raise FoldError(f"{what}: triangle(s) {names}{more} are mirrored relative to {why}")


def _longest_squared(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return np.max([np.sum((b - a) ** 2, axis=1), np.sum((c - b) ** 2, axis=1), np.sum((a - c) ** 2, axis=1)], axis=0)


def locate(triangulation: Delaunay, queries: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertex indices (n, 3), barycentric weights (n, 3), inside (n,)) of each query point.

    A point outside the triangulation gets the weights of the nearest point on its boundary (one weight
    is 0, the others are in [0, 1]), so anything interpolated with them stays within the values given.
    """
    queries = np.asarray(queries, dtype=np.float64)
    simplex = triangulation.find_simplex(queries)
    inside = simplex >= 0
    weights = np.zeros((len(queries), 3))
    if np.any(inside):
        transform = triangulation.transform[simplex[inside]]
        first = np.einsum("nij,nj->ni", transform[:, :2], queries[inside] - transform[:, 2])
        weights[inside] = np.column_stack([first, 1.0 - first.sum(axis=1)])
    if not np.all(inside):
        simplex[~inside], weights[~inside] = _nearest_on_boundary(triangulation, queries[~inside])
    return triangulation.simplices[simplex], weights, inside


def _nearest_on_boundary(triangulation: Delaunay, queries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    owner, opposite = np.nonzero(triangulation.neighbors < 0)
    corners = triangulation.simplices[owner]
    first = corners[np.arange(len(owner)), (opposite + 1) % 3]
    second = corners[np.arange(len(owner)), (opposite + 2) % 3]
    a, b = triangulation.points[first], triangulation.points[second]
    edge = b - a
    t = np.einsum("qed,ed->qe", queries[:, None, :] - a[None], edge) / np.einsum("ed,ed->e", edge, edge)
    t = np.clip(t, 0.0, 1.0)
    gap = np.linalg.norm(a[None] + t[..., None] * edge[None] - queries[:, None, :], axis=2)
    best = np.argmin(gap, axis=1)
    rows = np.arange(len(queries))
    weights = np.zeros((len(queries), 3))
    slot = opposite[best]
    weights[rows, (slot + 1) % 3] = 1.0 - t[rows, best]
    weights[rows, (slot + 2) % 3] = t[rows, best]
    return owner[best], weights
