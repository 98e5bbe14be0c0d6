"""Sibson (natural-neighbour) coordinates in 3D, computed exactly: the weights of Dirichlet FFD.

Definition (Sibson; Moccozet & Magnenat-Thalmann's DFFD, used by Escher et al. §3.1): insert a point x
into the Voronoi diagram of the sites p_i; x's new cell V_x takes a part of the cell V_i of each of its
natural neighbours, and

    lambda_i(x) = vol(V_x ∩ V_i) / vol(V_x).

So lambda >= 0, sum lambda = 1, sum lambda_i p_i = x (linear precision, hence exact affine
reproduction), lambda_i(p_j) = delta_ij, and lambda_i is non-zero only for x's natural neighbours.

How, exactly and without sampling. The Voronoi cell of a site is its circumcentric dual in the
Delaunay tetrahedralisation: a signed sum, over the tetrahedra T around the site p_i, of the pieces
(p_i, midpoint of edge ij, circumcentre of face ijl, circumcentre of T) — 6 per tetrahedron, signed by
orientation so that obtuse tetrahedra (circumcentre outside) still add up; the 24 pieces of one
tetrahedron sum to its volume (`dual_pieces`). Inserting x (Bowyer-Watson) removes the tetrahedra whose
circumsphere contains x (the cavity) and joins x to the cavity's boundary faces. Only pieces in those
tetrahedra change, so the volume x steals from V_i is

    (pieces of p_i in the cavity's tetrahedra) - (pieces of p_i in the new tetrahedra),

and vol(V_x) is their sum over i. Qhull (scipy.spatial.Delaunay) tetrahedralises the sites once; each
point then costs a circumsphere test against every tetrahedron and the pieces of its few dozen new
tetrahedra, vectorised over chunks of points. No volume is approximated: the results agree with an
independent computation (Qhull's halfspace intersection of the Voronoi cells before and after inserting
x) to rounding, ~1e-14 (tests/core/test_fitting_sibson.py).

Degenerate sites. Mirror-symmetric FPs put 4 sites on one circle (two mirror pairs), and Qhull's
triangulated output then holds flat tetrahedra. A flat tetrahedron's pieces cancel in pairs (the two
faces at each of its edges share one circumcircle), so it adds no volume. Its "circumsphere" is any
sphere through its circle; the spheres of the solid tetrahedra on either side of its plane are two of
them, and since "x inside the sphere centred at height t above the circle" is linear in t, x is inside
every sphere between them exactly when it is inside both. So a flat tetrahedron joins the cavity when
all its neighbours do (a flat neighbour by the same rule, the outside of the hull never), which keeps the
cavity star-shaped from x even when x lies in the flat tetrahedron's plane (a mesh vertex on the face's
plane of symmetry). A new tetrahedron takes the orientation of the solid one whose face it stands on (on
a flat one's face: its own, as x is off that plane). A point within SNAP_FRACTION of a site is that
site (lambda = 1 there). Points must lie inside the sites' convex hull, where V_x is bounded;
Dirichlet FFD encloses the mesh in auxiliary sites for that (`dffd`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import permutations

import numpy as np

from .errors import CoincidentFeaturePointsError, FeaturePointError, FittingError
from .spatial import spatial

FLAT_FRACTION = 1e-10  # |6 volume| / longest edge^3 below this: a flat tetrahedron
SNAP_FRACTION = 1e-9  # of the sites' bounding-box diagonal
CHUNK = 1024  # points per vectorised batch

Progress = Callable[[int, int], None]


def _parity(order: tuple[int, ...]) -> int:
    inversions = sum(a > b for k, a in enumerate(order) for b in order[k + 1 :])
    return -1 if inversions % 2 else 1


# Each ordered slot pair (i, j) of a tetrahedron, the remaining slots (k, m) in increasing order, and the
# parity of (i, j, k, m). The two pieces of p_i on edge ij combine into one determinant (`dual_pieces`).
_EDGE_FLAGS = tuple(
    (i, j, k, m, _parity((i, j, k, m)))
    for i, j in permutations(range(4), 2)
    for k, m in [sorted({0, 1, 2, 3} - {i, j})]
)


def _det(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, np.cross(b, c))


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, b)


def triangle_circumcentres(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    u, v = b - a, c - a
    w = np.cross(u, v)
    return a + np.cross(_dot(u, u)[..., None] * v - _dot(v, v)[..., None] * u, w) / (2.0 * _dot(w, w)[..., None])


def tetrahedron_circumcentres(corners: np.ndarray) -> np.ndarray:
    """(M, 3) circumcentres of (M, 4, 3) tetrahedra (inf/nan for flat ones)."""
    a = corners[:, 0]
    u, v, w = corners[:, 1] - a, corners[:, 2] - a, corners[:, 3] - a
    numerator = (
        _dot(u, u)[:, None] * np.cross(v, w)
        + _dot(v, v)[:, None] * np.cross(w, u)
        + _dot(w, w)[:, None] * np.cross(u, v)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        return a + numerator / (2.0 * _det(u, v, w))[:, None]


def face_circumcentres(corners: np.ndarray) -> np.ndarray:
    """(M, 4, 3): circumcentre of the face opposite each slot of (M, 4, 3) tetrahedra."""
    faces = [[s for s in range(4) if s != slot] for slot in range(4)]
    return np.stack([triangle_circumcentres(*(corners[:, k] for k in face)) for face in faces], axis=1)


def dual_pieces(corners: np.ndarray, faces: np.ndarray, centres: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """(M, 4): the signed volume of each corner's circumcentric dual piece inside each tetrahedron.

    Piece (i, j, k, m) is the tetrahedron (p_i, midpoint ij, circumcentre of face ijk, circumcentre C),
    of volume sigma * det(mid_ij - p_i, c_ijk - mid_ij, C - c_ijk) / 6 with sigma the orientation of
    (i, j, k, m). Its partner (i, j, m, k) has the opposite sigma, and det(a, b, D - b) = det(a, b, D),
    so the two make sigma * det((p_j - p_i) / 2, c_ijk - c_ijm, C - mid_ij) / 6. `orientation` is the sign
    of each tetrahedron in its slot order (+-1; 0 leaves a flat one out). The four corners' pieces add
    up to the tetrahedron's volume.
    """
    out = np.zeros(corners.shape[:2])
    for i, j, k, m, parity in _EDGE_FLAGS:
        half_edge = 0.5 * (corners[:, j] - corners[:, i])
        across = faces[:, m] - faces[:, k]  # c_ijk is the face without m, c_ijm the one without k
        rise = centres - 0.5 * (corners[:, i] + corners[:, j])
        out[:, i] += parity * _det(half_edge, across, rise)
    return out * (orientation / 6.0)[:, None]


@dataclass(frozen=True)
class SibsonCoordinates:
    """Per point, its natural neighbours among the sites and their Sibson coordinates (padded rows)."""

    indices: np.ndarray  # (N, K) int32 site of each slot; 0 in unused slots
    weights: np.ndarray  # (N, K) float64; 0 in unused slots
    counts: np.ndarray  # (N,) int32 slots in use (the natural neighbours)
    n_sites: int

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """(N, d) sum_i lambda_i values_i for (n_sites, d) values at the sites."""
        return np.einsum("nk,nkd->nd", self.weights, np.asarray(values, dtype=np.float64)[self.indices])


class _Tetrahedralisation:
    """The sites' Delaunay tetrahedra with what every insertion reuses: circumspheres and dual pieces."""

    def __init__(self, sites: np.ndarray):
        scipy_spatial = spatial()
        try:
            delaunay = scipy_spatial.Delaunay(sites)
        except scipy_spatial.QhullError:
            raise FeaturePointError("the control points lie in one plane; no tetrahedra to interpolate in") from None
        if len(delaunay.coplanar):
            raise CoincidentFeaturePointsError(
                f"control points {sorted(delaunay.coplanar[:, 0].tolist())} coincide with others"
            )
        self.delaunay = delaunay
        self.simplices = delaunay.simplices.astype(np.intp)
        self.neighbors = delaunay.neighbors.astype(np.intp)
        corners = sites[self.simplices]
        volume6 = _det(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0])
        longest = np.max(np.linalg.norm(corners[:, :, None] - corners[:, None, :], axis=3), axis=(1, 2))
        solid = np.abs(volume6) > FLAT_FRACTION * longest**3
        self.orientation = np.where(solid, np.sign(volume6), 0.0)
        self.centres = np.zeros((len(corners), 3))
        self.radius2 = np.full(len(corners), -np.inf)  # a flat tetrahedron's circumsphere contains nothing
        self.pieces = np.zeros((len(corners), 4))  # a flat tetrahedron's pieces cancel: none
        self.centres[solid] = tetrahedron_circumcentres(corners[solid])
        self.radius2[solid] = np.sum((corners[solid, 0] - self.centres[solid]) ** 2, axis=1)
        self.pieces[solid] = dual_pieces(
            corners[solid], face_circumcentres(corners[solid]), self.centres[solid], self.orientation[solid]
        )
        self.sites = sites
        self.flat = np.flatnonzero(~solid)

    def _flat_conflicts(self, conflict: np.ndarray) -> np.ndarray:
        """`conflict` with each flat tetrahedron in the cavity iff all its neighbours are (largest fixed point)."""
        neighbours = self.neighbors[self.flat]
        status = np.ones((len(conflict), len(self.flat)), dtype=bool)
        for _ in range(len(self.flat) + 1):
            conflict[:, self.flat] = status
            joined = np.all(np.where(neighbours >= 0, conflict[:, np.maximum(neighbours, 0)], False), axis=2)
            if np.array_equal(joined, status):
                break
            status = joined
        return conflict

    def stolen_volumes(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(volume each site loses to each point (c, n_sites), natural-neighbour mask (c, n_sites))."""
        n_points, n_sites = len(points), len(self.sites)
        conflict = np.sum((points[:, None, :] - self.centres[None]) ** 2, axis=2) < self.radius2[None]
        if len(self.flat):
            conflict = self._flat_conflicts(conflict)
        point, tet = np.nonzero(conflict)
        cell = point[:, None] * n_sites + self.simplices[tet]
        stolen = np.bincount(cell.ravel(), self.pieces[tet].ravel(), n_points * n_sites)

        across = self.neighbors[tet]
        kept = np.where(across >= 0, conflict[point[:, None], np.maximum(across, 0)], False)
        pair, slot = np.nonzero(~kept)  # the cavity's boundary faces: (conflict pair, slot x takes)
        new_point, new_tet = point[pair], tet[pair]
        corners = self.sites[self.simplices[new_tet]] - points[new_point, None, :]
        corners[np.arange(len(pair)), slot] = 0.0  # x, at the origin of its own frame
        faces = face_circumcentres(corners)
        orientation = self.orientation[new_tet]
        on_flat = orientation == 0.0
        if np.any(on_flat):
            edges = corners[on_flat, 1:] - corners[on_flat, :1]
            orientation[on_flat] = np.sign(_det(edges[:, 0], edges[:, 1], edges[:, 2]))
        with np.errstate(divide="ignore", invalid="ignore"):
            pieces = dual_pieces(corners, faces, tetrahedron_circumcentres(corners), orientation)
        pieces[np.arange(len(pair)), slot] = 0.0  # x's own piece: not taken from any site
        new_cell = new_point[:, None] * n_sites + self.simplices[new_tet]
        stolen -= np.bincount(new_cell.ravel(), pieces.ravel(), n_points * n_sites)

        neighbours = np.zeros(n_points * n_sites, dtype=bool)
        neighbours[cell.ravel()] = True
        return stolen.reshape(n_points, n_sites), neighbours.reshape(n_points, n_sites)


def sibson_coordinates(sites: np.ndarray, points: np.ndarray, progress: Progress | None = None) -> SibsonCoordinates:
    """Exact Sibson coordinates of (N, 3) points w.r.t. (n, 3) sites (every point inside the sites' hull).

    `progress(done, total)` is called after each batch of points.
    """
    sites = np.asarray(sites, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    if sites.ndim != 2 or sites.shape[1] != 3 or points.ndim != 2 or points.shape[1] != 3:
        raise FittingError(f"Sibson coordinates need (n, 3) sites and points, got {sites.shape} and {points.shape}")
    if not (np.all(np.isfinite(sites)) and np.all(np.isfinite(points))):
        raise FittingError("Sibson coordinates need finite sites and points")
    origin = 0.5 * (sites.min(axis=0) + sites.max(axis=0))
    sites, points = sites - origin, points - origin
    mesh = _Tetrahedralisation(sites)
    reach = float(np.linalg.norm(np.ptp(sites, axis=0)))

    distance, nearest = spatial().cKDTree(sites).query(points)
    snapped = distance <= SNAP_FRACTION * reach
    free = np.flatnonzero(~snapped)
    outside = free[mesh.delaunay.find_simplex(points[free]) < 0]
    if len(outside):
        raise FittingError(
            f"{len(outside)} point(s) lie outside the control points' convex hull (first: point {outside[0]})"
        )

    rows: list[tuple[np.ndarray, np.ndarray]] = [(np.array([k]), np.ones(1)) for k in nearest]
    total = len(points)
    done = int(np.count_nonzero(snapped))
    for start in range(0, len(free), CHUNK):
        batch = free[start : start + CHUNK]
        stolen, neighbours = mesh.stolen_volumes(points[batch])
        volume = stolen.sum(axis=1)
        if not np.all(np.isfinite(stolen)) or not np.all(volume > 0.0):
            bad = batch[~(np.all(np.isfinite(stolen), axis=1) & (volume > 0.0))]
            raise FittingError(f"degenerate control points around point {bad[0]}: its Voronoi cell has no volume")
        for row, k in enumerate(batch):
            sites_k = np.flatnonzero(neighbours[row])
            rows[k] = (sites_k, stolen[row, sites_k] / volume[row])
        done += len(batch)
        if progress is not None:
            progress(done, total)
    if progress is not None and not len(free):
        progress(total, total)
    return _pad(rows, len(sites))


def _pad(rows: list[tuple[np.ndarray, np.ndarray]], n_sites: int) -> SibsonCoordinates:
    counts = np.array([len(r[0]) for r in rows], dtype=np.int32)
    width = int(counts.max()) if len(counts) else 1
    indices = np.zeros((len(rows), width), dtype=np.int32)
    weights = np.zeros((len(rows), width))
    used = np.arange(width)[None, :] < counts[:, None]
    if len(rows):
        indices[used] = np.concatenate([r[0] for r in rows])
        weights[used] = np.concatenate([r[1] for r in rows])
    return SibsonCoordinates(indices=indices, weights=weights, counts=counts, n_sites=n_sites)
