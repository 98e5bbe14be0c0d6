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

The tongue's tip 6.1 is read off the tongue piece by the sample's rule (`tongue_points`): the most forward
point of its mid-line. 6.2 (the centre of the tongue body) and 6.3 / 6.4 (its borders there) fix nothing along
a tongue whose top and sides are flat, so they are not read by a rule: they are the sample's own tongue
vertices moved by the shape prior as the skin was (`template.fp_basis`, the targets' motion of those vertices
under the principal shapes the skin fit found) and carried by the registration, then moved with the tip (by
the tip read minus the tip carried) and snapped onto the piece. The tongue piece is the one the estimate of
6.2 (the middle of the mouth's floor, far from every tooth) reached.

Confidence (`READ_CONFIDENCE`): a point read off its piece by its definition gets the definition's, not the
skin fit's (the template skin around a teeth point is the inside of the lips, whose fit says nothing about
the teeth). The teeth ends and the tongue tip are extremes of their piece, exact once the piece is right;
6.2-6.4, placed by the shape the skin predicts for the tongue from the tip, get less (`CARRIED_CONFIDENCE`),
but are not listed: the development heads' are 0.8-1.4 mm off on average (3-4.4 mm by the rule "the middle
of the length" they replace; docs/auto_placement.md).
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .surface import Surface, area_samples
from .symmetry import MidPlane

FRONT = 0.005  # template metres
MID = 0.002  # template metres
TEETH = ("9.8", "9.9", "9.10", "9.11")
TONGUE = ("6.1", "6.2", "6.3", "6.4")
TONGUE_SAMPLES = 8000  # area samples of the tongue piece (about 1 mm apart), so its rules do not depend on
# where a remeshed or decimated tongue happens to have vertices
TEETH_REACH = 0.01  # template metres (a front tooth's height): the other teeth row's ends come this near the
# teeth points' estimates when these snapped onto one row
EXTREME_CONFIDENCE = 0.9  # an end of the piece its estimate found (not 1: it may be the wrong piece)
CARRIED_CONFIDENCE = 0.6  # carried from the tip by the shape the skin predicts: above the listing threshold
READ_CONFIDENCE = {fp_id: EXTREME_CONFIDENCE for fp_id in (*TEETH, "6.1")} | {
    fp_id: CARRIED_CONFIDENCE for fp_id in ("6.2", "6.3", "6.4")
}


def tongue_points(vertices: np.ndarray, triangles: np.ndarray, plane: MidPlane, axes, estimates: np.ndarray):
    """6.1, 6.2, 6.3, 6.4 (4, 3) on a tongue piece (see the module's doc), or None when no part of it lies on
    the mid-plane: the tip is the most forward mid-line point (over area samples too, so it does not depend
    on where a remeshed tongue has vertices), put on the mid-plane; the others are their `estimates` (4, 3)
    moved by the tip found minus the tip estimated, snapped onto the piece."""
    forward = axes[2]
    samples, _normals = area_samples(vertices, triangles, TONGUE_SAMPLES)
    points = np.vstack([vertices, samples])
    on_mid = np.abs(points @ plane.normal - plane.offset) <= MID
    if not on_mid.any():
        return None
    tip = plane.project(points[on_mid][np.argmax(points[on_mid] @ forward)])
    body, _normals = Surface(vertices, triangles).closest(estimates[1:] + (tip - estimates[0]))
    return np.vstack([tip, body])


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
        found = tongue_points(*pieces[tongue], plane, axes, estimates[[fp_index(f) for f in TONGUE]])
        if found is not None:
            placed[[fp_index(f) for f in TONGUE]] = found
            read |= set(TONGUE)
    return on_piece | read, read
