"""Mirror pairs as mirror images: the face's own mid-plane from the placed points, each pair made the mirror
image of itself across it, mid-line points put on it, then every skin point snapped back onto the skin.

A face is symmetric to within its own asymmetry; a registration's errors are not (the template slides one
way on one cheek and another on the other). The mid-plane is the least-squares plane through the mid-line
points and the pairs' midpoints, its normal the mean direction from each pair's right point to its left;
averaging each pair with its mirror image halves the independent error of its two points, and snapping
afterwards onto the user's skin keeps whatever asymmetry the skin itself has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mpeg4.feature_points import FEATURE_POINTS, fp_index
from .scipy_modules import cKDTree

SYMMETRY_STEPS = 40  # at most this many ICP steps register the mirrored points back onto the points
CONVERGED = 1e-5  # radians: an ICP step turning less than this ends the registration
SYMMETRY_KEEP = 0.8  # share of the closest pairs kept (the rest: the surface's own asymmetry, its edges)


@dataclass(frozen=True)
class MidPlane:
    normal: np.ndarray  # (3,) unit, pointing to the face's left
    offset: float  # the plane: normal . x = offset

    def reflect(self, points: np.ndarray) -> np.ndarray:
        return points - 2.0 * (points @ self.normal - self.offset)[..., None] * self.normal

    def project(self, points: np.ndarray) -> np.ndarray:
        return points - (points @ self.normal - self.offset)[..., None] * self.normal


def _pairs() -> tuple[np.ndarray, np.ndarray]:
    """Rows of the (left, right) FP pairs, each pair once."""
    left = [fp_index(fp.id) for fp in FEATURE_POINTS if fp.side == "L" and fp.mirror]
    right = [fp_index(FEATURE_POINTS[row].mirror) for row in left]
    return np.array(left), np.array(right)


def _mid_line(rows: np.ndarray) -> np.ndarray:
    return np.array([row for row in rows if FEATURE_POINTS[row].side == "mid"], dtype=np.int64)


def mid_plane(points: np.ndarray, rows: np.ndarray) -> MidPlane:
    """The mid-plane through `points` (84, 3), from the pairs and mid-line points among `rows`."""
    left, right = _pairs()
    keep = np.isin(left, rows) & np.isin(right, rows)
    left, right = left[keep], right[keep]
    across = points[left] - points[right]
    length = np.linalg.norm(across, axis=1, keepdims=True)
    normal = (across / np.where(length > 0, length, np.inf)).sum(axis=0)  # a pair on one point has no direction
    normal /= np.linalg.norm(normal)
    on_plane = np.vstack([0.5 * (points[left] + points[right]), points[_mid_line(rows)]])
    return MidPlane(normal, float(np.mean(on_plane @ normal)))


def symmetrise(points: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, MidPlane]:
    """`points` (84, 3) with the pairs among `rows` made mirror images and its mid-line points among `rows`
    put on the mid-plane; the other rows unchanged."""
    plane = mid_plane(points, rows)
    result = points.copy()
    left, right = _pairs()
    keep = np.isin(left, rows) & np.isin(right, rows)
    left, right = left[keep], right[keep]
    result[left] = 0.5 * (points[left] + plane.reflect(points[right]))
    result[right] = plane.reflect(result[left])
    mid = _mid_line(rows)
    result[mid] = plane.project(points[mid])
    return result, plane


def surface_mid_plane(points: np.ndarray, normals: np.ndarray, start: MidPlane) -> MidPlane:
    """The plane a face's surface samples `points` (K, 3), with unit `normals`, are most nearly
    mirror-symmetric about, from a `start` near it: the points mirrored in `start` are registered rigidly
    back onto the points (trimmed point-to-plane ICP, Chen and Medioni 1992, linearised rotation), which
    makes the registration composed with the mirroring a mirroring in the surface's own plane; each point
    and its image under that are a mirror pair, and the plane is the least-squares one through the pairs'
    midpoints, normal to their main direction."""
    tree = cKDTree(points)
    mirrored = start.reflect(points)
    moved = mirrored
    for _step in range(SYMMETRY_STEPS):
        distance, index = tree.query(moved)
        keep = distance <= np.quantile(distance, SYMMETRY_KEEP)
        target, normal = points[index[keep]], normals[index[keep]]
        rows = np.hstack([np.cross(moved[keep], normal), normal])
        step, *_rest = np.linalg.lstsq(rows, ((target - moved[keep]) * normal).sum(1), rcond=None)
        rotation = _rotation(step[:3])
        moved = moved @ rotation.T + step[3:]
        if np.linalg.norm(step[:3]) < CONVERGED:
            break
    across = (points - moved)[keep]
    axis = np.linalg.eigh(across.T @ across)[1][:, -1]
    axis = axis if axis @ start.normal > 0 else -axis
    return MidPlane(axis, float(np.mean(0.5 * (points + moved)[keep] @ axis)))


def _rotation(omega: np.ndarray) -> np.ndarray:
    """The rotation by the vector `omega` (axis times angle, radians), by Rodrigues' formula."""
    angle = float(np.linalg.norm(omega))
    if angle < 1e-15:
        return np.eye(3)
    k = omega / angle
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross
