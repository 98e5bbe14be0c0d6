"""Teeth points from the pieces in the mouth, by the points' definitions once the pieces are found.

The FDP table (ISO/IEC 14496-2, annex C) says: 9.8 / 9.10 the top / bottom of the upper teeth in the
middle, 9.11 / 9.9 the top / bottom of the lower teeth in the middle, 6.2 the centre of the tongue body and
6.3 / 6.4 its left / right border. The registration's estimates find the pieces (each point snaps onto the
nearest piece within reach, `pipeline.PART_REACH`), but with the teeth closed an upper tooth's estimate may
reach the lower teeth first, and an end of a piece lies wherever that piece ends, which an estimate carried
from another head does not know. So the pieces are told apart by their places (of the pieces the teeth
estimates reached, the highest is the upper teeth, the lowest the lower; a single piece belongs to the pair
whose estimates are nearer its ends) and the ends are read off each piece: its front (within FRONT of its
most forward point) on the mid-plane (within MID of it), highest and lowest. The sample's FP table puts
them the same way (`scripts/sample/makehuman/fp_rules.py`). The tongue's points stay snapped where their
estimates reached (its borders read off the piece the same way put them 5-24 mm off on the development
heads: the tongue piece was not told apart reliably).
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .symmetry import MidPlane

FRONT = 0.005  # template metres
MID = 0.002  # template metres
TEETH = ("9.8", "9.9", "9.10", "9.11")


def teeth_ends(vertices: np.ndarray, plane: MidPlane, up: np.ndarray, forward: np.ndarray):
    """(top, bottom) of a teeth piece's front on the mid-plane, or None when none of it is that near."""
    on_mid = vertices[np.abs(vertices @ plane.normal - plane.offset) <= MID]
    if not len(on_mid):
        return None
    depth = on_mid @ forward
    front = on_mid[depth >= depth.max() - FRONT]
    height = front @ up
    return front[np.argmax(height)], front[np.argmin(height)]


def mouth_ends(placed: np.ndarray, estimates: np.ndarray, reached: dict, pieces: list, plane: MidPlane, axes) -> set:
    """Teeth points of `placed` (84, 3) moved onto the ends of their pieces; `reached` maps an FP id to the
    index in `pieces` (vertex arrays) its estimate snapped onto, `estimates` are the points before they
    snapped. Returns the ids placed on a piece."""
    _left, up, forward = axes
    on_piece = set(reached)
    teeth = sorted({reached[f] for f in TEETH if f in reached}, key=lambda i: pieces[i].mean(axis=0) @ up)
    ends = {i: teeth_ends(pieces[i], plane, up, forward) for i in teeth}
    if len(teeth) >= 2:
        pairs = ((teeth[-1], "9.8", "9.10"), (teeth[0], "9.11", "9.9"))
    elif teeth and ends[teeth[0]] is not None:  # one piece (the teeth closed, or one row): the nearer pair's

        def miss(top, bottom):
            top_end, bottom_end = ends[teeth[0]]
            return np.linalg.norm(top_end - estimates[fp_index(top)]) + np.linalg.norm(
                bottom_end - estimates[fp_index(bottom)]
            )

        pairs = (min(((teeth[0], "9.8", "9.10"), (teeth[0], "9.11", "9.9")), key=lambda p: miss(p[1], p[2])),)
    else:
        pairs = ()
    for piece, top, bottom in pairs:
        if ends[piece] is not None:
            placed[fp_index(top)], placed[fp_index(bottom)] = ends[piece]
            on_piece |= {top, bottom}
    return on_piece
