"""Fitting's input checks: a set of feature points (checked, in table order, its coincident groups) and a mesh.

Every fitting step receives FPs as a mapping FP id -> (3,) position (mesh coordinates, metres) and
checks it here first, so a bad set is refused before any work with a message naming the FP.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..mpeg4.feature_points import FP_IDS, fp_index
from .errors import FeaturePointError, FittingError

# FPs closer than this fraction of their set's bounding-box diagonal count as one place. The sample
# head's 11.4 and 11.5 (hair thickness over a bald skull) coincide exactly.
COINCIDENT_FRACTION = 1e-6


def fp_array(positions: Mapping[str, object], what: str, dimension: int = 3) -> tuple[tuple[str, ...], np.ndarray]:
    """(ids in table order, (n, dimension) float64) from a mapping FP id -> position; `what` names the set."""
    if not isinstance(positions, Mapping):
        raise FeaturePointError(f"{what}: feature points must be a mapping FP id -> position")
    unknown = sorted(str(fp_id) for fp_id in positions if fp_id not in FP_IDS)
    if unknown:
        raise FeaturePointError(f"{what}: unknown MPEG-4 feature point(s) {', '.join(map(repr, unknown))}")
    ids = tuple(sorted(positions, key=fp_index))
    points = np.empty((len(ids), dimension))
    for row, fp_id in enumerate(ids):
        try:
            value = np.asarray(positions[fp_id], dtype=np.float64)
        except (TypeError, ValueError):
            raise FeaturePointError(f"{what}: FP {fp_id} is not a list of {dimension} numbers") from None
        if value.shape != (dimension,):
            raise FeaturePointError(f"{what}: FP {fp_id} has shape {value.shape}, expected ({dimension},)")
        if not np.all(np.isfinite(value)):
            raise FeaturePointError(f"{what}: FP {fp_id} is not finite ({value.tolist()})")
        points[row] = value
    return ids, points


def extent(points: np.ndarray) -> float:
    """Bounding-box diagonal (0 for fewer than two points)."""
    return float(np.linalg.norm(np.ptp(points, axis=0))) if len(points) > 1 else 0.0


def coincident_groups(ids: tuple[str, ...], points: np.ndarray) -> list[tuple[str, ...]]:
    """Groups (table order, two or more ids) of FPs within COINCIDENT_FRACTION of the set's extent."""
    tolerance = COINCIDENT_FRACTION * extent(points)
    gaps = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    close = gaps <= tolerance
    groups, seen = [], set()
    for row in range(len(ids)):
        if row in seen:
            continue
        members = np.flatnonzero(close[row])
        seen.update(members.tolist())
        if len(members) > 1:
            groups.append(tuple(ids[m] for m in members))
    return groups


def require_spatial(ids: tuple[str, ...], points: np.ndarray, what: str) -> None:
    """Refuse fewer than 4 FPs, or FPs that all lie in one plane (no 3D affine fit, no tetrahedra)."""
    if len(ids) < 4:
        raise FeaturePointError(f"{what}: {len(ids)} feature point(s) ({', '.join(ids)}); at least 4 are needed")
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if singular[2] <= 1e-9 * singular[0]:
        raise FeaturePointError(f"{what}: the feature points {', '.join(ids)} lie in one plane; 3D fitting needs depth")


def check_vertices(vertices: np.ndarray, what: str) -> np.ndarray:
    """(N, 3) finite float64 vertices, N >= 1, or a FittingError naming the first bad one."""
    vertices = np.asarray(vertices, dtype=np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or not len(vertices):
        raise FittingError(f"{what}: vertices must be an (N, 3) array with N >= 1, got shape {vertices.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(vertices), axis=1))
    if len(bad):
        raise FittingError(f"{what}: vertex {bad[0]} is not finite ({len(bad)} such vertices)")
    return vertices
