"""Eyelids that slide over the eyeball: a blink closes along a smooth curve and the lids meet.

Planar Bones moves an eyelid with its control triangles, and only the mid-lid feature point (3.1-3.4)
moves in a blink, so the lid margin folds into a V at that point. So the deformer is given the mid-lid
FPs at rest (`hold_lids`: the brows, cheeks and head still move the lids through it) and their motion is
added here instead. A lid is skin lying on the eyeball: its vertices turn about the eye's centre, around
the eye's horizontal axis (face x), by the angle through which the mid-lid FP turned. The angle is
weighted along the eye by the opening measured on the mesh (`opening_profile`: 1 under the mid-lid FP,
0 at the eye corners, where the lids are tied to the bone; `seen_margins`, the opening seen on the skin, for
lid masks set-up made; `lid_profile`, a sine arch, when the mesh shows no opening), so lids that meet under
the FPs meet along the whole eye and the margin keeps its curve; and by the lid's membership weight (how much
of the lid a vertex is), so the skin above and below follows smoothly. Turning keeps each vertex's distance to
the centre: the lid stays on the eye.

The lids also follow the eyeball's pitch in part (`UPPER_FOLLOWS_PITCH`, `LOWER_FOLLOWS_PITCH`), as
real lids do, and the two lids of an eye stop where they meet (`decode.meet_at_closure`, in angle, under the
mid-lid FPs), and all along the eye: no vertex turns past the other lid's margin at its place (`meet_lids`; a lid's
own skin also not past that margin as the skin shows it, `EyelidRig.room`).

No face turns over (not in the paper, which has no lids' turn): given the mesh's faces, `bind_eyelids` makes the
weights such that each lid alone, turning anywhere within its range (`_turn_range`), keeps every face's normal
(`lid_fold_rates`) at least 1 - `FOLD_SHARE` of the way it faced at rest, and `lid_turns` keeps the turns within
those ranges. Hand-made lid groups fall from 1 to 0 across a single face near the lid, which a turn of 0.1 rad
folds on the sample head; the weights of the skin around the lids (above the upper lid's crease, at the corners,
the lids' inner rims) are moved, by as little as projections onto those limits move them (`fold_free_weights`);
the lids' own weights (group weight >= `MEMBER`) stay as bound, so the lids still meet along the whole eye. Turns
toward closure and away from it get weights of their own (`EyelidRig.opening`): the skin above the upper lid must
turn with a rising lid, not with a blink (where the sculpted expressions leave it still).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..geometry.columns import column_cuts, column_gaps
from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.decode import meet_at_closure
from ..mpeg4.feature_points import fp_index
from . import fused

# Share of the eyeball's pitch the lids follow: the upper lid tracks vertical gaze closely, the lower lid
# less (no paper of ours gives numbers; these are the usual animation values).
UPPER_FOLLOWS_PITCH = 0.7
LOWER_FOLLOWS_PITCH = 0.3
# FPs per eye: upper mid-lid, lower mid-lid, inner corner, outer corner, pupil (left eye, right eye)
EYE_FPS = (("3.1", "3.3", "3.11", "3.7", "3.5"), ("3.2", "3.4", "3.8", "3.12", "3.6"))
_TURN_ROWS = np.array([[fp_index(up), fp_index(low), fp_index(pupil)] for up, low, _i, _o, pupil in EYE_FPS])
MID_LID_FPS = frozenset(fp_id for eye in EYE_FPS for fp_id in eye[:2])
PROFILE_BINS = 24  # bins (`trace_margins`) or lines (`seen_margins`) along the eye on which the opening is measured
ON_EYEBALL = (0.75, 0.95)  # x eyeball radius from its centre: skin turns with a lid from nothing at the first to all
REACH_RADII = (1.5, 2.0)  # the lids' turn fades out between these multiples of the eyeball radius from its centre
# Turns (rad, + up) each lid's weights are made fold-free for: the upper lid rises at most TURN_OPENING (the
# levator's 2 mm and a little of an upward gaze: the wider this, the more skin above the lid must turn with it)
# and falls through the eye's opening at rest and TURN_BEYOND_CLOSURE more (a closed eye looking down); the lower
# lid the other way round. `lid_turns` keeps the turns inside.
TURN_BEYOND_CLOSURE = 0.25
TURN_OPENING = 0.15
FOLD_SHARE = 0.4  # of a face's normal that one lid's turn may take: the two lids together leave 0.2 at least
MEMBER = 0.99  # a vertex at least this much of a lid (its group weight) is the lid: its weight is kept as bound
# `fold_free_weights`: at most SWEEPS sweeps (NUMPY_SWEEPS without the kernel: its sweeps pass over the faces
# already within their limits, numpy's cannot), until no face misses a limit by more than TOLERANCE (of its
# normal's share per radian); each projection's step times OMEGA. On the sample head at 4k vertices the lids'
# weights meet every limit within a few dozen sweeps; at 17k and 68k the sweeps stop short, some faces missing
# their limit (the live-folds table at those sizes shows what that leaves): both solves take 0.2 s at 68k with the
# kernel, 1.6 s without.
# Over-relaxing (OMEGA 1.9) converged faster at 4k but, stopped short at 68k, left rougher weights and more folds
# (the demo 15 faces in a frame against 1).
SWEEPS, NUMPY_SWEEPS, OMEGA, TOLERANCE = 1000, 200, 1.0, 1e-3
# `meet_lids`: each lid stops this angle (rad) short of where the other lid's margin is, about 0.1 mm at a lid's 16 mm
# from the eye's axis: margins that meet exactly cross where one's rows lie a hair beyond the traced margin, and
# the lids may stay 0.5 mm apart
MEET_CLEARANCE = 0.006


def lid_profile(x: np.ndarray, inner: float, mid: float, outer: float) -> np.ndarray:
    """Share of a lid's turn at lateral positions `x`: 0 at the corners `inner`/`outer`, 1 at `mid`.

    sin(pi tau) over the lid, with tau = 0.5 at the mid-lid point: the opening of an eye narrows to its
    corners like this, so a closed lid meets the other along its whole width; the slope is 0 at the
    mid point (no V) and the profile is 0 beyond the corners.
    """
    x = np.asarray(x, dtype=np.float64)
    t = (x - inner) / (outer - inner)
    t_mid = min(max((mid - inner) / (outer - inner), 0.05), 0.95)
    tau = np.where(t < t_mid, 0.5 * t / t_mid, 0.5 + 0.5 * (t - t_mid) / (1.0 - t_mid))
    return np.where((tau > 0.0) & (tau < 1.0), np.sin(np.pi * np.clip(tau, 0.0, 1.0)), 0.0)


def trace_margins(
    t: np.ndarray, elev: np.ndarray, upper: np.ndarray, lower: np.ndarray, hidden: np.ndarray | None = None
) -> list | None:
    """The lid margins along the eye, traced on the mesh: [(t, elevation, vertex) of the upper margin, of the lower].

    `t` (K,) position of the vertices from the inner (0) to the outer (1) corner, `elev` their elevation,
    `upper`/`lower` their lid membership. Each margin is traced by its lid's lowest (upper lid) or highest
    (lower lid) vertex in each bin of `t` (members at least half; up to `PROFILE_BINS` bins, about one per
    three members on a coarse mesh; `vertex` its index into `t`, -1 at the corners), and the margins meet at the
    corners; None when a margin has fewer than 3 points. `hidden` (2, K): vertices no bin picks for the upper and for
    the lower margin (`seen_picks`: not the margin the eye's centre sees); the bins are counted as without it.
    """
    members = min(int(np.sum(upper >= 0.5)), int(np.sum(lower >= 0.5)))
    hidden = np.zeros((2, len(t)), bool) if hidden is None else np.asarray(hidden, bool)
    edges = np.linspace(0.0, 1.0, max(4, min(PROFILE_BINS, members // 3)) + 1)
    margins = []
    for member, pick, out in ((upper, np.argmin, hidden[0]), (lower, np.argmax, hidden[1])):
        ts, angles, picked = [0.0], [np.nan], [-1]
        for b in range(len(edges) - 1):
            inside = np.flatnonzero((t >= edges[b]) & (t < edges[b + 1]) & (member >= 0.5) & ~out)
            if len(inside):
                k = inside[pick(elev[inside])]
                ts.append(float(t[k]))
                angles.append(float(elev[k]))
                picked.append(int(k))
        ts.append(1.0)
        angles.append(np.nan)
        picked.append(-1)
        margins.append((np.array(ts), np.array(angles), np.array(picked)))
    if min(len(m[0]) for m in margins) < 5:
        return None
    corner = [np.nanmean([m[1][1] for m in margins]), np.nanmean([m[1][-2] for m in margins])]
    for _ts, angles, _picked in margins:
        angles[0], angles[-1] = corner
    return margins


def seen_margins(
    local: np.ndarray, triangles: np.ndarray, radius: float, corners: np.ndarray, columns: int = PROFILE_BINS
) -> list | None:
    """The lid margins along the eye as the eye's centre sees them, in `trace_margins`' form (every vertex -1): the
    opening measured on the skin itself, whatever the lid weights say, in the angles the lids turn through.

    `local` (N, 3) rest positions relative to the eye's centre, face frame; `triangles` (T, 3) the mesh's; `radius`
    the eyeball's; `corners` (2, 3) the inner and the outer corner FP, relative to the centre. The skin that can
    cover the eye is the triangles with every corner in front of the centre, outside the eyeball's sphere and within
    the lids' reach (`REACH_RADII`), each corner at (x, its `elevation`): the lids turn about the face x axis, so a
    margin meets the other where their elevations meet, whatever their depth (seen straight on, the back of a thick
    margin can stand below its front). On `columns` lines of x evenly between the corners, the stretch of elevation
    the skin leaves open across the line between the corners is the opening there, its top the upper margin and its
    bottom the lower; a line that sees none (past the eyeball's outline, or the skin of a corner) has the margins
    meet on the line between the corners, as they do at the corners themselves, except the lines between a corner
    and the first line that sees an opening, whose margins run straight from the one to the other. None when fewer
    than 3 lines see an opening (an eye closed at rest, or no eye opening in the mesh)."""
    ts, margins, _points, seen = _seen_margin_points(local, triangles, radius, corners, columns)
    if seen.sum() < 3:
        return None
    # the lines between a corner and the first line that sees an opening (the inner corner's caruncle fills them)
    # take the margins from the corner to that line: counted as shut, they stepped the turn from none to most across
    # one edge of a coarse mesh, where the margins in front of the caruncle are apart (the decimated head: a share of
    # 0.01 at one margin vertex and 0.72 at the next turned the face between them over, and Unfold Skin, opening it,
    # pulled the margin 2 mm back up: the lids stayed 1.7 mm apart)
    # (within the eyeball's outline: past it the lids cover no eye, and the margins meet on the corners' line there)
    first, last = np.flatnonzero(seen)[[0, -1]]
    ends = np.zeros(len(ts), bool)
    ends[1:first] = ends[last + 1 : -1] = True
    x = np.asarray(corners, dtype=np.float64)[:, 0]
    ends &= np.abs(x[0] + ts * (x[1] - x[0])) < radius
    margins = np.array([np.where(ends, np.interp(ts, ts[~ends], m[~ends]), m) for m in margins])
    return [(ts, margin, np.full(len(ts), -1)) for margin in margins]


def seen_margin_points(
    local: np.ndarray, triangles: np.ndarray, radius: float, corners: np.ndarray, columns: int = PROFILE_BINS
) -> tuple[np.ndarray, np.ndarray]:
    """The points of the skin on the lid margins `seen_margins` finds, on the lines that see an opening: (2, P, 3)
    the corners (vertex indices) of the triangle each point of the upper and of the lower margin lies on and
    (2, P, 3) its barycentric weights there, from the inner corner out. Followed through a deformation (the
    weights applied to the triangle's corners), they are the lids' edges themselves, evenly along the eye, on any
    topology: the vertices nearest a line through the lid FPs are not the margin where it curves away from that
    line (the inner corner of the sample's lids, 1 mm above it)."""
    _ts, _margins, points, seen = _seen_margin_points(local, triangles, radius, corners, columns)
    points = points[:, seen]
    return points[:, :, 4:].astype(np.intp), points[:, :, 1:4]


def _seen_margin_points(local, triangles, radius, corners, columns):
    """`seen_margins`' lines (P,), margins (2, P) and the points of the skin at them (2, P, 1 + 3 + 3: elevation,
    barycentric weights, the triangle's corners), with which lines see an opening (P,)."""
    return _seen_lines(local, triangles, radius, corners, np.linspace(0.0, 1.0, columns + 2))


def _seen_lines(local, triangles, radius, corners, ts):
    """`_seen_margin_points` on the lines at `ts` (P,) along the eye, the first and the last the corners (not
    looked at)."""
    local = np.asarray(local, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    near = np.linalg.norm(local, axis=1) / radius
    skin = ((local[:, 2] > 0.0) & (near > 1.0) & (near < REACH_RADII[1]))[triangles].all(axis=1)
    chart = np.stack([local[:, 0], elevation(local, np.zeros(3))], axis=1)[triangles[skin]]
    # each corner carries its barycentric weights and the triangle's corners, which `column_cuts` interpolates
    carried = np.concatenate(
        [np.broadcast_to(np.eye(3), (len(chart), 3, 3)), triangles[skin][:, None, :].repeat(3, 1)], axis=2
    )
    chart = np.concatenate([chart, carried], axis=2)
    ends = np.asarray(corners, dtype=np.float64)
    ends = np.stack([ends[:, 0], elevation(ends, np.zeros(3))], axis=1)  # (2, 2) x and elevation, inner and outer
    margins = np.repeat((ends[0, 1] + ts * (ends[1, 1] - ends[0, 1]))[None], 2, axis=0)  # (2, P) upper, lower
    points = np.zeros((2, len(ts), 7))
    seen = np.zeros(len(ts), bool)
    for k, t in enumerate(ts[1:-1], start=1):
        x, across = ends[0] + t * (ends[1] - ends[0])  # across: the line between the corners
        below, above = column_gaps(*column_cuts(chart, x))
        hit = np.flatnonzero((below[:, 0] <= across) & (above[:, 0] >= across))
        if len(hit) and abs(x) < radius:
            points[:, k] = above[hit[0]], below[hit[0]]
            margins[:, k] = points[:, k, 0]
            seen[k] = True
    return ts, margins, points, seen


def seen_picks(
    margins: list,
    t: np.ndarray,
    elev: np.ndarray,
    local: np.ndarray,
    triangles: np.ndarray,
    radius: float,
    corners: np.ndarray,
    member: np.ndarray,
) -> np.ndarray:
    """(2, K) the vertices (at `t` along the eye, elevation `elev`) that `trace_margins` picked for the upper and for
    the lower margin (`margins`) and that are not the lid's margin: on the lines through them (`seen_margins`' lines,
    on the skin `local`, `triangles`, `radius`, `corners` as there) the skin the eye's centre sees at the edge of
    the opening lies nearer the other lid than they do (they stand above the upper margin, below the lower) and is
    a member of their lid (`member` (2, N), the upper and the lower lid's at the mesh's vertices, at least 0.5 at
    that point, as `trace_margins` counts members), so they are behind the lid's edge, not on it. Skin of neither
    lid at the opening's edge (a painted lid's inner rim hanging below its front at the inner corner, the
    triangulated head) leaves the picks alone: the lid's margin is its lowest member.

    A bin that holds no vertex of the margin (the margin's vertices farther apart than the bins: 1.3 mm on the
    subdivided head, the bins 1.0 mm) picked the lowest member behind it: on the subdivided head, vertices of the
    row halfway between the margin and the lid's inner rim (members of 0.5), 0.5-2.5 degrees above the margin at
    their place; `margin_members` then made the lid's back around them full members beside the rim's 0, and the
    lids' turn folded those faces (Unfold Skin, opening them, pulled the back 2-3 mm and creased the closed lid
    down its middle). A line that sees no opening tells nothing: its picks stay. The elevations are compared to
    1e-9 rad (rounding: a pick on the margin is a corner of the skin the line crosses there)."""
    out = np.zeros((2, len(t)), bool)
    for k, (side, (_ts, _angles, picked)) in enumerate(zip((1.0, -1.0), margins, strict=True)):
        picks = picked[picked >= 0]
        if not len(picks):
            continue
        lines = np.concatenate([[0.0], t[picks], [1.0]])
        _lines, seen_at, points, seen = _seen_lines(local, triangles, radius, corners, lines)
        at = points[k, 1:-1]
        ours = np.einsum("pc,pc->p", at[:, 1:4], member[k][at[:, 4:].astype(np.intp)]) >= 0.5
        behind = seen[1:-1] & ours & (side * (elev[picks] - seen_at[k, 1:-1]) > 1e-9)
        out[k, picks[behind]] = True
    return out


def seen_edge_members(
    rows: np.ndarray, member: np.ndarray, t: np.ndarray, elev: np.ndarray, edge: np.ndarray, seen: list
) -> np.ndarray:
    """The upper lid's memberships `member` (K,) of the vertices `rows` (K,) (at `t` along the eye, elevation `elev`)
    with the upper lid's edge as the eye's centre sees it made full members: the vertices in `edge` (the corners of
    the triangles the upper margin of `seen_margins` lies on, `seen_margin_points`) that the mask gives a part of the
    lid (above 0) and that lie above the lower margin `seen[1]`.

    The lowest skin of the upper lid is what closes onto the lower lid. Where the mask gives it only a part of the
    lid (a subdivided mask's new row halfway between the margin and the inner rim, 0.5; the triangulated sample's
    inner-corner triangle that reaches onto the rim), it turned by that part and hung behind the closed lid: the
    seen margin 1.90 / 2.09 mm off a smooth curve at the blink on the subdivided head (0.63 / 0.76 at rest), 2.68 /
    2.76 on the triangulated one (0.58). Skin the mask leaves out (0: a painted lid's inner rim and lining) stays the
    fold-free weights' to move: made full, the corners' pockets turned with the lid and crossed. Made after the
    margins are traced (`margin_members`): made before, the traced margins, and with them the opening the rows behind
    the edge turn by, changed too, and the triangulated head's closed edge had a dark wedge under its outer third.
    The upper lid's only: the upper lid closes the eye (the blink), and the same for the lower lid's edge gave the
    upper lid's edge at the sample's outer corner a share of the lower lid's turn (the fold-free weights), which took
    the skin's stop (`skin_stop_room`) off the row beside it (0.81 -> 1.09 mm off smooth there). Painted masks only,
    as `margin_members`: masks set-up made end where the FPs' edge curves say, not blended across the edge, and made
    full there the 2 mm remesh's eyes stayed 0.09 / 0.83 and 0.32 / 1.06 mm open (straight on / from below)."""
    on_edge = np.isin(rows, edge) & (member > 0.0) & (elev > np.interp(t, *seen[1][:2]))
    return np.where(on_edge, 1.0, member)


def margin_members(
    margins: list, t: np.ndarray, elev: np.ndarray, upper: np.ndarray, lower: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The lids' memberships `upper`/`lower` (K,) on the lid's side of its traced margin (`trace_margins`; the
    vertices at `t` along the eye whose elevation `elev` is at or beyond the margin's there) over the margin's own
    membership at their place, clipped to [0, 1]: a margin whose membership is below 1 (a mask blended across the
    margin, as decimation or a soft brush leaves it) turns short of the other lid, which the lids' turn by the
    opening (`opening_profile`) counts on; dividing by it makes each margin a full member and keeps the lid's fall
    away from it in proportion. The skin past the margin (the lid's inner rim, the corners' pockets) keeps its own."""
    out = []
    for (ts, angles, picked), member, side in zip(margins, (upper, lower), (1.0, -1.0), strict=True):
        at_margin = np.where(picked >= 0, member[np.maximum(picked, 0)], 1.0)
        on_lid = side * (elev - np.interp(t, ts, angles)) >= 0.0
        out.append(np.where(on_lid, np.clip(member / np.interp(t, ts, at_margin), 0.0, 1.0), member))
    return out[0], out[1]


def vertex_neighbours(triangles: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's edges as compressed rows: vertex k's neighbours are `indices[indptr[k]:indptr[k + 1]]`."""
    tri = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    pairs = np.unique(np.concatenate([pairs, pairs[:, ::-1]]), axis=0)
    return np.searchsorted(pairs[:, 0], np.arange(n + 1)), pairs[:, 1]


def one_row_deep(margin: np.ndarray, neighbours: tuple, elev: np.ndarray, member: np.ndarray, side: float) -> bool:
    """Whether a lid's mask is its margin row alone: for more than half of the lid's margin vertices `margin`
    (indices), the neighbour that climbs farthest onto the lid (`side` (+1 the upper lid, -1 the lower) times its
    elevation `elev` over the margin vertex's) is no member (`member` below 0.5). Such a lid turns its margin and
    leaves the skin one edge away, however far that is: on a mesh decimated after its masks were painted (the
    collapses blend the groups) the upper lid is the margin row, the next row 12-14 degrees up stays, and the closed
    lid is one strip of faces 45 degrees across, crumpled where that row zig-zags. The rows behind a painted margin
    on a finer mesh are members, whatever the count of rows: the test asks for one row, not a depth in mm."""
    indptr, indices = neighbours
    shallow = counted = 0
    for m in np.asarray(margin, dtype=np.intp):
        around = indices[indptr[m] : indptr[m + 1]]
        climb = side * (elev[around] - elev[m])
        if not len(around) or climb.max() <= 0.0:
            continue
        counted += 1
        shallow += member[around[np.argmax(climb)]] < 0.5
    return bool(counted > 0 and 2 * shallow > counted)


def opening_profile(margins: list, t: np.ndarray, t_mid: float) -> np.ndarray | None:
    """Share of the lids' turn along the eye: the opening between the traced `margins` at `t` over the
    opening under the mid-lid FPs (`t_mid`), so that lids that meet under the FPs meet along the whole eye."""

    def opening(x):
        return np.interp(x, *margins[0][:2]) - np.interp(x, *margins[1][:2])

    mid = opening(t_mid)
    if not mid > 0.0:
        return None
    return np.where((t > 0.0) & (t < 1.0), np.clip(opening(t) / mid, 0.0, 1.0), 0.0)


def _fall(x: np.ndarray) -> np.ndarray:
    """1 for x <= 0, smoothly down to 0 at x = 1 (slope at most 1.5)."""
    x = np.clip(x, 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def elevation(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Angle of face-frame points above the horizontal plane through `centre`, about the face x axis."""
    d = np.asarray(points, dtype=np.float64) - centre
    return np.arctan2(d[..., 1], d[..., 2])


@dataclass(frozen=True)
class EyelidRig:
    """What `apply` needs, computed once from the rest face."""

    vertices: np.ndarray  # (K,) indices of the vertices the lids move
    eye: np.ndarray  # (K,) 0 left eye, 1 right eye
    upper: np.ndarray  # (K,) share of the upper lid's turn (membership x profile)
    lower: np.ndarray  # (K,) share of the lower lid's turn
    local: np.ndarray  # (K, 3) rest positions relative to their eye's centre, face frame
    centres: np.ndarray  # (2, 3) eye centres, face frame
    rest_angles: np.ndarray  # (2, 3) rest elevation of the upper mid-lid FP, lower mid-lid FP, pupil
    axes: np.ndarray  # (3, 3) face frame in mesh coordinates
    turn_range: np.ndarray | None = None  # (2, 2, 2) [eye][upper, lower][least, most] turn; None: not limited
    # (K, 2) the upper and lower lid's weights for turns away from closure (the upper lid up, the lower down), where
    # `upper` and `lower` are for turns toward it; None: `upper` and `lower` for both
    opening: np.ndarray | None = None
    # (K,) the lids' traced opening at each vertex's place along the eye over the mid one (`meeting_curve`), where
    # `meet_lids` stops the lids; None: stopped under the mid-lid FPs only
    meeting: np.ndarray | None = None
    # (eye, lid) pairs (0 left / 1 right, 0 upper / 1 lower) whose mask was the margin row alone (`one_row_deep`) and
    # turn by the memberships made from the FPs where those are larger
    deepened: tuple = ()
    # (K, 2) the angle (rad) from each vertex to the other lid's margin at its place along the eye as the eye's centre
    # sees it on the skin (`seen_margins`): down to the lower margin for the upper lid's turn, up to the upper margin
    # for the lower lid's; NaN where that stop does not apply (`skin_stop_room`: the skin shows no opening there, the
    # other lid moves the vertex too, or it lies past the other margin already); None: no stop by the skin
    # (`meet_lids`). Made once by `bind_eyelids`, so the frames do not work out which rows it applies to
    room: np.ndarray | None = None


def bind_eyelids(
    rest: np.ndarray,
    upper_lid: np.ndarray,
    lower_lid: np.ndarray,
    neutral: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
    axes: np.ndarray = BLENDER_FACE_AXES,
    triangles: np.ndarray | None = None,
    trace_opening: bool = True,
    made_lids: Callable[[], tuple[np.ndarray, np.ndarray] | None] | None = None,
) -> EyelidRig | None:
    """Rig the lids of a rest face; None when an eye's lid FPs are missing.

    `rest` (N, 3) mesh positions; `upper_lid`/`lower_lid` (N,) membership weights in [0, 1] (1 on the lid);
    `neutral` (84, 3) rest FP positions (NaN where missing); `centres` (2, 3) and `radii` (2,) the left and
    right eyeballs, all in mesh coordinates. With the mesh's `triangles` (T, 3), the weights are made so that
    no face turns over (`fold_free_weights`) and the turns are kept within the range that holds for
    (`_turn_range`). The share of the turn along the eye follows the opening traced on the mesh through the lid
    weights (`opening_profile`; where the skin of `triangles` shows a larger opening, that one: a traced opening falls
    short where a bin's pick is no margin), or with `trace_opening` False (lid weights made from the FPs, which know no
    more of the margins than the FPs do: margins traced through them bend where the weights do) the opening the
    eye's centre sees on the skin of `triangles` (`seen_margins`) over the mid-lid FPs' own opening, and no turn
    toward closure where it sees none (the skin shut across the eye at rest, as a scan of closed eyes: the sine
    arch turned the Lee Perry-Smith scan's upper lids through the lower, up to 150 crossing pairs at the demo's
    blink); a sine arch between the corners (`lid_profile`) where the weights trace no opening.

    `made_lids`: a function giving (N,) x 2, the upper and lower lids' memberships as set-up would make them from
    the FPs (`auto_masks`; called only when needed, once, for it costs 0.4 s at 17k vertices; None: none made); a
    lid whose own mask is its margin row alone (`one_row_deep`, with `triangles`) turns as the larger of the two
    (`EyelidRig.deepened` says which), so the rows behind its margin turn with it.
    """
    axes = np.asarray(axes, dtype=np.float64)
    face = np.asarray(rest, dtype=np.float64) @ axes.T
    fps = np.asarray(neutral, dtype=np.float64) @ axes.T
    centres = np.asarray(centres, dtype=np.float64) @ axes.T
    radii = np.asarray(radii, dtype=np.float64)
    ids = [[fp_index(f) for f in eye] for eye in EYE_FPS]
    if not all(np.all(np.isfinite(fps[k[:4]])) for k in ids):
        return None
    distance = np.linalg.norm(face[:, None] - centres[None], axis=2)
    eye = np.argmin(distance, axis=1)
    rows = np.arange(len(face))
    near = distance[rows, eye] / radii[eye]
    # skin on the eyeball: not inside it (the socket the eyeball hides) nor far from it (brow, cheek)
    on_eyeball = 1.0 - _fall((near - ON_EYEBALL[0]) / (ON_EYEBALL[1] - ON_EYEBALL[0]))
    fade = _fall((near - REACH_RADII[0]) / (REACH_RADII[1] - REACH_RADII[0])) * on_eyeball
    in_front = face[:, 2] > centres[eye, 2]
    up = np.clip(np.asarray(upper_lid, dtype=np.float64), 0.0, 1.0)
    low = np.clip(np.asarray(lower_lid, dtype=np.float64), 0.0, 1.0)
    painted, made = (up, low), None
    neighbours = None if made_lids is None or triangles is None else vertex_neighbours(triangles, len(face))
    deepened = []
    keep = np.flatnonzero((fade > 0.0) & in_front)
    eye, fade, up, low = eye[keep], fade[keep], up[keep], low[keep]
    up_weight, low_weight = np.zeros(len(keep)), np.zeros(len(keep))
    rest_angles = np.full((2, 3), np.nan)
    meets = [None, None]  # per eye: the lids' opening along the eye as the weights have it, for `meeting_curve`
    along = np.zeros(len(keep))  # each vertex's place along its eye, 0 at the inner corner, 1 at the outer
    seen_by_eye = [None, None]  # per eye: the margins the eye's centre sees on the skin, for `EyelidRig.room`
    for e, (upper, lower, inner, outer, pupil) in enumerate(ids):
        on = eye == e
        x = face[keep[on], 0]
        inner_x, outer_x = fps[inner, 0], fps[outer, 0]
        rest_angles[e] = elevation(fps[[upper, lower, pupil]], centres[e])
        t = along[on] = (x - inner_x) / (outer_x - inner_x)
        elev = elevation(face[keep[on]], centres[e])
        mid = (fps[upper, 0] - inner_x) / (outer_x - inner_x)
        closure = None  # traced margins: the share of their own mid opening
        meets_override = None
        if triangles is not None:
            seen = seen_margins(face - centres[e], triangles, radii[e], fps[[inner, outer]] - centres[e])
            seen_by_eye[e] = None if seen is None else (seen, inner_x, outer_x)
        if trace_opening:
            trace = functools.partial(_seen_trace, t, elev, face - centres[e], triangles, radii[e])
            trace = (
                None if seen_by_eye[e] is None else functools.partial(trace, fps[[inner, outer]] - centres[e], keep[on])
            )
            margins = trace_margins(t, elev, up[on], low[on]) if trace is None else trace(up[on], low[on])
            if margins is not None and neighbours is not None:
                elev_all = elevation(face, centres[e])
                for k, (lid, side) in enumerate(zip((up, low), (1.0, -1.0), strict=True)):
                    picked = margins[k][2]
                    if not one_row_deep(keep[on][picked[picked >= 0]], neighbours, elev_all, painted[k], side):
                        continue
                    made = made if made is not None else made_lids() or ()
                    if made:
                        lid[on] = np.maximum(lid[on], np.clip(np.asarray(made[k], dtype=np.float64)[keep[on]], 0, 1))
                        deepened.append((e, k))
                if deepened and deepened[-1][0] == e:
                    margins = trace_margins(t, elev, up[on], low[on]) if trace is None else trace(up[on], low[on])
            profile = opening_profile(margins, t, mid) if margins is not None else None
            if profile is not None and seen_by_eye[e] is not None:
                # and at least by the opening the skin shows: the traced one falls short where a bin's pick is no
                # margin or a margin vertex is not picked (the decimated head: 4 bins, its margin stopped 3 degrees
                # above the lower lid a fifth of the way out); the skin's stop keeps them from passing it (`room`)
                closure_e = rest_angles[e, 0] - rest_angles[e, 1]
                seen = seen_by_eye[e][0]
                profile = np.maximum(profile, meeting_curve(seen, t, mid, closure_e).clip(0.0, 1.0))
                meets_override = functools.partial(
                    _larger_of,
                    functools.partial(meeting_curve, margins, t_mid=mid),
                    functools.partial(meeting_curve, seen, t_mid=mid, closure=closure_e),
                )
        elif triangles is not None:  # seen margins: the turn that closes them when the mid-lid FPs meet
            margins = None if seen_by_eye[e] is None else seen_by_eye[e][0]
            closure = rest_angles[e, 0] - rest_angles[e, 1]
            profile = meeting_curve(margins, t, mid, closure) if margins is not None and closure > 0.0 else None
            if margins is None:  # no opening on the skin: the lids meet at rest already (a scan's shut eye)
                up_weight[on] = low_weight[on] = 0.0
                meets[e] = (np.zeros_like, inner_x, outer_x)
                continue
        else:
            profile = None
        if profile is not None:
            if trace_opening:
                up[on], low[on] = margin_members(margins, t, elev, up[on], low[on])
            if trace_opening and seen_by_eye[e] is not None:  # the upper lid's lowest skin, seen, is its edge
                corners, bary = seen_margin_points(
                    face - centres[e], triangles, radii[e], fps[[inner, outer]] - centres[e]
                )
                up[on] = seen_edge_members(keep[on], up[on], t, elev, corners[0][bary[0] > 0.0], seen_by_eye[e][0])
            up_weight[on], low_weight[on] = up[on] * profile, low[on] * profile
            meeting_at = meets_override or functools.partial(meeting_curve, margins, t_mid=mid, closure=closure)
            meets[e] = (meeting_at, inner_x, outer_x)
        else:  # no opening traced on the mesh (or not asked to trace one): a sine arch along the eye
            up_weight[on] = up[on] * lid_profile(x, inner_x, fps[upper, 0], outer_x)
            low_weight[on] = low[on] * lid_profile(x, inner_x, fps[lower, 0], outer_x)
            mids = (mid, (fps[lower, 0] - inner_x) / (outer_x - inner_x))
            meets[e] = (functools.partial(arch_meeting, t_mids=mids), inner_x, outer_x)
    weights = np.stack([up_weight * fade, low_weight * fade], axis=1)
    turn_range = opening = None
    if triangles is not None:
        turn_range = _turn_range(rest_angles)
        # the skin just inside the eyeball's sphere (the lids' inner rims, hidden by the eyeball) may turn too:
        # held still, it would fold the faces it shares with the lids' edges, whatever the weights outside
        within = np.flatnonzero((near < REACH_RADII[1]) & in_front)
        extra = np.setdiff1d(within, keep)
        # a lid's members keep their weights, but not past the corners (where they are 0): held at 0 beside a margin
        # that still turns (a measured opening closes within a millimetre or two of the corner), they left the
        # corner's pocket to the fold-free weights, which turned it with one lid or the other until it crossed (the
        # demo's blink on the sample with its groups deleted: a pair at each outer corner). Freeing every member of
        # weight 0 (the opening's shut stretches inside the corners too) roughened the 2 mm remesh's inner corner
        member = (np.stack([up, low], axis=1) >= MEMBER) & ((along > 0.0) & (along < 1.0))[:, None]
        if not trace_opening:
            # masks set-up made say which lid a vertex is: one lid's members are not the other's to turn (the
            # fold-free weights turned the lower lid's margin with the upper lid's blink at the decimated head's
            # inner corner, 3.6 mm down, and the eye stayed 1.3 mm open)
            member = member | member[:, ::-1]
        member = np.concatenate([member, np.zeros((len(extra), 2), bool)])
        keep, eye = np.concatenate([keep, extra]), np.concatenate([eye, np.argmin(distance[extra], axis=1)])
        weights = np.concatenate([weights, np.zeros((len(extra), 2))])
        arguments = (face, keep, eye, weights, member, centres, np.asarray(triangles), turn_range)
        weights, opening = fold_free_weights(*arguments)
    moved = (weights > 0.0).any(axis=1)
    if opening is not None:
        moved |= (opening > 0.0).any(axis=1)
        opening = opening[moved]
    keep, eye, weights = keep[moved], eye[moved], weights[moved]
    room = np.full((len(keep), 2), np.nan)
    for e, seen_at in enumerate(seen_by_eye):
        if seen_at is not None:
            (upper_margin, lower_margin), inner_x, outer_x = [m[:2] for m in seen_at[0]], *seen_at[1:]
            on = eye == e
            t = (face[keep[on], 0] - inner_x) / (outer_x - inner_x)
            elev = elevation(face[keep[on]], centres[e])
            room[on] = np.stack([elev - np.interp(t, *lower_margin), np.interp(t, *upper_margin) - elev], axis=1)
    room = skin_stop_room(room, weights[:, 0], weights[:, 1])
    meeting = np.zeros(len(keep))
    for e, (opening_at, inner_x, outer_x) in enumerate(meets):
        on = eye == e
        meeting[on] = opening_at((face[keep[on], 0] - inner_x) / (outer_x - inner_x))
    return EyelidRig(
        vertices=keep,
        eye=eye,
        upper=weights[:, 0],
        lower=weights[:, 1],
        local=face[keep] - centres[eye],
        centres=centres,
        rest_angles=rest_angles,
        axes=axes,
        turn_range=turn_range,
        opening=opening,
        meeting=meeting,
        deepened=tuple(deepened),
        room=room if np.isfinite(room).any() else None,
    )


def _seen_trace(t, elev, local, triangles, radius, corners, rows, upper, lower) -> list | None:
    """`trace_margins` whose bins pick no vertex `seen_picks` finds behind the upper margin (traced again until none);
    `rows` (K,) the vertices at `t`, `upper`/`lower` (K,) their memberships.

    The upper lid's only: it closes the eye (the blink), and the lower lid's picks on a coarse mesh are not its
    margin's vertices at their place either (the decimated head's 4 bins: a pick 14 degrees below the lower margin
    the skin shows there, which a member of 0.64 makes): left out, its lower margin kept 3 picks and no opening was
    traced (a sine arch instead: both eyes 1.3 mm open at the blink)."""
    hidden = np.zeros((2, len(t)), bool)
    member = np.zeros((2, len(local)))
    member[:, rows] = upper, lower
    while True:
        margins = trace_margins(t, elev, upper, lower, hidden)
        if margins is None:
            return None
        behind = seen_picks(margins, t, elev, local, triangles, radius, corners, member)
        behind[1] = False
        if not (behind & ~hidden).any():
            return margins
        hidden |= behind


def skin_stop_room(room: np.ndarray, upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """`room` (K, 2) (the angle from each vertex down to the lower margin and up to the upper margin as the skin shows
    them) kept where `meet_lids` stops a lid's turn by it, NaN elsewhere: a vertex of this lid alone (the other lid's
    weight, `lower` for the upper lid's turn and `upper` for the lower's, 0 or less) with room before that margin
    (more than 0). Skin both lids move lies on neither side of a margin (a decimated face's blended corners opened
    when held by it), and skin already past the other margin keeps the opening's stop."""
    alone = np.stack([np.asarray(lower) <= 0.0, np.asarray(upper) <= 0.0], axis=1)
    with np.errstate(invalid="ignore"):
        return np.where(alone & (room > 0.0), room, np.nan)


def meeting_curve(margins: list, t: np.ndarray, t_mid: float, closure: float | None = None) -> np.ndarray:
    """(P,) at positions `t` along the eye: the opening between the traced `margins` over that under the mid-lid
    FPs (`t_mid`; `opening_profile` unclipped above), 0 at and beyond the corners and where the traced mid is shut.
    With `closure` (rad, the mid-lid FPs' own opening, which a full blink turns the lids through) over that
    instead: lids whose margins lie beyond or short of their FPs meet all the same (`seen_margins`)."""
    opening = np.interp(t, *margins[0][:2]) - np.interp(t, *margins[1][:2])
    mid = np.interp(t_mid, *margins[0][:2]) - np.interp(t_mid, *margins[1][:2]) if closure is None else closure
    if not mid > 0.0:
        return np.zeros_like(opening)
    return np.where((t > 0.0) & (t < 1.0), opening.clip(0.0) / mid, 0.0)


def _larger_of(first: Callable, second: Callable, t: np.ndarray) -> np.ndarray:
    """The larger of two `meeting_curve`s at positions `t` along the eye."""
    return np.maximum(first(t), second(t))


def arch_meeting(t: np.ndarray, t_mids: tuple[float, float]) -> np.ndarray:
    """`meeting_curve` for lids turned by sine arches (`lid_profile`, the upper's and the lower's mid at `t_mids`):
    the mean of the two arches at positions `t` along the eye."""
    return 0.5 * sum(lid_profile(t, 0.0, t_mid, 1.0) for t_mid in t_mids)


def meet_lids(rig: EyelidRig, turns: np.ndarray, up: np.ndarray, low: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lids' turns (K,) toward closure stopped where the lids meet at each vertex's place along the eye.

    `meet_at_closure` stops the lids under the mid-lid FPs; the shares `s` of the eye's opening there (c) the lids
    have closed (`turns` (2, 2) over it) say where the other lid's margin is elsewhere: at a place whose traced
    opening is o c (`EyelidRig.meeting`: o its share of the mid one) it has come s_other o c toward this one, so
    no vertex of this lid turns toward closure by more than (1 - s_other) o c less `MEET_CLEARANCE`, whatever its
    weight (the margin's weight is o: it stops at the other margin; rows behind it near the inner corner had more,
    and went through the lower lid at a full blink). With `EyelidRig.room` (r, the angle from the vertex to the other
    lid's margin on the skin; NaN where that stop does not apply, `skin_stop_room`), a vertex also turns by no more
    than r - s_other o c.
    """
    closure = np.maximum(rig.rest_angles[:, 0] - rig.rest_angles[:, 1], 1e-9)
    shares = (turns * np.array([-1.0, 1.0]) / closure[:, None])[rig.eye]  # (K, 2): how far each lid has closed
    opening = rig.meeting * closure[rig.eye]
    inside = opening > 0.0
    stop = (opening[:, None] * (1.0 - shares[:, ::-1]).clip(0.0) - MEET_CLEARANCE).clip(0.0)  # (K, 2) upper, lower
    if rig.room is not None:
        # nor past the other lid's margin as the skin shows it (`EyelidRig.room`, less the way that margin has come):
        # the opening a painted lid's weights trace runs past it where a pick is no margin (the sample's outer corner:
        # a lower-lid vertex 7 degrees below the margin), and a margin turned through the other lid folded the corner's
        # faces, which Unfold Skin then opened by pulling the margin back up. Only the skin of this lid alone, with
        # room before that margin (the rows where `room` is not NaN, `skin_stop_room`; fmin passes NaN over), and the
        # seen margin is the skin itself, so no clearance
        stop = np.fmin(stop, (rig.room - opening[:, None] * shares[:, ::-1].clip(0.0)).clip(0.0))
    up = np.where(inside & (up < 0.0), np.maximum(up, -stop[:, 0]), up)
    low = np.where(inside & (low > 0.0), np.minimum(low, stop[:, 1]), low)
    return up, low


def _turn_range(rest_angles: np.ndarray) -> np.ndarray:
    """(2, 2, 2) [eye][upper, lower][least, most] turns: through the opening and `TURN_BEYOND_CLOSURE` more
    toward the other lid, `TURN_OPENING` away from it."""
    closure = np.nan_to_num(rest_angles[:, 0] - rest_angles[:, 1], nan=0.0).clip(0.0) + TURN_BEYOND_CLOSURE
    return np.stack(
        [
            np.stack([-closure, np.full(2, TURN_OPENING)], axis=1),
            np.stack([np.full(2, -TURN_OPENING), closure], axis=1),
        ],
        axis=1,
    )


def lid_fold_rates(chart: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(T, 3) per face g: a lid turn θ with weights w at the face's corners keeps 1 + θ g · w of its normal.

    `chart` (N, 3) the points' (x, r, φ) about the eye's x axis: a turn about that axis adds θ w to φ and
    changes nothing else, so the face's normal in the chart, N + θ N', is linear in θ (a cross product of two
    edges, each linear in θ, whose θ² term is the cross product of two vectors along φ: zero). Its agreement
    with the rest normal is measured with the chart's metric at the face, diag(r², r², 1) (the normal of the
    face in space, up to the face's size), and divided by the same at rest, N·N = c0, so that 1 + θ g · w is
    the share of its normal the face keeps: 0 when it stands on edge, below 0 when it has turned over.
    """
    q = chart[triangles]
    e2, e3 = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    normal = np.cross(e2, e3)
    r2 = q[:, :, 1].mean(axis=1) ** 2
    c0 = r2 * (normal[:, 0] ** 2 + normal[:, 1] ** 2) + normal[:, 2] ** 2
    # N' = e2 × (0, 0, Δw3) + (0, 0, Δw2) × e3, Δw_k = w_k − w_1: r²(N_x N'_x + N_r N'_r) is p Δw2 + q Δw3
    p = np.divide(r2 * (normal[:, 1] * e3[:, 0] - normal[:, 0] * e3[:, 1]), c0, out=np.zeros_like(c0), where=c0 > 0)
    q_ = np.divide(r2 * (normal[:, 0] * e2[:, 1] - normal[:, 1] * e2[:, 0]), c0, out=np.zeros_like(c0), where=c0 > 0)
    return np.stack([-(p + q_), p, q_], axis=1)


def color_classes(triangles: np.ndarray, n: int) -> list[np.ndarray]:
    """The faces in classes no two of whose faces share a vertex, so a class is projected at once (in any
    order, with the same result): each round takes the faces whose fixed pseudo-random priority beats every
    other remaining face at each of their corners (Luby's rounds)."""
    remaining = np.arange(len(triangles))
    priority = (remaining.astype(np.uint64) * np.uint64(2654435761)) % np.uint64(2**32)  # a bijection: no ties
    priority = priority.astype(np.int64)
    classes = []
    while len(remaining):
        best = np.full(n, -1, np.int64)
        np.maximum.at(best, triangles[remaining].ravel(), np.repeat(priority[remaining], 3))
        wins = (best[triangles[remaining]] == priority[remaining, None]).all(axis=1)
        classes.append(remaining[wins])
        remaining = remaining[~wins]
    return classes


def fold_free_weights(
    face: np.ndarray,
    vertices: np.ndarray,
    eye: np.ndarray,
    weights: np.ndarray,
    fixed: np.ndarray,
    centres: np.ndarray,
    triangles: np.ndarray,
    turn_range: np.ndarray,
) -> np.ndarray:
    """((K, 2), (K, 2)): the upper and lower lid weights of `vertices` (K,) (of eyes `eye`) for turns toward
    closure and for turns away from it, each moved so that on every face of `triangles` (T, 3, indexing `face`
    (N, 3), face-frame points) each lid turning alone within `turn_range` (`_turn_range`) keeps at least
    1 - `FOLD_SHARE` of the face's normal (`lid_fold_rates`).

    Weights where `fixed` (K, 2) stay (the lids themselves: they set where the lids meet), the points not in
    `vertices` stay at 0, and each face's two limits are met in turn by the smallest change of its corners' free
    weights (a projection, its step times `OMEGA`), the faces in `color_classes` order, weights kept in [0, 1], for
    up to `SWEEPS` (`NUMPY_SWEEPS`) sweeps or until no face misses a limit by more than `TOLERANCE`. By the compiled
    kernel where it is available (`fused.fold_free_sweeps`: the same steps in the same order), else numpy.
    """
    n = len(face)
    inside = np.zeros(n, bool)
    inside[vertices] = True
    faces = triangles[inside[triangles].any(axis=1)]
    eye_of = np.zeros(n, np.intp)
    eye_of[vertices] = eye
    first = np.where(inside[faces[:, 0]], faces[:, 0], np.where(inside[faces[:, 1]], faces[:, 1], faces[:, 2]))
    face_eye = eye_of[first]
    g = np.empty((len(faces), 3))
    for e in (0, 1):
        on = face_eye == e
        d = face - centres[e]
        chart = np.stack([d[:, 0], np.hypot(d[:, 1], d[:, 2]), np.arctan2(d[:, 1], d[:, 2])], axis=1)
        g[on] = lid_fold_rates(chart, faces[on])
    # 1 + θ a ≥ 1 − FOLD_SHARE for θ in [least, most]: a ≥ −FOLD_SHARE / most for the turns up, a ≤ FOLD_SHARE /
    # −least for the turns down. Toward closure (the upper lid down, the lower up) and away from it the lids get
    # weights of their own, so that what turns with a rising lid (the skin above it) need not follow a blink.
    limits = turn_range[face_eye]  # (F, 2 lids, 2)
    rising, falling = -FOLD_SHARE / limits[:, :, 1], FOLD_SHARE / -limits[:, :, 0]
    free = np.zeros((n, 2), bool)
    free[vertices] = ~np.asarray(fixed, bool)
    gf = g[:, :, None] * free[faces]  # (F, 3, 2): a face's rate on its free corners' weights
    norm = (gf * gf).sum(axis=1)  # (F, 2)
    classes = color_classes(faces, n)
    out = []
    for upper_lid_up in (False, True):  # toward closure, then away from it
        lower = np.full((len(faces), 2), -np.inf)
        upper = np.full((len(faces), 2), np.inf)
        if upper_lid_up:
            lower[:, 0], upper[:, 1] = rising[:, 0], falling[:, 1]
        else:
            upper[:, 0], lower[:, 1] = falling[:, 0], rising[:, 1]
        w = np.zeros((n, 2))
        w[vertices] = weights
        arrays = (faces, g, gf, norm, lower, upper)
        if fused.fold_free_sweeps(classes, *arrays, w, SWEEPS, OMEGA, TOLERANCE) is None:
            fold_free_sweeps(classes, *arrays, w, NUMPY_SWEEPS, OMEGA, TOLERANCE)
        out.append(w[vertices])
    return out[0], out[1]


def fold_free_sweeps(classes, faces, g, gf, norm, lower, upper, w, sweeps, omega, tolerance) -> int:
    """`fold_free_weights`' sweeps in numpy, in place on `w` (N, 2); returns how many were made."""
    made = 0
    for made in range(1, sweeps + 1):  # noqa: B007 (the count is the result)
        worst = 0.0
        for members in classes:
            corners = faces[members]
            now = w[corners]  # (C, 3, 2)
            rate = g[members]
            a = rate[:, 0, None] * now[:, 0] + rate[:, 1, None] * now[:, 1] + rate[:, 2, None] * now[:, 2]
            miss = np.clip(a, lower[members], upper[members]) - a
            worst = max(worst, float(np.abs(miss).max(initial=0.0)))
            step = np.divide(miss, norm[members], out=np.zeros_like(miss), where=norm[members] > 0.0)
            w[corners] = np.clip(now + omega * gf[members] * step[:, None, :], 0.0, 1.0)
        if worst <= tolerance:
            break
    return made


def lid_turns(rig: EyelidRig, fp_positions: np.ndarray) -> np.ndarray:
    """(2, 2) turn of the upper and lower mid-lid (radians, + up) of each eye, gaze-follow and stop included.

    `fp_positions` (84, 3) current FP positions in mesh coordinates (a missing pupil: no gaze follow).
    Both eyes at once: this runs on every played frame, and on arrays this small numpy's cost is per call.
    """
    fps = np.asarray(fp_positions, dtype=np.float64)[_TURN_ROWS] @ rig.axes.T  # (2, 3, 3): upper, lower, pupil
    now = elevation(fps, rig.centres[:, None, :])
    delta = np.where(np.isfinite(now), now - rig.rest_angles, 0.0)
    up = delta[:, 0] + UPPER_FOLLOWS_PITCH * delta[:, 2]
    low = delta[:, 1] + LOWER_FOLLOWS_PITCH * delta[:, 2]
    down, rise = meet_at_closure(-up, low, rig.rest_angles[:, 0] - rig.rest_angles[:, 1])
    turns = np.stack([-down, rise], axis=1)
    if rig.turn_range is not None:  # the turns the weights are fold-free for
        turns = np.clip(turns, rig.turn_range[:, :, 0], rig.turn_range[:, :, 1])
    return turns


@functools.lru_cache(maxsize=16)
def _mid_lid_rows(control_ids: tuple[str, ...]) -> list[int]:
    return [k for k, fp_id in enumerate(control_ids) if fp_id in MID_LID_FPS]


def hold_lids(control_ids, points: np.ndarray, control_rest: np.ndarray) -> np.ndarray:
    """The control points (M, 3) with the mid-lid FPs (3.1-3.4) at rest: their motion is the lids' turn."""
    lids = _mid_lid_rows(tuple(control_ids))  # played every frame with the same ids
    if not lids:
        return points
    held = np.array(points, copy=True)
    held[lids] = control_rest[lids]
    return held


def apply_eyelids(rig: EyelidRig, out: np.ndarray, fp_positions: np.ndarray) -> None:
    """Add the lids' turn about the eye centres to the deformed positions `out` (N, 3), in place."""
    turns = lid_turns(rig, fp_positions)
    if not turns.any():  # lids at rest and the gaze level: every vertex would turn by exactly 0
        return
    turn = turns[rig.eye]  # (K, 2) each vertex's eye's upper and lower lid turn
    upper, lower = rig.upper, rig.lower
    if rig.opening is not None:  # the weights for a turn toward closure or away from it (the same at 0)
        upper = np.where(turn[:, 0] > 0.0, rig.opening[:, 0], upper)
        lower = np.where(turn[:, 1] < 0.0, rig.opening[:, 1], lower)
    up, low = upper * turn[:, 0], lower * turn[:, 1]
    if rig.meeting is not None:
        up, low = meet_lids(rig, turns, up, low)
    angle = up + low
    # the turn about the face x axis moves only y and z: add (turned - local) straight along the y and z axes,
    # without building the turned copy; c - 1 as -2 sin^2(angle / 2) keeps small turns exact
    c1, s = -2.0 * np.sin(0.5 * angle) ** 2, np.sin(angle)
    y, z = rig.local[:, 1], rig.local[:, 2]
    moved = np.empty((len(angle), 2))
    moved[:, 0] = c1 * y + s * z
    moved[:, 1] = c1 * z - s * y
    out[rig.vertices] += moved @ rig.axes[1:]
