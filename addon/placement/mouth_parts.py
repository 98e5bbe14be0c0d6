"""Teeth and tongue points from the pieces in the mouth, by the points' definitions once the pieces are found.

The FDP table (ISO/IEC 14496-2, annex C) says: 9.8 / 9.10 the top / bottom of the upper teeth in the middle,
9.11 / 9.9 the top / bottom of the lower teeth in the middle, 6.2 the centre of the tongue body and 6.3 / 6.4
its left / right border. The registration's estimates find the pieces (each point snaps onto the nearest piece
within reach, `pipeline.PART_REACH`), but with the teeth closed an upper tooth's estimate may reach the lower
teeth first, and an end of a piece lies wherever that piece ends, which an estimate carried from another head
does not know; and with the bite closed the estimates may reach only one piece. So the teeth pieces are those
the teeth estimates reached, but the tongue's, and when that is one piece, the other piece whose ends come
nearest the estimates, within TEETH_REACH; they are told apart by their places (the highest is the upper
teeth, the lowest the lower; a single piece belongs to the pair whose estimates are nearer its ends), and the
ends are read off each piece: its front (within FRONT of its most forward point) on the mid-plane (within MID
of it), highest and lowest. The sample's FP table puts them the same way
(`scripts/sample/makehuman/fp_rules.py`).

The tongue's points are read off the tongue piece by the sample's rules (`tongue_points`): 6.1 the most
forward point of its mid-line, 6.2 the highest mid-line point at the middle of its length, 6.3 / 6.4 its
leftmost / rightmost points at 6.2's depth. The tongue piece is the one the estimate of 6.2 (the middle of the
mouth's floor, far from every tooth) reached.

Confidence (`READ_CONFIDENCE`): a point read off its piece by its definition gets the definition's, not the
skin fit's (the template skin around a teeth point is the inside of the lips, whose fit says nothing about
the teeth). The teeth ends and the tongue tip are extremes of their piece, exact once the piece is right;
6.2 is only "the centre of the tongue body" and 6.3 / 6.4 its borders there, which fix nothing finer along a
tongue whose top and sides are flat (the development heads' own 6.2-6.4, one vertex each carried by their
shape targets, lie 3-5 mm along the tongue from this rule), so those three are listed for the user to check.
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .surface import area_samples
from .symmetry import MidPlane

FRONT = 0.005  # template metres
MID = 0.002  # template metres
TEETH = ("9.8", "9.9", "9.10", "9.11")
TONGUE = ("6.1", "6.2", "6.3", "6.4")
TONGUE_SAMPLES = 8000  # area samples of the tongue piece (about 1 mm apart), so its rules do not depend on
# where a remeshed or decimated tongue happens to have vertices
TEETH_REACH = 0.01  # template metres (a front tooth's height): the other teeth row's ends come this near the
# teeth points' estimates when these snapped onto one row
SLICE = 0.001  # template metres: half the thickness of the slice across the tongue at its middle
EXTREME_CONFIDENCE = 0.9  # an end of the piece its estimate found (not 1: it may be the wrong piece)
ALONG_CONFIDENCE = 0.4  # a point the definition does not fix along the piece: below the listing threshold
READ_CONFIDENCE = {fp_id: EXTREME_CONFIDENCE for fp_id in (*TEETH, "6.1")} | {
    fp_id: ALONG_CONFIDENCE for fp_id in ("6.2", "6.3", "6.4")
}


def tongue_points(vertices: np.ndarray, triangles: np.ndarray, plane: MidPlane, axes):
    """6.1, 6.2, 6.3, 6.4 (4, 3) on a tongue piece (see the module's doc), or None when no part of it lies on
    the mid-plane. The sample's rules pick among its vertices; here the top of the mid-line and the
    sides are flat along the tongue, so "highest near the middle" and "leftmost near 6.2" are taken in a
    thin slice at the middle of its length, and the mid-line points are put on the mid-plane."""
    left, up, forward = axes
    samples, _normals = area_samples(vertices, triangles, TONGUE_SAMPLES)
    points = np.vstack([vertices, samples])
    depth = points @ forward
    on_mid = np.abs(points @ plane.normal - plane.offset) <= MID
    if not on_mid.any():
        return None
    tip = points[on_mid][np.argmax(depth[on_mid])]
    middle = 0.5 * (tip @ forward + depth.min())
    across = np.abs(depth - middle) <= SLICE
    body = points[across & on_mid]
    if not len(body):
        return None
    centre = body[np.argmax(body @ up)]
    side = points[across] @ left
    border = points[across][[np.argmax(side), np.argmin(side)]]
    return np.vstack([plane.project(np.array([tip, centre])), border])


def teeth_ends(vertices: np.ndarray, plane: MidPlane, up: np.ndarray, forward: np.ndarray):
    """(top, bottom) of a teeth piece's front on the mid-plane, or None when none of it is that near."""
    on_mid = vertices[np.abs(vertices @ plane.normal - plane.offset) <= MID]
    if not len(on_mid):
        return None
    depth = on_mid @ forward
    front = on_mid[depth >= depth.max() - FRONT]
    height = front @ up
    return front[np.argmax(height)], front[np.argmin(height)]


def _reach(ends, estimates: np.ndarray) -> float:
    """How near a teeth piece's ends come to the teeth points' estimates."""
    teeth = estimates[[fp_index(f) for f in TEETH]]
    return float(min(np.linalg.norm(teeth - end, axis=1).min() for end in ends))


def mouth_ends(
    placed: np.ndarray, estimates: np.ndarray, reached: dict, pieces: list, plane: MidPlane, axes
) -> tuple[set, set]:
    """Teeth and tongue points of `placed` (84, 3) moved onto their places on their pieces; `reached` maps an
    FP id to the index in `pieces` ((vertices, triangles) each) its estimate snapped onto, `estimates` are
    the points before they snapped. Returns the ids placed on a piece, and those of them read off it by their
    definition (the rest only snapped onto it)."""
    _left, up, forward = axes
    on_piece = set(reached)
    read = set()
    tongue = reached.get("6.2")
    ends = {i: teeth_ends(vertices, plane, up, forward) for i, (vertices, _t) in enumerate(pieces) if i != tongue}
    teeth = {reached[f] for f in TEETH if f in reached} - {tongue}
    if len(teeth) == 1:  # the other row, if a piece's ends come near the estimates
        reach = {i: _reach(end, estimates) for i, end in ends.items() if end is not None and i not in teeth}
        other = min(reach, key=reach.get, default=None)
        if other is not None and reach[other] <= TEETH_REACH:
            teeth.add(other)
    teeth = sorted(teeth, key=lambda i: pieces[i][0].mean(axis=0) @ up)
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
            read |= {top, bottom}
    if tongue is not None:
        found = tongue_points(*pieces[tongue], plane, axes)
        if found is not None:
            placed[[fp_index(f) for f in TONGUE]] = found
            read |= set(TONGUE)
    return on_piece | read, read
