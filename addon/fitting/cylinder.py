"""The cylinder a face is unrolled on (Escher et al. §3.1.1, §3.2, §3.3).

The paper projects the generic face, the given FPs and the calibration mesh onto a cylinder around the
head's vertical axis but does not say where that axis is. Our reading: the axis is the face frame's up
axis through the middle of the bounding box (in the face frame) of the points that define the face
(the FPs when only FPs are known, the mesh vertices when there is a mesh), and the radius is their mean
distance from it. Both are equivariant: a moved, turned or scaled face gets the moved, turned or scaled
cylinder, so two faces are unrolled the same way. The seam (angle +-pi) is at the back of the head.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.cylindrical import cylindrical_projection
from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.feature_points import feature_point
from .errors import FeaturePointError

# The FPs a cylinder around the head can unroll: those on its outer surface (not the teeth, the tongue or
# 7.1 inside the head) and away from the axis, where the angle is arbitrary (the skull top 11.4 and 11.5
# sit on it). Our reading of "all the feature points of the generic face" (§3.1.1).
OUTER_SURFACES = frozenset({"skin", "eye", "ear", "hair"})
AXIS_FRACTION = 0.2


def on_outer_surface(fp_id: str) -> bool:
    return feature_point(fp_id).surface in OUTER_SURFACES


@dataclass(frozen=True)
class FaceCylinder:
    centre: np.ndarray  # (3,) a point on the axis, mesh coordinates
    axes: np.ndarray  # (3, 3) rows: the face's left, up, forward in mesh coordinates
    radius: float  # arc length per radian

    @classmethod
    def around(cls, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES, what: str = "face") -> FaceCylinder:
        axes = np.asarray(axes, dtype=np.float64)
        local = np.asarray(points, dtype=np.float64) @ axes.T
        centre_local = 0.5 * (local.min(axis=0) + local.max(axis=0))
        radius = float(np.mean(np.hypot(*(local - centre_local)[:, [0, 2]].T)))
        if not radius > 0.0:
            raise FeaturePointError(f"{what}: the points lie on the vertical axis; nothing to unroll on a cylinder")
        return cls(centre=centre_local @ axes, axes=axes, radius=radius)

    @property
    def period(self) -> float:
        """Arc length once around the head (2 pi r)."""
        return 2.0 * np.pi * self.radius

    def project(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) mesh points -> (n, 2) (arc length toward the face's left, height above the centre)."""
        return cylindrical_projection(points, self.centre, self.axes, self.radius)

    def axis_distance(self, points: np.ndarray) -> np.ndarray:
        """(n,) horizontal distance of mesh points from the axis."""
        local = (np.asarray(points, dtype=np.float64) - self.centre) @ self.axes.T
        return np.hypot(local[:, 0], local[:, 2])

    def unrollable(self, ids: tuple[str, ...] | list[str], points: np.ndarray) -> list[int]:
        """Rows of the FPs `ids` at `points` that this cylinder unrolls (outer surface, off the axis)."""
        distance = self.axis_distance(np.asarray(points).reshape(-1, 3))
        reach = AXIS_FRACTION * self.radius
        return [row for row, fp_id in enumerate(ids) if on_outer_surface(fp_id) and distance[row] >= reach]

    def rays(self, projected: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Origins on the axis and horizontal unit directions of the rays that project to (n, 2) points."""
        projected = np.asarray(projected, dtype=np.float64)
        angle = projected[:, 0] / self.radius
        left, up, forward = self.axes
        origins = self.centre + projected[:, 1:2] * up
        directions = np.sin(angle)[:, None] * left + np.cos(angle)[:, None] * forward
        return origins, directions

    def unwrap(self, projected: np.ndarray, near_angle: np.ndarray) -> np.ndarray:
        """`projected` with each arc length moved by whole turns so its angle is within pi of `near_angle`.

        Matches another face's unrolling across the seam: the back of one head may land at +pi, the
        other's at -pi.
        """
        out = np.array(projected, dtype=np.float64)
        turns = np.round((np.asarray(near_angle) - out[:, 0] / self.radius) / (2.0 * np.pi))
        out[:, 0] += self.period * turns
        return out
