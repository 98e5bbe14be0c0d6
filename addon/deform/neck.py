"""Head turns on a head that sits on a body: the head turns, the neck follows in part, the shoulders stay (no bpy).

Head rotation (FAPs 48-50) turns the whole face object about FP 7.1 (head_motion.py): right for a head on its
own. On a mesh with a body, each vertex is then turned back by the share of the turn it must not take,
1 - w, where w is its head-turn weight: 1 on the head down to the chin's height, 0 from NECK_LENGTHS chin
heights below FP 7.1 down, smooth between (an editable vertex group). The turn back is about the same axis and
pivot by (1 - w) times the angle, so the neck twists smoothly instead of shrinking as a blend of positions
would. The weight also fades with the distance from the vertical line through 7.1, from 1 at SIDE_START to 0 at
SIDE_END chin heights: a character in a T-pose has its arms at the neck's height, and a share of the head's turn
swung them (the Rocketbox male's arms, 87 cm out, moved 24 cm and turned 519 faces over in the demo's head turns).
A head reaches at most 2.1 chin heights from that line (the sample and the Rocketbox head, ears included), so the
head is not touched. A mesh with no vertex where w is 0 is a head on its own: it gets no weights and turns whole,
as before.
"""

from __future__ import annotations

import numpy as np

NECK_LENGTHS = 2.5  # x the chin's height below 7.1: where the body starts (weight 0)
SIDE_START, SIDE_END = 2.5, 4.0  # x the chin's height from the vertical through 7.1: the weight fades between


def head_turn_weights(rest: np.ndarray, axes: np.ndarray, spine: np.ndarray, chin: np.ndarray) -> np.ndarray | None:
    """(N,) head-turn weights of the rest mesh, or None for a head without a body (or without 7.1 and 2.1)."""
    if not (np.all(np.isfinite(spine)) and np.all(np.isfinite(chin))):
        return None
    up = np.asarray(axes, dtype=np.float64)[1]
    drop = float((spine - chin) @ up)
    if drop <= 0.0:
        return None
    offset = np.asarray(rest, dtype=np.float64) - spine
    height = offset @ up  # 0 at 7.1, -drop at the chin
    side = np.linalg.norm(offset - np.outer(height, up), axis=1)
    t = np.clip((height + NECK_LENGTHS * drop) / ((NECK_LENGTHS - 1.0) * drop), 0.0, 1.0)
    u = np.clip((SIDE_END * drop - side) / ((SIDE_END - SIDE_START) * drop), 0.0, 1.0)
    weights = t * t * (3.0 - 2.0 * t) * (u * u * (3.0 - 2.0 * u))
    return weights if (weights == 0.0).any() else None


def turn_back(out: np.ndarray, vertices: np.ndarray, share: np.ndarray, turn: np.ndarray, pivot: np.ndarray) -> None:
    """Turn `out[vertices]` (mesh coordinates, in place) about `pivot` by `share` (K,) times the inverse of the
    head's turn `turn` (3, 3), each vertex by its own share of the angle (Rodrigues' formula). A vertex that takes the
    whole turn back (share 1: the body, most of a full figure's vertices) is turned by the inverse itself, `turn`
    transposed, in one product (the Rocketbox's 14,500 of 15,600: 4.2 ms a frame by Rodrigues, 0.4 ms so)."""
    cos = np.clip((np.trace(turn) - 1.0) / 2.0, -1.0, 1.0)
    angle = float(np.arccos(cos))
    if angle == 0.0 or len(vertices) == 0:
        return
    axis = np.array([turn[2, 1] - turn[1, 2], turn[0, 2] - turn[2, 0], turn[1, 0] - turn[0, 1]])
    norm = np.linalg.norm(axis)
    if norm < 1e-12:  # a half turn: no head does that
        return
    axis /= norm
    p = out.take(vertices, axis=0).astype(np.float64) - pivot  # take: 2x faster than out[vertices]
    turned = p @ np.asarray(turn, dtype=np.float64)  # row vectors: turn^T p, the whole turn back
    partial = np.flatnonzero(share != 1.0)
    if len(partial):
        q = p[partial]
        theta = -share[partial] * angle
        c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
        x, y, z = axis
        across = np.stack([y * q[:, 2] - z * q[:, 1], z * q[:, 0] - x * q[:, 2], x * q[:, 1] - y * q[:, 0]], axis=1)
        turned[partial] = q * c + across * s + (q @ axis)[:, None] * axis * (1.0 - c)
    out[vertices] = turned + pivot
