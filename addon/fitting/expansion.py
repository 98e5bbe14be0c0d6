"""The "expanded" Delaunay triangulation of unrolled feature points (Escher et al. §3.2, Figure 5).

The Delaunay triangulation of the unrolled FPs leaves much of the head outside (Figure 4). The paper
duplicates the FPs "on the left and right side by a horizontal shift" and fills "the upper and lower
parts ... with 2 duplications each, using a horizontal symmetry", which "approximate[s] a spherical
projection"; every vertex then lies in a triangle. The figure is lost in our copy, so the readings:

- left and right: the FPs shifted by one period (2 pi r, once around the head), so the triangulation
  wraps around the back of the head continuously;
- above and below: the FPs mirrored about a horizontal line MARGIN of the FPs' height range above the
  highest FP (resp. below the lowest) and shifted by half a period. Two copies each (shifts -1/2 and
  +1/2) are the "2 duplications"; the half-period shift is what going over a sphere's pole does (one
  comes down on the opposite side), which is the spherical approximation the paper names, and it spans
  the full width. The margin keeps every copy off the originals (mirrored exactly at the highest FP,
  a copy would land on an FP half a turn away at that height). The lines come from the FPs alone, so
  two faces' expansions correspond (§3.3). The expanded triangulation covers everything between the
  two lines all the way round, and most of what lies beyond (the copies reach up to one FP height range
  further); a vertex outside it takes the nearest point of its boundary.

Each expanded point is an original FP with a copy operation, and the same operation can be applied to
values attached to the FPs (`expand_values`): texture coordinates are copied unchanged, while another
face's unrolled FPs are shifted and mirrored with that face's own period and lines (§3.3).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import FeaturePointError
from .plane_triangulation import locate, triangulate

if TYPE_CHECKING:
    from scipy.spatial import Delaunay

MARGIN = 0.1  # of the FPs' height range, between the highest (lowest) FP and the mirror line
# (shift in periods, mirror) of each copy; mirror 0 = none, +1 = about the top line, -1 = the bottom one
COPIES = ((0.0, 0), (-1.0, 0), (1.0, 0), (-0.5, 1), (0.5, 1), (-0.5, -1), (0.5, -1))
COPY_NAMES = ("", "left", "right", "above, left", "above, right", "below, left", "below, right")


@dataclass(frozen=True)
class Band:
    """Where a face is unrolled: its period and the two horizontal mirror lines."""

    period: float
    bottom: float
    top: float

    @classmethod
    def of(cls, period: float, unrolled_fps: np.ndarray) -> Band:
        """The band of (n, 2) unrolled FPs: mirror lines MARGIN beyond the lowest and the highest."""
        heights = np.asarray(unrolled_fps)[:, 1]
        margin = MARGIN * float(np.ptp(heights))
        return cls(period=float(period), bottom=float(heights.min()) - margin, top=float(heights.max()) + margin)


def expand_values(values: np.ndarray, band: Band) -> np.ndarray:
    """(len(COPIES) * n, 2) the unrolled points `values` under every copy operation, originals first."""
    values = np.asarray(values, dtype=np.float64)
    copies = []
    for shift, mirror in COPIES:
        copy = values.copy()
        copy[:, 0] += shift * band.period
        if mirror:
            line = band.top if mirror > 0 else band.bottom
            copy[:, 1] = 2.0 * line - copy[:, 1]
        copies.append(copy)
    return np.concatenate(copies)


@dataclass(frozen=True)
class ExpandedTriangulation:
    triangulation: Delaunay  # over expand_values(points, band)
    n: int  # number of original points

    @classmethod
    def build(cls, points: np.ndarray, labels: Sequence[str], band: Band, what: str) -> ExpandedTriangulation:
        points = np.asarray(points, dtype=np.float64)
        spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False) if len(points) >= 3 else None
        if spread is None or spread[1] <= 1e-9 * spread[0]:
            raise FeaturePointError(
                f"{what}: {len(points)} point(s) ({', '.join(labels) or 'none'}); at least 3 not on one line are needed"
            )
        every = [f"{label} ({name})" if name else label for name in COPY_NAMES for label in labels]
        return cls(triangulate(expand_values(points, band), every, what), len(points))

    def locate(self, queries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(expanded point indices (m, 3), barycentric weights (m, 3)) of each query point.

        Indices run over `expand_values(...)`; `% n` gives the original FP. A point that rounding puts
        just outside the expanded hull takes its nearest boundary point.
        """
        corners, weights, _ = locate(self.triangulation, queries)
        return corners, weights

    def original_triangles(self) -> np.ndarray:
        """(T, 3) triangles (indices of original points) whose corners are all uncopied FPs."""
        simplices = self.triangulation.simplices
        return simplices[np.all(simplices < self.n, axis=1)]
