"""A welded mouth's height from its corners: the commissures are pits in the skin.

Where the lips are one surface (a voxel remesh or a sculpt fused them; no opening in the mesh, no slit between
them: `openings` and `slit` read nothing), nothing along the mouth marks the lips' line, and the registration
can leave the whole mouth slid up or down the face along smooth skin (the development heads' voxel-remeshed
mouths: 1.5-2.2 mm high with the left-out prior, docs/auto_placement.md). The mouth's ends still show: at each
corner the lips' bulges meet the cheek in a pit, the commissure, which is the skin's most concave point there
(the least local height, `features.local_height`, over a ball about a lip's height across). The corners' pits
give the mouth's height at its two ends; the mouth's points (the inner and outer lip contours and the corners)
are moved up or down together by the mean of the two corners' vertical offsets from their pits, so a mouth that
slid is put back at the height its corners say and keeps the shape the registration gave it (the same shift on
both sides: a symmetric placement stays symmetric). Only the height is taken: the pit is on the skin, where a
welded mouth's inner corner 2.4/2.5 lies inside it, behind the pit.

A pit is a pit only when it is concave (negative local height) and deeper than all the skin a half of REACH
further round (`commissure`): a convex or smooth corner region, or a deepest point at the edge of the looked-at
ball (still going down, outside), moves nothing.
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .features import local_height
from .surface import Surface, area_samples

REACH = 0.006  # template metres: a corner's pit is looked for this near the carried corner
RADIUS = 0.006  # template metres: the local height's ball, about a lip's height
SAMPLES = 6000  # area samples of the skin round a corner (about 0.3 mm apart)
CORNERS = ("2.4", "2.5")
MOUTH = ("2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9") + tuple(f"8.{k}" for k in range(1, 11))


def commissure(surface: Surface, guess: np.ndarray) -> np.ndarray | None:
    """The skin's most concave point (least local height over a RADIUS ball) within REACH of `guess`, when it is
    concave and no skin within half as far again is deeper; else None."""
    wider = 1.5 * REACH
    near = surface.tree.query_ball_point(guess, wider + RADIUS)
    if not near:
        return None
    around = np.isin(surface.triangles, near).any(axis=1)
    samples, normals = area_samples(surface.vertices, surface.triangles[around], SAMPLES)
    distance = np.linalg.norm(samples - guess, axis=1)
    looked = distance <= wider
    if not looked.any():
        return None
    heights = local_height(samples[looked], normals[looked], samples, RADIUS)
    deepest = int(np.argmin(heights))
    if heights[deepest] >= 0.0 or distance[looked][deepest] > REACH:
        return None
    return samples[looked][deepest]


def mouth_height(placed: np.ndarray, surface: Surface, up: np.ndarray) -> tuple[np.ndarray, float | None]:
    """`placed` (84, 3) with the mouth's points moved along `up` by the mean offset of the corners 2.4/2.5 from
    their pits (`commissure`) and snapped onto the skin; and that offset (None when no corner has a pit: nothing
    moves)."""
    offsets = []
    for fp_id in CORNERS:
        corner = placed[fp_index(fp_id)]
        pit = commissure(surface, corner)
        if pit is not None:
            offsets.append(float((pit - corner) @ up))
    if not offsets:
        return placed, None
    shift = float(np.mean(offsets))
    placed = placed.copy()
    rows = [fp_index(fp_id) for fp_id in MOUTH]
    placed[rows], _normals = surface.closest(placed[rows] + shift * up)
    return placed, shift
