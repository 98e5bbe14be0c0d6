"""Where a vertical line crosses triangles seen from the front, and which stretches of it they leave open (no bpy).

A face seen straight on is its triangles projected along the face's z axis; a vertical line at x through them
crosses each triangle it meets over one interval of y. What a viewer sees through the skin along that line (an
eye's opening between the lids) is what those intervals leave uncovered.
"""

from __future__ import annotations

import numpy as np


def column_cuts(corners: np.ndarray, x: float) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and the highest point (S, C - 1) at which the line at `x` crosses each of the triangles `corners`
    (T, 3, C: x, y and any further coordinates, C >= 2) it meets: y first, the further coordinates at that point
    after it."""
    corners = np.asarray(corners, dtype=np.float64)
    lows = np.full((len(corners), corners.shape[2] - 1), np.inf)
    highs = np.full_like(lows, -np.inf)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        xa, xb = corners[:, a, 0], corners[:, b, 0]
        cut = (np.minimum(xa, xb) <= x) & (np.maximum(xa, xb) >= x) & (xa != xb)
        t = np.divide(x - xa, xb - xa, out=np.zeros_like(xa), where=cut)[:, None]
        point = corners[:, a, 1:] + t * (corners[:, b, 1:] - corners[:, a, 1:])
        lows = np.where((cut & (point[:, 0] < lows[:, 0]))[:, None], point, lows)
        highs = np.where((cut & (point[:, 0] > highs[:, 0]))[:, None], point, highs)
    hit = np.isfinite(lows[:, 0])
    return lows[hit], highs[hit]


def column_gaps(lows: np.ndarray, highs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The stretches of the line the crossings (`column_cuts`) leave open between them: (G, C - 1) the point
    below each gap (the top of the crossings under it) and (G, C - 1) the point above it (the bottom of the
    crossing over it), bottom to top; nothing below the lowest crossing or above the highest."""
    order = np.argsort(lows[:, 0], kind="stable")
    lows, highs = lows[order], highs[order]
    top = np.maximum.accumulate(highs[:, 0])  # the covered run's top up to each crossing
    below = highs[np.maximum.accumulate(np.where(highs[:, 0] >= top, np.arange(len(top)), 0))]
    gap = np.flatnonzero(lows[1:, 0] > top[:-1])
    return below[gap], lows[gap + 1]
