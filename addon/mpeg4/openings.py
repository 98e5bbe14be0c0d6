"""The face's openings (mouth, eyes) in feature point terms, and the control mesh of an incomplete FP set.

Motion must not cross the mouth or the eye openings (paper 000, section 3): no control triangle may join
a point above an opening to one below it, and the triangles on each side are limited by a mask
(upper_lip, lower_lip, upper_eyelid, lower_eyelid) so their affection volumes stop at the opening.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..geometry.cylindrical import cylindrical_projection
from ..geometry.delaunay import delaunay
from .frame import BLENDER_FACE_AXES

UPPER_LIP = frozenset({"2.2", "2.6", "2.7", "8.1", "8.5", "8.6", "8.9", "8.10"})
LOWER_LIP = frozenset({"2.3", "2.8", "2.9", "8.2", "8.7", "8.8"})
UPPER_EYELID = frozenset({"3.1", "3.2", "3.13", "3.14"})
LOWER_EYELID = frozenset({"3.3", "3.4", "3.9", "3.10"})
OPENINGS = ((UPPER_LIP, LOWER_LIP), (UPPER_EYELID, LOWER_EYELID))
MASK_SETS = {"upper_lip": UPPER_LIP, "lower_lip": LOWER_LIP, "upper_eyelid": UPPER_EYELID, "lower_eyelid": LOWER_EYELID}
MASK_NAMES = tuple(MASK_SETS)


def spans_opening(ids) -> bool:
    """True when a triangle's FP ids lie on both sides of the mouth or of an eye."""
    s = set(ids)
    return any(s & upper and s & lower for upper, lower in OPENINGS)


def triangle_mask(ids) -> str | None:
    """The mask limiting a triangle that touches one side of an opening (None elsewhere)."""
    s = set(ids)
    for name, members in MASK_SETS.items():
        if s & members:
            return name
    return None


def triangulate_present(
    positions: Mapping[str, np.ndarray], centre: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES
) -> tuple[list[str], np.ndarray, list[str | None]]:
    """Control mesh over whichever FPs are present: Delaunay in a cylindrical projection about `centre`.

    Returns the FP ids (vertex order), (T, 3) triangles with outward normals, and each triangle's mask.
    Triangles across the mouth or an eye are dropped. Points that coincide on the neutral face (closed
    lips) are separated by a hair in the projection only, upper side up, so both stay in the mesh.
    """
    ids = sorted(positions, key=lambda s: tuple(int(p) for p in s.split(".")))
    pts = np.array([positions[i] for i in ids], dtype=np.float64)
    uv = cylindrical_projection(pts, centre, axes)
    span = float(np.ptp(uv, axis=0).max()) or 1.0
    key = np.round(uv / (1e-9 * span))
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    for k in np.flatnonzero(first[inverse.ravel()] != np.arange(len(ids))):
        uv[k, 1] += (1e-6 if ids[k] in UPPER_LIP | UPPER_EYELID else -1e-6) * span
    tris = delaunay(uv)
    keep = [t for t in tris if not spans_opening(ids[k] for k in t)]
    tris = np.array(keep, dtype=np.int64).reshape(-1, 3)
    # the projection is seen from outside (angle grows toward the face's left), so counter-clockwise in
    # (arc, height) is counter-clockwise seen from the front: normals face out of the head
    return ids, tris, [triangle_mask(ids[k] for k in t) for t in tris]
