"""Cylindrical projection of points around a head's vertical axis (Escher et al., section 3).

A head is roughly a cylinder about its up axis, so (angle around that axis x radius, height) unrolls
the face into a plane where a 2D triangulation or interpolation of its feature points is well shaped.
The seam (angle +-pi) is put at the back of the head.
"""

from __future__ import annotations

import numpy as np

from .face_axes import BLENDER_FACE_AXES


def cylindrical_projection(
    points: np.ndarray, centre: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES, radius: float | None = None
) -> np.ndarray:
    """(n, 3) mesh-space points -> (n, 2) (arc length around the up axis, height).

    `centre` is a point on the cylinder's axis, `axes` the face frame (rows: left, up, forward).
    Angle 0 is straight ahead; arc length uses `radius` (default: mean horizontal distance to the axis).
    """
    rel = (np.asarray(points, dtype=np.float64) - np.asarray(centre, dtype=np.float64)) @ np.asarray(axes).T
    angle = np.arctan2(rel[:, 0], rel[:, 2])
    if radius is None:
        radius = float(np.mean(np.hypot(rel[:, 0], rel[:, 2]))) or 1.0
    return np.stack([angle * radius, rel[:, 1]], axis=1)
