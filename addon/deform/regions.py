"""Affection-volume regions of a control triangle (Planar Bones paper, §2.1: eq. 2–7, 9–11).

Conventions, as in the paper: a triangle LMN = OPQ has corners V_0, V_1, V_2; e_j = V_{j+1} − V_j
(eq. 7, indices mod 3); n = unit((M − L) × (N − L)) (eq. 3); b_j = unit(e_j × n) is the in-plane unit
normal of edge j, which points out of the triangle for either winding. Points are row vectors, so the
paper's s = o + (S − O) A⁻¹ A' reads `origin + local @ rows`.

Regions are coded as small integers: ``FACE`` (R_A), ``EDGE + j`` (R_B,j), ``APEX + j`` (R_C,j).
"""

from dataclasses import dataclass

import numpy as np

FACE = 0
EDGE = 1
APEX = 4


@dataclass(frozen=True)
class TriangleFrames:
    """Rest-pose geometry of T control triangles, everything `locate` needs."""

    corners: np.ndarray  # (T, 3, 3) V_j
    edge_lengths: np.ndarray  # (T, 3) ‖e_j‖
    unit_edges: np.ndarray  # (T, 3, 3) e_j / ‖e_j‖
    normals: np.ndarray  # (T, 3) n, eq. 3
    edge_normals: np.ndarray  # (T, 3, 3) b_j
    doubled_areas: np.ndarray  # (T,) ‖(M − L) × (N − L)‖
    inverse_frames: np.ndarray  # (T, 3, 3) (A^OPQ)⁻¹ of eq. 2; zero for a zero-area triangle, which has none


def unit(vectors: np.ndarray) -> np.ndarray:
    """Normalise along the last axis; zero vectors stay zero (a collapsed triangle must not give NaN)."""
    norms = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return np.divide(vectors, norms, out=np.zeros_like(vectors), where=norms > 0.0)


def triangle_frames(corners: np.ndarray) -> TriangleFrames:
    """Frames of the (T, 3, 3) triangle corners (eq. 2, 3, 7, 10, 11)."""
    edges = np.roll(corners, -1, axis=1) - corners
    cross = np.cross(edges[:, 0], corners[:, 2] - corners[:, 0])
    normals = unit(cross)
    doubled_areas = np.linalg.norm(cross, axis=-1)
    # all at once: one 3 x 3 inversion per call of `locate` costs more than the rest of it on large meshes
    frames_a = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], normals], axis=1)
    inverse = np.zeros_like(frames_a)
    has_plane = doubled_areas > 0.0  # det(A^OPQ) is the doubled area
    inverse[has_plane] = np.linalg.inv(frames_a[has_plane])
    return TriangleFrames(
        corners=corners,
        edge_lengths=np.linalg.norm(edges, axis=-1),
        unit_edges=unit(edges),
        normals=normals,
        edge_normals=unit(np.cross(edges, normals[:, None, :])),
        doubled_areas=doubled_areas,
        inverse_frames=inverse,
    )


def deformation_basis(corners: np.ndarray) -> np.ndarray:
    """Rows [V_0, V_1, V_2, n, b_0, b_1, b_2] of each deformed triangle, shape (T, 7, 3).

    Every region's image (eq. 1, 12, 13) is a combination of these rows: eq. 1 is
    (1 − α − β) o + α p + β q + h n', eq. 12 is (1 − x) v_j + x v_{j+1} + y b'_j + h n', and eq. 13 is
    v_j + h n' plus the rescaled in-plane part a b'_j + b b'_{j−1}. Runs every frame, so it uses
    component-wise cross products: `np.cross` set-up costs more than the arithmetic for ~100 triangles.
    """
    basis = np.empty((len(corners), 7, 3))
    basis[:, :3] = corners
    edges = corners[:, [1, 2, 0]] - corners
    normal = _unit_rows(_cross(edges[:, 0], corners[:, 2] - corners[:, 0]))  # eq. 3
    basis[:, 3] = normal
    basis[:, 4:] = _unit_rows(_cross(edges, normal[:, None, :]))
    return basis


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _unit_rows(vectors: np.ndarray) -> np.ndarray:
    """`unit` for the per-frame path: zero vectors (collapsed triangles) stay zero."""
    norms = np.sqrt(np.einsum("...k,...k->...", vectors, vectors))[..., None]
    return np.divide(vectors, norms, out=np.zeros_like(vectors), where=norms > 0.0)


@dataclass(frozen=True)
class Location:
    """Where points lie relative to one triangle's affection volume."""

    region: np.ndarray  # (n,) int8 region code
    distance: np.ndarray  # (n,) distance to the plane / edge line / apex of that region
    face_local: np.ndarray  # (n, 3) (α, β, h) = (S − O) A⁻¹, eq. 1 (used by SoFFD for every region)
    region_local: np.ndarray  # (n, 3) coordinates in the region's frame: A, B_j (eq. 10) or C_j (eq. 11)
    apex_distance: np.ndarray  # (n,) D_j(S) of eq. 14 for apex regions, 0 elsewhere


# eq. 4's cells by sign bits (u < 0, v < 0, w > 1): inside; across QO (u < 0); across OP (v < 0); behind O
# (u, v < 0); across PQ (w > 1); behind Q (u < 0, w > 1); behind P (v < 0, w > 1, whatever u)
_CELL_REGION = np.array([FACE, EDGE + 2, EDGE + 0, APEX + 0, EDGE + 1, APEX + 2, APEX + 1, APEX + 1], dtype=np.int8)


def locate(frames: TriangleFrames, t: int, points: np.ndarray) -> Location:
    """Region, distance and local coordinates of (n, 3) points for triangle t (eq. 4–7, 10, 11, 14).

    Eq. 4 as printed is read with (u, v) the coordinates of the projection in the affine frame
    (O; P − O, Q − O) and w = u + v, which is what makes "w ≤ 1" meaningful: u ≥ 0, v ≥ 0, w ≤ 1 is the
    inside. The printed conditions are kept, but the labels of its lines 3–6 are permuted in print; we
    label each cell by the edge it lies across or the apex it lies behind, so v < 0 (across OP) is
    R'_B,0, w > 1 (across PQ) is R'_B,1, u < 0 (across QO) is R'_B,2, and the corner cells behind O, P, Q
    are R'_C,0, R'_C,1, R'_C,2. Eq. 6 then picks the edge of the corner cell that the point projects
    onto, and eq. 5 is applied to that edge as well: the printed eq. 6 omits this clamp, which only
    matters behind an obtuse apex, where a point can project beyond the far end of the chosen edge.
    The result is the partition of space into the points nearest to the face, to each open edge and to
    each apex, so the distance below is the Euclidean point–triangle distance: continuous, and equal
    on both sides of every region boundary, as are the images of eq. 1, 12 and 13 there.
    """
    corners = frames.corners[t]
    origin = corners[0]
    unit_edges = frames.unit_edges[t]
    edge_normals = frames.edge_normals[t]
    lengths = frames.edge_lengths[t]
    probes = np.concatenate([frames.inverse_frames[t], unit_edges.T, edge_normals.T], axis=1)  # (3, 9), eq. 2
    projected = (points - origin) @ probes
    face_local = projected[:, :3]
    offsets = corners - origin
    along = projected[:, 3:6] - np.einsum("jk,jk->j", offsets, unit_edges)  # c_j(S), eq. 7
    outward = projected[:, 6:9] - np.einsum("jk,jk->j", offsets, edge_normals)  # (S − V_j) · b_j
    height = face_local[:, 2]

    u, v = face_local[:, 0], face_local[:, 1]
    # eq. 4 by the signs of u, v and 1 - w (w = u + v): bit 0 u < 0, bit 1 v < 0, bit 2 w > 1
    cell = (u < 0).view(np.int8) | ((v < 0).view(np.int8) << 1) | (((u + v) > 1).view(np.int8) << 2)
    region = _CELL_REGION[cell]

    corner = np.flatnonzero(region >= APEX)  # eq. 6
    i = region[corner] - APEX
    previous = (i + 2) % 3
    to_previous = along[corner, previous] <= lengths[previous]
    to_next = ~to_previous & (along[corner, i] >= 0)
    region[corner[to_previous]] = EDGE + previous[to_previous]
    region[corner[to_next]] = EDGE + i[to_next]

    edge = np.flatnonzero((region >= EDGE) & (region < APEX))  # eq. 5
    j = region[edge] - EDGE
    c = along[edge, j]
    region[edge] = np.where(c < 0, APEX + j, np.where(c > lengths[j], APEX + (j + 1) % 3, EDGE + j))

    # the face region's values are its own coordinates: only the other points (often the fewer) go on
    other = np.flatnonzero(region != FACE)
    k = (region[other].astype(np.intp) - 1) % 3  # feature index j of edge and apex regions
    k_previous = (k + 2) % 3
    is_apex = region[other] >= APEX
    c_k = along[other, k]
    y_k = outward[other, k]
    y_previous = outward[other, k_previous]
    apex_distance = np.zeros(len(points))
    apex_distance[other] = np.where(is_apex, np.hypot(c_k, y_k), 0.0)  # D_j(S) = ‖Π(S) − V_j‖, eq. 14

    # In-plane coordinates (a, b) of Π(S) − V_j on the non-orthogonal rows b_j, b_{j−1} of C_j (eq. 11),
    # from the dot products y_j, y_{j−1} and the Gram term g = b_j · b_{j−1}.
    g = np.einsum("jk,jk->j", edge_normals, np.roll(edge_normals, 1, axis=0))[k]
    gram = 1.0 - g * g
    a = (y_k - g * y_previous) / gram
    b = (y_previous - g * y_k) / gram

    region_local = face_local.copy()
    region_local[other, 0] = np.where(is_apex, a, c_k / lengths[k])  # e_j is un-normalised in B_j, eq. 10
    region_local[other, 1] = np.where(is_apex, b, y_k)

    distance = np.abs(height)
    distance[other] = np.hypot(height[other], np.where(is_apex, apex_distance[other], y_k))
    return Location(region, distance, face_local, region_local, apex_distance)


def distance_lower_bound(frames: TriangleFrames, t: int, points: np.ndarray) -> np.ndarray:
    """A cheap lower bound of the point–triangle distance, to skip `locate` for far points.

    The triangle lies in its plane and inside each edge's half-plane (S − V_j) · b_j ≤ 0, which are
    orthogonal, so its distance is at least √(h² + max(0, max_j (S − V_j) · b_j)²); it is exact for points
    in the face region and for points beside an edge whose projection falls within the edge.
    """
    normal = frames.normals[t]
    edge_normals = frames.edge_normals[t]
    probes = np.concatenate([normal[:, None], edge_normals.T], axis=1)  # (3, 4)
    corners = frames.corners[t]
    offsets = np.concatenate([[corners[0] @ normal], np.einsum("jk,jk->j", corners, edge_normals)])
    projected = points @ probes - offsets
    # the largest of the three edge columns, column by column (a max along axis 1 of an (n, 3) array is
    # several times slower in numpy)
    beyond = np.maximum(np.maximum(projected[:, 1], projected[:, 2]), projected[:, 3])
    return np.hypot(projected[:, 0], np.maximum(beyond, 0.0, out=beyond), out=beyond)


def affection_weight(distance: np.ndarray, radius: float, exponent: float) -> np.ndarray:
    """Eq. 9: (½(1 + cos(π d / r)))ⁿ inside the affection radius r, 0 outside."""
    if radius <= 0.0:
        return np.zeros_like(distance)
    inside = distance < radius
    ratio = np.where(inside, distance / radius, 1.0)
    return np.where(inside, (0.5 * (1.0 + np.cos(np.pi * ratio))) ** exponent, 0.0)
