"""Fold-overs: faces of a deformed mesh that have turned over relative to the rest pose.

A deformer folds the skin where neighbouring vertices move so differently that a face's normal turns by
more than 90°: the face then shows its back, a crease or a spike. `inverted_faces` finds them by the sign
of the dot product of each face's rest and deformed normal; a polygon counts as folded when any triangle
of its fan does (a fan is what a renderer may draw of it). Faces of zero area at rest have no normal and
are never counted.
"""

from __future__ import annotations

import numpy as np

from .inputs import DeformError, check_points


def fan_triangles(face_sizes: np.ndarray, corner_vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Polygons as fans: (K, 3) vertex triples and (K,) the polygon of each.

    ``face_sizes`` (F,) are the corner counts (at least 3) and ``corner_vertices`` (Σ sizes,) the corners'
    vertices polygon after polygon, as Blender's `loop_total` and loops' `vertex_index` give them.
    """
    sizes = np.asarray(face_sizes, dtype=np.intp)
    corners = np.asarray(corner_vertices, dtype=np.intp)
    if sizes.ndim != 1 or corners.ndim != 1 or (sizes.size and sizes.min() < 3) or sizes.sum() != len(corners):
        raise DeformError("faces need at least 3 corners each, and as many corner vertices as their sizes add up to")
    start = np.cumsum(sizes) - sizes
    owner = np.repeat(np.arange(len(sizes)), sizes - 2)
    step = np.arange(len(owner)) - np.repeat(np.cumsum(sizes - 2) - (sizes - 2), sizes - 2)  # 0.. size-3
    first = start[owner]
    triangles = np.stack([corners[first], corners[first + step + 1], corners[first + step + 2]], axis=1)
    return triangles, owner


def inverted_faces(
    rest: np.ndarray, deformed: np.ndarray, triangles: np.ndarray, owner: np.ndarray | None = None
) -> np.ndarray:
    """(F,) True for the faces whose deformed normal points against their rest normal.

    ``triangles`` (K, 3) index the (N, 3) positions; ``owner`` (K,) gives each triangle's face (from
    `fan_triangles`; default: each triangle is a face).
    """
    rest = check_points(rest, "rest")
    deformed = check_points(deformed, "deformed")
    if deformed.shape != rest.shape:
        raise DeformError(f"deformed has shape {deformed.shape}, rest {rest.shape}")
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    if triangles.size and (triangles.min() < 0 or triangles.max() >= len(rest)):
        raise DeformError(f"triangle indices must lie in [0, {len(rest)})")
    owner = np.arange(len(triangles)) if owner is None else np.asarray(owner, dtype=np.intp)
    if owner.shape != (len(triangles),):
        raise DeformError("owner must give one face per triangle")

    def normals(points: np.ndarray) -> np.ndarray:
        a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
        return np.cross(b - a, c - a)

    flipped = np.einsum("ij,ij->i", normals(rest), normals(deformed)) < 0.0
    n_faces = int(owner.max()) + 1 if len(owner) else 0
    return np.bincount(owner[flipped], minlength=n_faces) > 0


def count_inverted(
    rest: np.ndarray, deformed: np.ndarray, triangles: np.ndarray, owner: np.ndarray | None = None
) -> int:
    """How many faces `inverted_faces` finds."""
    return int(np.count_nonzero(inverted_faces(rest, deformed, triangles, owner)))
