"""How far the skin of one lip passes into the other (no bpy): the measure behind "the lips never cross".

Each lip is a sheet of skin that wraps from the face over the red of the lip into the mouth. In the face
frame (y up), a point is inside the lower lip's flesh when the first lower-lip surface straight above it
faces up (leaving the flesh upward crosses its top), and inside the upper lip's flesh when the first
upper-lip surface straight below it faces down. `lip_penetration` gives, for every vertex of one lip, that
vertical depth into the other lip (positive), or the clearance to the other lip's facing surface in its
column (negative); the vertical is the direction in which the lips close, and near their meeting line the
vertical depth and the distance to the surface agree to the slope of the red of the lip.

`guard_lips` keeps them apart on the skin. Keeping the lips' FPs in order (`decode._stop_at_closure`) is
not enough: the inner surface of each lip lies behind its control triangles and swings with them, so with
the FPs meeting, the skin still passed the other lip by 0.25 mm (OU with anger) and by up to 2.9 mm for
random lip FAPs within range. The guard runs after the deformer, on the lip vertices only: each stays on
its side of a seam between the lips, a function of x across the mouth that runs midway between the
inner-lip FPs and moves to lie between the lips where they come close.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..geometry.normals import vertex_normals
from ..geometry.pieces import connected_pieces
from ..mpeg4.feature_points import fp_index
from . import fused

MIN_PROJECTED_AREA = 1e-12  # m^2: a triangle seen edge-on from above has no height to give
BOX_MARGIN = 2e-3  # m: the mouth box reaches this far above and below the outer lip contour
EDGE_SLACK = 1e-9  # barycentric: a column this close to a triangle's edge goes through it
# The lengths in metres here are for an adult's face; a face of another size (modelled in centimetres, or
# scaled) has them in proportion to its mouth: its inner corners' distance (2.4 to 2.5) over this one.
MOUTH_WIDTH = 0.05  # m


def face_unit(corners: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> float:
    """Mesh units per metre of an adult's face, from the (2, 3) inner mouth corners 2.4, 2.5 (mesh coordinates)."""
    width = abs(float((np.asarray(corners[0], np.float64) - corners[1]) @ np.asarray(axes, np.float64)[0]))
    return width / MOUTH_WIDTH if np.isfinite(width) and width > 0.0 else 1.0


def mouth_sides(
    rest: np.ndarray,
    upper_mask: np.ndarray,
    lower_mask: np.ndarray,
    neutral: np.ndarray,
    *,
    axes: np.ndarray = BLENDER_FACE_AXES,
    triangles: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(N,) upper-lip and lower-lip vertices: the mask's side (weight above 1/2) within the mouth box.

    The box spans the mouth corners (2.4, 2.5) across, the outer lip contour (8.1 to 8.2) up and down,
    BOX_MARGIN more above and below, and reaches back to the corners (the skin inside the mouth behind the
    corners, where the two lips are one, belongs to neither). `neutral` is the (84, 3) FP rows in FP_IDS
    order (mesh coordinates).

    With the mesh's `triangles` (K, 3), the box also takes the crease behind the corners, where the lips' meeting line
    runs on into the mouth: within BOX_MARGIN in height of that line (straight between the SEAM_PAIRS' midpoints, as at
    rest), as far back as it runs on from the lips in front of the corners (joined to them along the mesh's edges
    through such vertices; session 14 stopped it BOX_MARGIN deep, and the scan's slit, 5-7 mm deeper, was then only
    carried: sheared by its walls' pushes, 9-12 crossing pairs at its left end in most demo frames; with no bound in
    depth, skin at the back of the head whose made masks say lips joined in, 80-220 mm behind). Where the lips meet
    behind the corner FPs their masks say both (ICT's inner corners: 1/2 each), so there each vertex of the lips (the
    masks' sum above 1/2) goes by the way its skin faces at rest: facing down, the upper lip's underside; facing up, the
    lower lip's top. Left out, that crease was only carried with the lips beside it, and in the smile the pushes of both
    lips sheared it through itself (ICT, demo frame 121: 10 of its 12 crossing pairs). Without the band in height, the
    scan's inner lips behind its corners' depth (its lip line rises 5 mm over the corners 10 mm in) were taken as well,
    and crossed the skin carried beside them.

    Past the corners across (within the box's height, joined to the lips), the lips' skin folded shut on itself
    (`_corner_fold`: touching a layer that faces the other way) goes by the way it faces too: only carried, each layer
    took its own mix of both lips' pushes and passed through the other (the Rocketbox's commissures, 8.4: a pair in
    21 of 60 demo frames). `bind_lip_guard` holds it to no seam (the seam ends at the corners) and keeps it off
    the other layer by the contact.
    """
    face = np.asarray(rest, dtype=np.float64) @ np.asarray(axes).T
    fps = np.asarray(neutral, dtype=np.float64) @ np.asarray(axes).T
    half_width = 0.5 * abs(fps[fp_index("2.4"), 0] - fps[fp_index("2.5"), 0])
    mid_x = 0.5 * (fps[fp_index("2.4"), 0] + fps[fp_index("2.5"), 0])
    margin = BOX_MARGIN * face_unit(np.asarray(neutral)[[fp_index("2.4"), fp_index("2.5")]], axes)
    top, bottom = fps[fp_index("8.1"), 1] + margin, fps[fp_index("8.2"), 1] - margin
    back = min(fps[fp_index("2.4"), 2], fps[fp_index("2.5"), 2])  # the lips, not the mouth's inside behind them
    box_across = np.abs(face[:, 0] - mid_x) <= half_width
    box_height = (face[:, 1] <= top) & (face[:, 1] >= bottom)
    box = box_across & box_height
    masks_sum = np.asarray(upper_mask) + np.asarray(lower_mask)
    front = box & (face[:, 2] >= back)
    lower = front & (np.asarray(lower_mask) > 0.5)
    upper = front & (np.asarray(upper_mask) > 0.5) & ~lower
    if triangles is not None:
        line = np.array([0.5 * (fps[fp_index(u)] + fps[fp_index(b)]) for u, b in SEAM_PAIRS])
        line = line[np.argsort(line[:, 0])]
        near = np.abs(face[:, 1] - np.interp(face[:, 0], line[:, 0], line[:, 1])) <= margin
        crease = box & ~front & near & (masks_sum > 0.5)
        crease &= _joined(np.asarray(triangles, np.intp), crease, upper | lower)
        normals = vertex_normals(face, np.asarray(triangles, np.intp))
        facing = normals[:, 1]
        upper |= crease & (facing < 0.0)
        lower |= crease & (facing > 0.0)
        beside = box_height & ~box_across & (masks_sum > 0.5)
        beside &= _joined(np.asarray(triangles, np.intp), beside, upper | lower)
        fold = _corner_fold(face, np.asarray(triangles, np.intp), normals, beside, margin)
        upper |= fold & (facing < 0.0)
        lower |= fold & (facing > 0.0)
    return upper, lower


def _corner_fold(face: np.ndarray, triangles: np.ndarray, normals: np.ndarray, beside: np.ndarray, unit: float):
    """(N,) bool: the lips' skin past the mouth corners across (`beside`: within the box's height, outside its width,
    the masks' sum above 1/2, joined to the lips) that touches a layer of skin facing the other way at rest, nearer than
    TOUCH_GAP along its normal (in front of it, or passed into it by less): a fold of the skin shut on itself, as where
    the Rocketbox's lips turn into each other at its commissures, the two layers 0-0.12 mm apart on one plane. The
    layer touched lies past the corners too (a triangle all of whose corners are `beside`): skin touching the lips in
    the box is their own curl (the sample's lower lip at each corner, facing down onto itself), which taken as the upper
    lip crossed in random lip-FAP frames. `face` (N, 3) the face frame, `normals` (N, 3) its vertex normals, `unit` mesh
    units of BOX_MARGIN (the box's margin)."""
    candidates = np.flatnonzero(beside & (np.linalg.norm(normals, axis=1) > 0.0))
    if not len(candidates):
        return np.zeros(len(face), bool)
    reach = TOUCH_GAP / BOX_MARGIN * unit
    tris = triangles[beside[triangles].all(axis=1)]
    ahead, behind = _along(face[candidates], -normals[candidates], face[tris], reach, True, (candidates, tris))
    touching = (ahead < reach) | (behind < reach)
    fold = np.zeros(len(face), bool)
    fold[candidates[touching]] = True
    return fold


def _joined(triangles: np.ndarray, candidates: np.ndarray, lips: np.ndarray) -> np.ndarray:
    """(N,) bool: those of the (N,) `candidates` joined to a vertex of `lips` along the edges of `triangles` (K, 3),
    through candidates (`connected_pieces`: set-up runs where the extension has no scipy wheel, windows-arm64)."""
    through = candidates | lips
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    piece = connected_pieces(len(candidates), edges[through[edges].all(axis=1)])
    return candidates & np.isin(piece, piece[lips])


def lip_penetration(
    deformed: np.ndarray,
    triangles: np.ndarray,
    upper: np.ndarray,
    lower: np.ndarray,
    *,
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> tuple[np.ndarray, np.ndarray]:
    """Signed depth of each upper-lip vertex into the lower lip and of each lower-lip vertex into the upper.

    `deformed` (N, 3) mesh positions, `triangles` (K, 3) the mesh as triangles (`folds.fan_triangles`),
    `upper` / `lower` (N,) bool the lips' vertices (`mouth_sides`). Returns two (N,) arrays in mesh units:
    positive where the vertex lies inside the other lip's flesh (the depth below its top, or above its
    bottom), negative the clearance to the other lip's facing surface in the vertex's column, NaN where the
    column misses the other lip or the vertex is not on that lip. A triangle belongs to a lip when all its
    corners do.
    """
    face = np.asarray(deformed, dtype=np.float64) @ np.asarray(axes).T
    triangles = np.asarray(triangles, dtype=np.intp)
    upper, lower = np.asarray(upper, bool), np.asarray(lower, bool)
    into_lower = np.full(len(face), np.nan)
    into_upper = np.full(len(face), np.nan)
    into_lower[upper] = _depth(face[upper], face[triangles[lower[triangles].all(axis=1)]], 1.0)
    into_upper[lower] = _depth(face[lower], face[triangles[upper[triangles].all(axis=1)]], -1.0)
    return into_lower, into_upper


def _depth(points: np.ndarray, tris: np.ndarray, up: float) -> np.ndarray:
    """(V,) signed depth of `points` into the flesh under `tris` (up = 1: flesh below their top, -1: above).

    Looking along `up` from each point, the first surface met decides: facing toward the point's side
    (its normal along `up`) means the point is in the flesh, depth = distance to it. Otherwise, looking the
    other way, the first surface facing `up` gives the clearance (negative)."""
    if len(points) == 0 or len(tris) == 0:
        return np.full(len(points), np.nan)
    usable, normal_y = _seen_from_above(tris)
    a, b, c = tris[usable, 0], tris[usable, 1], tris[usable, 2]
    wa, wb, wc = _in_columns(points, a, b, c, normal_y)
    # a column through an edge belongs to both triangles, whichever way rounding puts it
    inside = (wa >= -EDGE_SLACK) & (wb >= -EDGE_SLACK) & (wc >= -EDGE_SLACK)
    height = wa * a[:, 1] + wb * b[:, 1] + wc * c[:, 1]
    offset = up * (height - points[:, None, 1])  # > 0: the surface lies ahead, looking along `up`
    faces_up = up * normal_y > 0.0
    ahead = np.where(inside & (offset >= 0.0), offset, np.inf)
    first = ahead.argmin(axis=1)
    rows = np.arange(len(points))
    hit = np.isfinite(ahead[rows, first])
    depth = np.where(hit & faces_up[first], ahead[rows, first], np.nan)
    behind = np.where(inside & (offset < 0.0) & faces_up, -offset, np.inf)
    clearance = behind.min(axis=1)
    return np.where(np.isnan(depth) & np.isfinite(clearance), -clearance, depth)


def _seen_from_above(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T,) bool: the triangles with (T, 3, 3) `corners` that cover a column (not seen edge-on from above), and
    (T',) twice the signed xz-projected area of those: the triangle's normal y times its area (y = z cross x)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    normal_y = (b[:, 2] - a[:, 2]) * (c[:, 0] - a[:, 0]) - (b[:, 0] - a[:, 0]) * (c[:, 2] - a[:, 2])
    usable = np.abs(normal_y) > 2.0 * MIN_PROJECTED_AREA
    return usable, normal_y[usable]


def _in_columns(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, normal_y: np.ndarray) -> tuple:
    """(P, T) barycentric coordinates of the (P, 3) points in the xz plane (the vertical column through each) in the
    triangles with (T, 3) corners a, b, c and twice their signed xz-projected areas `normal_y`."""
    px, pz = points[:, None, 0], points[:, None, 2]
    wb = ((pz - a[:, 2]) * (c[:, 0] - a[:, 0]) - (px - a[:, 0]) * (c[:, 2] - a[:, 2])) / normal_y
    wc = ((b[:, 2] - a[:, 2]) * (px - a[:, 0]) - (b[:, 0] - a[:, 0]) * (pz - a[:, 2])) / normal_y
    return 1.0 - wb - wc, wb, wc


# The seam between the lips, right corner to left corner: (upper inner FP, lower inner FP) pairs
SEAM_PAIRS = (("2.5", "2.5"), ("2.7", "2.9"), ("2.2", "2.3"), ("2.6", "2.8"), ("2.4", "2.4"))
SEAM_STEPS = 4  # seam knots from one SEAM_PAIRS pair to the next
N_KNOTS = SEAM_STEPS * (len(SEAM_PAIRS) - 1) + 1
CHORDS = (0.5, 1.0)  # half-widths of the seam's chords that bound each lip, x the other lip's reach
ENDS = np.array([0.0, *(end for half in CHORDS for end in (-half, half))])  # the seam's point, chords' ends
SHIFTS = np.unique(ENDS)  # where the bounds bend, x the reach from the seam's knots
CARRY_RADIUS = 8e-3  # m along the skin: beside the lips, how far their push reaches
CARRY_SOURCES = 3  # the guarded vertices nearest a carried one that share their push with it (and any tied)
TIE = 1e-12  # m: distances along the skin this close are one
LOWER_SHIFT = 1e6  # face x, beyond any mesh: the lower lip's bound is looked up past the upper lip's
NO_PAIRS = np.zeros((0, 2), np.intp)  # `_carry` with no (vertex, guarded vertex) pairs
# a lip vertex this close in front of its lip's triangle, x the triangle's longest edge, is a sliver folded onto it
# (`_shadowed`); farther, a layer of its own (the 2 mm remesh's fused lips: 0.55 and more; with those too, the guard's
# rounds and Unfold Skin's fought to the frame's budget, leaving 2 faces turned over in joy.fap)
SLIVER = 0.25
TOUCH_GAP = 5e-4  # m: lips this close at rest touch (`Contact.keep`); the mesh's own gaps there are kept
EDGE_ON = 1e-9  # a triangle whose normal is this near square to the way a vertex looks is seen edge-on
CONTACT_REACH = 2e-3  # m: how far into the other lip a vertex of the contact is looked for (`press_apart`)
# m: lips pressed onto each other are kept this far apart, half of it on each side of the seam (`guard_lips`) and all of
# it from the other lip's skin in the contact (`press_apart`). Pressed exactly onto the one seam (or onto the other
# lip's skin at its samples), the two faceted sheets lay on each other and crossed wherever rounding or a facet between
# samples put them: ICT's demo frame 84, 19 pairs in the middle of the mouth, where its lips are parted at rest (with
# 1e-7 m on each side of the seam, none); and at the contact between its samples, 2 with 1e-7 m, 1 with 1e-6, none with
# 3e-6. A hundredth of a millimetre is nothing any render shows.
MEET_GAP = 1e-5


@dataclass(frozen=True)
class Contact:
    """The guarded vertices past the seam at rest (slack < 0) and the other lip's skin they are kept out of.

    Where the lips touch over a surface that is not a function of x alone (a closed mouth whose lower lip tucks in
    behind the upper one, the Rocketbox's lips overlapping 2 mm in height; a sealed lip crease whose walls are
    bumpy, the Lee Perry-Smith scan), every vertex of the contact past the seam keeps its rest offset as slack, and
    a slack says nothing of where the other lip is: lips sliding on each other in depth or across passed through
    each other there, both sides held at their bounds (session 11). These vertices, and the other lip's at the same
    seam knots, are kept out of the other lip's flesh, on the other lip's own triangles as they are deformed, and where
    they touch it at rest (closer than TOUCH_GAP: ICT's closed lips 0.1-0.4 mm apart at the corners) no closer than at
    rest: kept only out of the other lip, the edges between crossed it. The depth is taken square to the contact, along
    the skin's own normal into its lip (session 12): straight up or down, a contact that turns steep (the Rocketbox's
    corners in the smile) gave depths at rest that were the slope's, not the lips' (a vertical column grazing the other
    lip), kept as allowances. And it is taken at the vertices and midway along the edges between them: crossings
    between vertices each out of the other lip were most of what was left. Lips that pass into each other at rest by
    less than a touch are parted to touching once they move (kept as deep, the overlap slid along and crossed anew)."""

    rows: np.ndarray  # (P,) rows into `LipGuard.vertices`: the upper lip's in the contact, then the lower lip's
    vertices: np.ndarray  # (P,) their mesh vertices
    look: np.ndarray  # (S,) per sample (`ends`): 1 on the upper lip (looking at the lower lip's triangles), -1 lower
    keep: np.ndarray  # (S,) each sample's depth into the other lip at rest along `direction` (< 0: a clearance kept)
    triangles: np.ndarray  # (T, 3) the lower lip's triangles, then the upper lip's: the other lip's skin
    facing: np.ndarray  # (T,) 1 on the lower lip (looked at from the upper), -1 on the upper
    direction: np.ndarray  # (S, 3) unit, face frame: into the sample's own lip at rest (minus the skin's normal)
    reach: float  # how far along `direction` the other lip is looked for (mesh units): CONTACT_REACH, and the keeps
    ends: np.ndarray  # (S, 2) the samples: midway between these two of `vertices` (a vertex: itself twice)


@dataclass(frozen=True)
class LipGuard:
    """The lip vertices kept on their side of the seam between the lips (`bind_lip_guard`)."""

    vertices: np.ndarray  # (V,) mesh vertices of both lips, the upper lip's first
    n_upper: int  # how many of `vertices` are on the upper lip
    side: np.ndarray  # (V,) 1 on the upper lip, -1 on the lower
    # (V,) how far a vertex must stay on its side of the seam: MEET_GAP / 2, or less where it lies closer at rest, and
    # negative where it lies past the seam at rest (where the lips touch, at the corners): that much past it is kept
    slack: np.ndarray
    spread: np.ndarray  # (N_KNOTS, M) the seam's knots as weights of the control points (before adapting)
    knots: np.ndarray  # (J,) the seam knots with vertices of both lips near them at rest
    order: np.ndarray  # rows into `vertices`: the upper-lip ones near each of `knots`, knot after knot, then
    starts: np.ndarray  # the lower-lip ones likewise; (2J,) where each run starts in `order`
    axes: np.ndarray  # (3, 3) the face frame (rows x, y up, z forward in mesh coordinates)
    reach: tuple[float, float]  # the widest triangle of the lower / upper lip across (face x) at rest
    width: float  # the seam's width at rest (face x, corner to corner)
    shift: np.ndarray  # (V,) 0 on the upper lip, LOWER_SHIFT (x unit) on the lower
    unit: float  # mesh units per metre of an adult's face (`face_unit`)
    skin: np.ndarray  # (V + C,) `vertices`, then the skin beside them (within CARRY_RADIUS) that follows
    sources: np.ndarray  # (CARRY_SOURCES, V + C) rows into `vertices`: whose push each of `skin` shares
    shares: np.ndarray  # (CARRY_SOURCES, V + C) how much (signed: along a guarded vertex's side, else face up)
    lift: tuple[tuple[np.ndarray, float], ...]  # (flat index of `skin` along a mesh axis, the face's up on it)
    # where the seam does not part the lips at rest (`Contact`): each kept out of the other lip's own surface
    contact: Contact | None = None


def seam(guard: LipGuard, points: np.ndarray, signed_y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N_KNOTS,) x and height of the seam's knots in the face frame, from the control points (M, 3) and
    the guarded vertices' heights times their side, `signed_y` (V,).

    Between each SEAM_PAIRS pair's midpoints the seam runs straight, SEAM_STEPS knots to a stretch. A knot
    with both lips near it then moves to lie between them: between the lowest upper-lip and the highest
    lower-lip vertex near it, as close to the midpoint as that allows, or where they overlap, within the
    overlap. So the seam moves no vertex where the lips are apart, and where they overlap it splits the
    overlap by where the FPs meet. The knots' x is made non-decreasing (a corner stretched inward past
    the next pair) so the seam stays a function of x."""
    knots = guard.spread @ points @ guard.axes[:2].T
    x, y = np.maximum.accumulate(knots[:, 0]), knots[:, 1]
    if len(guard.knots):
        high, low = np.minimum.reduceat(signed_y.take(guard.order), guard.starts).reshape(2, -1)
        low = -low  # the lower lip's runs took the least of -y
        y[guard.knots] = np.minimum(np.maximum(y[guard.knots], np.minimum(low, high)), np.maximum(low, high))
    return x, y


def bind_lip_guard(
    rest: np.ndarray,
    control_rest: np.ndarray,
    fp_ids: tuple[str, ...],
    triangles: np.ndarray,
    upper: np.ndarray,
    lower: np.ndarray,
    *,
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> LipGuard:
    """The guard for the lips' vertices `upper` / `lower` (N,) bool (`mouth_sides`) of the mesh `rest`
    (N, 3) with `triangles` (K, 3), over the control points `control_rest` (M, 3) named `fp_ids`, which
    must include the inner-lip FPs 2.2-2.9.

    A vertex is near the seam knot nearest to it across the mouth, at rest. A vertex still past the seam at rest (where
    the lips touch, at the corners) keeps that much as slack; the others stay half of MEET_GAP on their side of it (or
    as close as they lie at rest), so that lips pressed onto it are that far apart, not on each other. A lip vertex with
    its own lip's skin straight past it toward the other lip, or behind it (`_shadowed`: a fold, as at the mouth's
    corners) is carried with the skin beside the lips, not guarded."""
    rows = {fp_id: k for k, fp_id in enumerate(fp_ids)}
    upper_all, lower_all = upper, lower
    upper, lower = np.asarray(upper, bool), np.asarray(lower, bool) & ~np.asarray(upper, bool)
    axes = np.asarray(axes, dtype=np.float64)
    face_rest = np.asarray(rest, dtype=np.float64) @ axes.T
    steps = np.arange(N_KNOTS) / SEAM_STEPS
    spread = np.zeros((N_KNOTS, len(control_rest)))
    for k, (u, b) in enumerate(SEAM_PAIRS):
        share = 0.5 * np.interp(steps, np.arange(len(SEAM_PAIRS)), np.eye(len(SEAM_PAIRS))[k])
        spread[:, rows[u]] += share
        spread[:, rows[b]] += share
    knots_x = spread @ np.asarray(control_rest, dtype=np.float64) @ axes[0]
    tris = np.asarray(triangles, dtype=np.intp)
    reach = tuple(
        float(np.ptp(face_rest[tris[lip[tris].all(axis=1)], 0], axis=1).max(initial=0.0)) for lip in (lower, upper)
    )
    # where a lip's skin overlaps itself seen from above (the fold where the lip's skin turns up into a mouth corner),
    # the layer toward the other lip is what meets it: the layer behind is carried with the skin over it, not pushed
    # on its own, which moved the layers by different amounts, through each other; a lone vertex over its lip's
    # triangle (a jittered subdivision's quad folded onto itself) pushes that triangle's corners as far as itself
    (shadowed_upper, over_upper), (shadowed_lower, over_lower) = (
        _shadowed(face_rest, tris, upper, -1.0),
        _shadowed(face_rest, tris, lower, 1.0),
    )
    upper, lower = upper & ~shadowed_upper, lower & ~shadowed_lower
    vertices = np.concatenate([np.flatnonzero(upper), np.flatnonzero(lower)])
    n_upper = int(upper.sum())
    side = np.where(np.arange(len(vertices)) < n_upper, 1.0, -1.0)
    face = face_rest[vertices]
    nearest = np.rint(np.interp(face[:, 0], knots_x, np.arange(N_KNOTS, dtype=np.float64))).astype(np.intp)
    # the seam runs from corner to corner: lip skin past a corner across (a fold there, `mouth_sides`) has no seam to
    # keep to; the contact keeps it off the other layer, and no knot moves for it
    beyond = (face[:, 0] < knots_x[0]) | (face[:, 0] > knots_x[-1])
    nearest[beyond] = -1
    knots = [k for k in range(N_KNOTS) if np.any((nearest == k) & (side > 0)) and np.any((nearest == k) & (side < 0))]
    members = [np.flatnonzero((side == s) & (nearest == k)) for s in (1.0, -1.0) for k in knots]
    unit = face_unit(np.asarray(control_rest)[[rows["2.4"], rows["2.5"]]], axes)
    carry = _carry(rest, tris, vertices, side, unit, np.concatenate([over_upper, over_lower]))
    guard = LipGuard(
        vertices=vertices,
        n_upper=n_upper,
        side=side,
        slack=np.zeros(len(vertices)),
        spread=spread,
        knots=np.array(knots, dtype=np.intp),
        order=np.concatenate(members).astype(np.intp) if knots else np.zeros(0, np.intp),
        starts=np.cumsum([0] + [len(m) for m in members[:-1]]).astype(np.intp),
        axes=axes,
        reach=reach,
        width=float(knots_x[-1] - knots_x[0]),
        shift=np.where(side > 0.0, 0.0, LOWER_SHIFT * unit),
        unit=unit,
        **carry,
        lift=tuple((3 * carry["skin"] + axis, float(axes[1, axis])) for axis in np.flatnonzero(axes[1])),
    )
    signed_y = side * face[:, 1]
    clearance = signed_y - _bound(guard, face[:, 0].copy(), *seam(guard, control_rest, signed_y))
    slack = np.where(beyond, -np.inf, np.minimum(clearance, 0.5 * MEET_GAP * unit))
    lips = (np.asarray(upper_all, bool), np.asarray(lower_all, bool) & ~np.asarray(upper_all, bool))
    past = np.isin(nearest, nearest[(slack < 0.0) & ~beyond]) & ~beyond | beyond
    contact = _contact(face_rest, tris, vertices, n_upper, past, lips, unit)
    return LipGuard(**{**guard.__dict__, "slack": slack, "contact": contact})


def _contact(
    face: np.ndarray,
    triangles: np.ndarray,
    vertices: np.ndarray,
    n_upper: int,
    past: np.ndarray,
    lips: tuple,
    unit: float,
) -> Contact | None:
    """The `Contact` of the guarded `vertices` (the first `n_upper` on the upper lip) flagged in (V,) bool `past`, at
    rest in the (N, 3) face frame; the other lip's triangles are those with every corner on it (`lips`: (upper, lower)
    (N,) bool, the mouth's sides before the layers behind a fold were left to the carry). None where none is."""
    rows = (np.flatnonzero(past[:n_upper]), n_upper + np.flatnonzero(past[n_upper:]))
    if not (len(rows[0]) or len(rows[1])):
        return None
    other = tuple(triangles[lip[triangles].sum(axis=1) >= 2] for lip in (lips[1], lips[0]))
    # the clearance kept is a touch: closer than TOUCH_GAP at rest (ICT's corners 0.1-0.4 mm); farther (the sample's
    # lower lip 3.8 mm under the upper at a corner), the lips may come closer as they press, as the seam lets them
    touch, gap = TOUCH_GAP * unit, MEET_GAP * unit  # farther apart they may come as close as MEET_GAP
    normals = vertex_normals(face, triangles)
    look = np.repeat([1.0, -1.0], [len(rows[0]), len(rows[1])])
    chosen = vertices[np.concatenate(rows)]
    direction = np.concatenate([_inward(normals[chosen[look == up]], up) for up in (1.0, -1.0)])
    # where the vertices are, and midway along the mesh's edges between two of them on one lip: an edge between two
    # vertices each out of the other lip crossed it (the Rocketbox's corners in the smile, ICT's)
    local = np.full(len(face), -1, np.intp)
    local[chosen] = np.arange(len(chosen))
    edges = np.sort(local[np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])], axis=1)
    edges = np.unique(edges[(edges[:, 0] >= 0) & (look[edges[:, 0]] == look[edges[:, 1]])], axis=0)
    ends = np.concatenate([np.repeat(np.arange(len(chosen))[:, None], 2, axis=1), edges])
    ends = ends[np.argsort(-look[ends[:, 0]], kind="stable")]  # the upper lip's first
    sample_look = look[ends[:, 0]]
    towards = direction[ends].sum(axis=1)
    towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-300)
    at = face[chosen][ends].mean(axis=1)
    keep = np.zeros(len(ends))
    for up, t in zip((1.0, -1.0), other, strict=True):
        mine = sample_look == up
        ahead, behind = _along(at[mine], towards[mine], face[t], CONTACT_REACH * unit, behind=True)
        keep[mine] = np.where(np.isfinite(ahead), ahead, np.where(behind < touch, -behind, -gap))
    # lips that pass into each other at rest by less than a touch (the Rocketbox's corners, 0.1 mm) touch there: they
    # are parted to touching (MEET_GAP apart) once the lips move, as an overlap kept slid along with them and crossed
    # anew (the Rocketbox's demo: 19 pairs kept as deep as at rest, 5 parted); deeper, the lips are one there (the
    # scan's sealed crease: pushed apart, they tore it)
    keep[(keep > 0.0) & (keep < touch)] = -gap
    return Contact(
        rows=np.concatenate(rows),
        vertices=chosen,
        look=sample_look,
        keep=keep,
        triangles=np.concatenate(other),
        facing=np.repeat([1.0, -1.0], [len(other[0]), len(other[1])]),
        direction=towards,
        reach=float(CONTACT_REACH * unit + np.abs(keep).max(initial=0.0)),
        ends=ends,
    )


def _inward(normals: np.ndarray, up: float) -> np.ndarray:
    """(P, 3) unit: into the lip's flesh at each vertex, away from the other lip (minus the skin's `normals`); where
    the skin has no normal or its normal faces the lip's own side (a flap turned into the mouth), straight along its
    side (`up` 1: the upper lip's, -1: the lower's): the seam's own direction."""
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    inward = -normals / np.maximum(length, 1e-300)
    straight = (length[:, 0] <= 0.0) | (up * inward[:, 1] <= 0.0)
    inward[straight] = (0.0, up, 0.0)
    return inward


def _along(
    points: np.ndarray,
    direction: np.ndarray,
    tris: np.ndarray,
    reach: float,
    behind: bool = False,
    own: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Along each of the (P, 3) unit `direction` from the (P, 3) `points` (face frame), the first of the (T, 3, 3)
    `tris` (the other lip's skin) within `reach`: (P,) its distance where it faces along the direction (the point is in
    the other lip's flesh, as deep; +inf where none faces so or none is met), and with `behind`, (P,) the distance back
    within `reach` to the nearest one behind that faces along it (the clearance; +inf where none). Only the (point,
    triangle) pairs whose boxes meet are looked at (the stretch looked along, the triangle's), found through bins of x
    (`_boxes_meeting`): on ICT's head about 700 of 620,000. `own`: (P,) the points' vertices and (T, 3) the triangles'
    corners, a point not looking at the triangles it is a corner of."""
    ahead = np.full(len(points), np.inf)
    back = np.full(len(points), np.inf)
    if not len(points) or not len(tris) or not np.isfinite(reach) or not np.isfinite(points).all():
        return ahead, back
    reach_box = (reach if behind else 0.5 * reach) * np.abs(direction)  # the stretch ahead, or with `behind` as far
    middle = points if behind else points + 0.5 * reach * direction  # back too
    point, tri = _boxes_meeting(middle - reach_box, middle + reach_box, tris.min(axis=1), tris.max(axis=1))
    if own is not None:  # (P,) the points' vertices, (T, 3) the triangles' corners: a vertex's own fan is not looked at
        other = (own[1][tri] != own[0][point, None]).all(axis=1)
        point, tri = point[other], tri[other]
    if not len(point):
        return ahead, back
    ax, ay, az = tris[tri, 0].T
    e1x, e1y, e1z = tris[tri, 1].T - (ax, ay, az)
    e2x, e2y, e2z = tris[tri, 2].T - (ax, ay, az)
    dx, dy, dz = direction[point].T
    hx, hy, hz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x  # d x e2
    det = e1x * hx + e1y * hy + e1z * hz  # e1 . (d x e2) = -d . (e1 x e2): less than 0 where it faces along d
    square = (e1x * e1x + e1y * e1y + e1z * e1z) * (e2x * e2x + e2y * e2y + e2z * e2z)
    ok = det * det > EDGE_ON * EDGE_ON * square  # else seen edge-on
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    sx, sy, sz = points[point].T - (ax, ay, az)
    u = inv * (sx * hx + sy * hy + sz * hz)
    qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x  # s x e1
    v = inv * (dx * qx + dy * qy + dz * qz)
    t = inv * (e2x * qx + e2y * qy + e2z * qz)
    hit = ok & (u >= -EDGE_SLACK) & (v >= -EDGE_SLACK) & (u + v <= 1.0 + EDGE_SLACK)  # an edge is both triangles'
    along = det < 0.0  # faces along the direction
    first = np.full(len(points), np.inf)
    forward = hit & (t >= 0.0) & (t <= reach)
    np.minimum.at(first, point[forward], t[forward])
    # the nearest surface ahead decides: the flesh's when it faces along the direction
    facing = np.full(len(points), np.inf)
    decides = forward & along & (t <= first[point])
    np.minimum.at(facing, point[decides], t[decides])
    ahead = np.where(facing <= first, facing, np.inf)
    if behind:
        backward = hit & (t < 0.0) & (-t <= reach) & along
        np.minimum.at(back, point[backward], -t[backward])
    return ahead, back


def _boxes_meeting(low: np.ndarray, high: np.ndarray, box_low: np.ndarray, box_high: np.ndarray) -> tuple:
    """(K,) rows of the (P, 3) boxes `low`-`high` and (K,) rows of the (T, 3) boxes `box_low`-`box_high` that meet, each
    pair once: found through bins of x as wide as the median box (at least the span over T: T^2 pairs at most, as every
    pair), each pair in the first bin both cover, then kept where the boxes meet (on ICT's head about 700 pairs of
    620,000; the pairs sharing a bin, some 50,000, are most of the contact's cost; cells of x and z cost more, the
    stretches looked along being longer than the triangles are wide)."""
    origin = min(low[:, 0].min(), box_low[:, 0].min())
    span = max(high[:, 0].max(), box_high[:, 0].max()) - origin
    width = max(float(np.median(box_high[:, 0] - box_low[:, 0])), span / len(box_low), 1e-300)

    def spread(lo: np.ndarray, hi: np.ndarray) -> tuple:
        first = ((lo[:, 0] - origin) // width).astype(np.int64)
        count = ((hi[:, 0] - origin) // width).astype(np.int64) - first + 1
        bins = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())
        return bins, np.repeat(np.arange(len(lo)), count), first

    box_bins, box_of, box_first = spread(box_low, box_high)
    order = np.argsort(box_bins, kind="stable")
    box_bins, box_of = box_bins[order], box_of[order]
    bins, of, first = spread(low, high)
    begin, end = np.searchsorted(box_bins, bins, "left"), np.searchsorted(box_bins, bins, "right")
    found = end - begin
    point, shared = np.repeat(of, found), np.repeat(bins, found)
    tri = box_of[np.repeat(begin - np.cumsum(found) + found, found) + np.arange(found.sum())]
    once = shared == np.maximum(first[point], box_first[tri])
    point, tri = point[once], tri[once]
    for axis in (1, 2, 0):  # one axis at a time, on what is left (a column each: 3x faster than the boxes at once)
        meet = (low[point, axis] <= box_high[tri, axis]) & (high[point, axis] >= box_low[tri, axis])
        point, tri = point[meet], tri[meet]
    return point, tri


def _shadowed(face: np.ndarray, triangles: np.ndarray, lip: np.ndarray, toward: float) -> tuple:
    """Where the skin of `lip` (N,) bool overlaps itself, looking along `toward` (1: the face's up, from the lower lip;
    -1: down, from the upper) at rest in the (N, 3) face frame. (N,) bool: the lip's vertices over which lies a
    triangle of the same lip that is not their own (the layer behind a fold). (P, 2): (corner, vertex) pairs, a
    lip vertex straight in front of a triangle of its lip that is not its own, closer to it than SLIVER x its longest
    edge, and that triangle's corners on the lip: a sliver of the lip folded onto it that covers none of its corners,
    as a jittered subdivision's quad whose fourth corner lies 0.2 mm over its other triangle, 0.03 of its longest
    edge (pushed toward its side 0.13 mm more than them, the corner went through). A triangle is the lip's with two
    of its corners on it: the mouth box ends at the corners' x, and the lip's skin there has a corner past it."""
    lip = np.asarray(lip, bool)
    tris = triangles[lip[triangles].sum(axis=1) >= 2]
    seen, normal_y = _seen_from_above(face[tris])
    tris = tris[seen]
    a, b, c = (face[tris[:, k]] for k in range(3))
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1)], 0)
    shadowed = np.zeros(len(face), bool)
    over = [np.zeros((0, 2), np.intp)]
    for chunk in np.array_split(np.flatnonzero(lip), max(1, int(lip.sum()) // 256)):
        wa, wb, wc = _in_columns(face[chunk], a, b, c, normal_y)
        height = toward * (wa * a[:, 1] + wb * b[:, 1] + wc * c[:, 1] - face[chunk, None, 1])
        inside = (wa > EDGE_SLACK) & (wb > EDGE_SLACK) & (wc > EDGE_SLACK)  # strictly: a flat lip shadows nothing
        inside &= ~(tris[None] == chunk[:, None, None]).any(axis=2)
        shadowed[chunk] = (inside & (height > 0.0)).any(axis=1)
        vertex, triangle = np.nonzero(inside & (height < 0.0) & (-height < SLIVER * longest))
        corners = tris[triangle]
        pairs = np.stack([corners.ravel(), np.repeat(chunk[vertex], 3)], axis=1)
        over.append(pairs[lip[pairs[:, 0]]])
    return shadowed, np.unique(np.concatenate(over), axis=0)


def guard_lips(guard: LipGuard, out: np.ndarray, points: np.ndarray) -> bool:
    """Keep each lip's vertices on their side of the seam, in place on the deformed (N, 3) `out`; True when
    it moved any (`guard.skin`, the vertices it may move).

    `points` are the control points as deformed (the FP positions the deformer was given). A vertex that has passed the
    seam (more than it did at rest) moves straight up or down onto it (half of MEET_GAP on its own side): the lips press
    on each other there instead of passing through. The skin beside it follows with a share of that push that fades
    along the skin (`_carry`), so the faces between do not turn over. Continuous (clamps, minima, maxima and fixed
    weights), and mirror-symmetric for a mirror-symmetric face and mesh, as the seam's knots come in mirror pairs and
    tied distances along the skin share alike.
    """
    x, y = guard.axes[:2].astype(out.dtype) @ out.take(guard.vertices, axis=0).T  # take: 3x faster than out[...]
    signed_y = guard.side * y
    past = guard.slack - signed_y + _bound(guard, x, *seam(guard, points, signed_y))
    if past.max(initial=0.0) <= 0.0:
        return False
    _push(guard, out, np.maximum(past, 0.0))
    return True


def press_apart(guard: LipGuard, out: np.ndarray, native: bool = True) -> bool:
    """Keep the vertices of `guard.contact`, and the middles of the edges between them, out of the other lip's flesh
    (the depth square to the contact, `_along`, less what they had at rest beyond a touch) and as far from it as at rest
    where they touched it, in place on the deformed (N, 3) `out`, after `guard_lips`: each vertex moves into its own
    lip by the most any of its samples lacks, the skin beside it following as it follows the seam's push
    (`_push_along`). True when it moved any. Pushes only part the lips (each into its own lip, away from the other).

    `native`: by the compiled kernel where it is (`fused.press_apart_into`, native/lip_guard.h: the same result bit
    for bit; on the shared heads' demo 0.4-0.8 ms a call against numpy's 9-20 ms; the arrays it takes are made at the
    first call and kept with the guard); else, and as its reference, by numpy here, whose sums over the three axes
    are written out in the kernel's order."""
    contact = guard.contact
    if contact is None or not len(contact.triangles):
        return False
    if native:
        moved = fused.press_apart_into(_contact_arrays(guard, out), out)
        if moved is not None:
            return moved
    axes = guard.axes
    face = _in_frame(out.take(contact.vertices, axis=0).astype(np.float64), axes)
    points = (face[contact.ends[:, 0]] + face[contact.ends[:, 1]]) / 2.0
    corners = _in_frame(out.take(contact.triangles.ravel(), axis=0).astype(np.float64), axes).reshape(-1, 3, 3)
    # a clearance at rest is looked from that far back toward the other lip
    start = points + np.minimum(contact.keep, 0.0)[:, None] * contact.direction
    depth = np.zeros(len(points))
    for look in (1.0, -1.0):
        rows = np.flatnonzero(contact.look == look)
        ahead, _ = _along(start[rows], contact.direction[rows], corners[contact.facing == look], contact.reach)
        depth[rows] = np.where(np.isfinite(ahead), ahead, 0.0)
    lacks = np.maximum(depth - np.maximum(contact.keep, 0.0), 0.0)
    if lacks.max(initial=0.0) <= 0.0:
        return False
    # each vertex moves by the most any of its samples lacks (an edge's two ends both: its middle moves as far), along
    # the samples' mean direction weighted by what each lacks
    moves = np.zeros((len(contact.vertices), 3))
    push = np.zeros(len(contact.vertices))
    for k in range(2):
        np.maximum.at(push, contact.ends[:, k], lacks)
        np.add.at(moves, contact.ends[:, k], lacks[:, None] * contact.direction)
    norm = np.sqrt(moves[:, 0] * moves[:, 0] + moves[:, 1] * moves[:, 1] + moves[:, 2] * moves[:, 2])
    along = moves / np.maximum(norm, 1e-300)[:, None]
    pushes = np.zeros(len(guard.vertices))
    pushes[contact.rows] = push
    directions = np.zeros((len(guard.vertices), 3))
    directions[contact.rows] = along
    _push_along(guard, out, pushes, directions)
    return True


def _contact_arrays(guard: LipGuard, out: np.ndarray | None = None) -> fused.ContactArrays:
    """The guard's contact and carry as the kernel takes them, made once (the other lip's triangles first sorted as
    they lie in `out`) and kept with the guard: they are its own state, as the kernel's order of the triangles is from
    call to call, so they go in its __dict__ (the dataclass is frozen; dataclasses.replace makes a guard without)."""
    arrays = guard.__dict__.get("_contact_arrays")
    if arrays is None:
        c = guard.contact
        arrays = fused.ContactArrays.of(
            c.vertices, c.rows, c.ends, c.look, c.keep, c.direction, c.triangles, c.facing, c.reach, guard.axes,
            len(guard.vertices), guard.skin, guard.sources, guard.shares, out,
        )  # fmt: skip
        guard.__dict__["_contact_arrays"] = arrays
    return arrays


def _in_frame(points: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(P, 3) mesh `points` in the face frame, `points @ axes.T` with each sum written out (a matrix product's order
    is the BLAS's: the kernel's twin sums in this one)."""
    return np.stack([points[:, 0] * a[0] + points[:, 1] * a[1] + points[:, 2] * a[2] for a in axes], axis=1)


def _push_along(guard: LipGuard, out: np.ndarray, push: np.ndarray, directions: np.ndarray) -> None:
    """`_push`, each guarded vertex moved by its (V,) `push` along its (V, 3) unit `directions` (face frame) instead
    of straight along its side, and the skin beside the lips by its shares of those moves, in place on `out`. The sums
    run source after source and axis after axis, as in the kernel's twin (`pbk_press_apart`)."""
    weight = np.abs(guard.shares) * push.take(guard.sources)  # (k, V + C)
    step = np.zeros((len(guard.skin), 3))
    for k in range(len(guard.sources)):
        term = weight[k][:, None] * directions.take(guard.sources[k], axis=0)
        step = term if k == 0 else step + term
    n = len(guard.vertices)
    own = step[:n]
    short = push - (own[:, 0] * directions[:, 0] + own[:, 1] * directions[:, 1] + own[:, 2] * directions[:, 2])
    step[:n] = own + directions * np.maximum(short, 0.0)[:, None]
    a = guard.axes
    moved = np.stack([step[:, 0] * a[0, m] + step[:, 1] * a[1, m] + step[:, 2] * a[2, m] for m in range(3)], axis=1)
    out[guard.skin] += moved.astype(out.dtype)


def _push(guard: LipGuard, out: np.ndarray, push: np.ndarray) -> None:
    """Move each guarded vertex by its (V,) `push` (>= 0) toward its side, and the skin beside the lips by its
    shares of the pushes (`_carry`), along the face's up, in place on `out`."""
    step = (guard.shares * push.take(guard.sources)).sum(axis=0)  # (k, V + C): 3x faster than (V + C, k)
    n = len(guard.vertices)
    step[:n] = guard.side * np.maximum(push, step[:n])
    if out.flags.c_contiguous:  # along the face's up, by flat index: 3x faster than out[rows] +=
        flat = out.reshape(-1)
        for rows, part in guard.lift:
            flat.put(rows, flat.take(rows) + step * part)
    else:
        out[guard.skin] += step[:, None] * guard.axes[1]


def _carry(
    rest: np.ndarray,
    triangles: np.ndarray,
    vertices: np.ndarray,
    side: np.ndarray,
    unit: float,
    over: np.ndarray = NO_PAIRS,
) -> dict:
    """The skin that follows the guard's push (`LipGuard.skin`, `sources`, `shares`).

    Each vertex within CARRY_RADIUS along the mesh's edges of the guarded `vertices` takes the average of
    the pushes of its CARRY_SOURCES nearest guarded vertices, each weighted by 1 - smoothstep(d / radius) of
    its distance d along the skin, times the largest of those weights: the push fades out smoothly over the
    skin instead of folding the faces beside a pushed vertex. Beside the lips, vertices of both lips share
    (where a push up meets a push down, at the mouth's corners, they cancel); a guarded vertex shares only
    its own lip's pushes (toward its side: never toward the other lip) and moves by its own or the shared
    push, whichever is more. `over` (P, 2) (vertex, guarded vertex) pairs (`_shadowed`: a triangle's corner and a
    vertex of its lip straight in front of the triangle): such a vertex also takes the mean push of the guarded
    vertices in front of it, on top of its share (a triangle with one vertex in front of it moves at least as far as
    that vertex, and stays behind it). Taking that mean instead of the share left the corners' neighbours behind:
    the jittered subdivision's mouth corner then crossed 2 pairs where it had crossed none."""
    rest = np.asarray(rest, dtype=np.float64)
    n = len(rest)
    radius = CARRY_RADIUS * unit
    near = np.zeros(n, bool)  # no path along the edges as long as CARRY_RADIUS leaves the lips' box grown by it
    if len(vertices):
        low, high = rest[vertices].min(axis=0) - radius, rest[vertices].max(axis=0) + radius
        near = np.all((rest >= low) & (rest <= high), axis=1)
    tris = triangles[near[triangles].all(axis=1)]
    pairs = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]).astype(np.int64)
    key = np.unique(np.concatenate([pairs[:, 0] * n + pairs[:, 1], pairs[:, 1] * n + pairs[:, 0]]))
    begin, end = np.divmod(key, n)  # each edge both ways, by start then end
    length = np.linalg.norm(rest[begin] - rest[end], axis=1)

    def graph(keep: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return np.searchsorted(begin[keep], np.arange(n + 1)), end[keep], length[keep]

    k = CARRY_SOURCES
    beside = _nearest(graph(np.ones(len(key), bool)), vertices, k, unit)
    skin = [vertices.tolist(), sorted(set(beside) - set(vertices.tolist()))]
    lists = [[] for _ in vertices]
    for lip in (1.0, -1.0):
        rows = np.flatnonzero(side == lip)
        on_lip = np.zeros(n, bool)
        on_lip[vertices[rows]] = True
        # along the lip's own edges: the nearest of its vertices are its neighbours on it (3x faster than
        # searching the skin beside it too, at 68k vertices)
        own = _nearest(graph(on_lip[begin] & on_lip[end]), vertices[rows], k + 1, unit)
        for row, v in zip(rows.tolist(), vertices[rows].tolist(), strict=True):
            lists[row] = [(d, int(rows[r])) for d, r in own[v] if rows[r] != row]
    lists += [beside[v] for v in skin[1]]
    width = max(map(len, lists), default=0)
    sources, dist = np.zeros((len(lists), width), np.intp), np.full((len(lists), width), np.inf)
    for i, found in enumerate(lists):
        for j, (d, r) in enumerate(found):
            dist[i, j], sources[i, j] = d, r
    t = np.clip(dist / radius, 0.0, 1.0)
    falloff = 1.0 - t * t * (3.0 - 2.0 * t)
    most = falloff.max(axis=1, keepdims=True, initial=0.0)  # a lip of one vertex has no neighbour on it
    shares = falloff / np.maximum(falloff.sum(axis=1, keepdims=True), 1e-300) * most
    sources, shares = _full_shares(sources, shares, np.array(skin[0] + skin[1], np.intp), vertices, over)
    shares *= side[sources] * np.concatenate([side, np.ones(len(skin[1]))])[:, None]
    return {
        "skin": np.array(skin[0] + skin[1], np.intp),
        "sources": np.ascontiguousarray(sources.T),
        "shares": np.ascontiguousarray(shares.T),
    }


def _full_shares(
    sources: np.ndarray, shares: np.ndarray, skin: np.ndarray, vertices: np.ndarray, over: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(R, k) `sources` and `shares` of the rows of `skin`, and where a row's vertex has (vertex, guarded vertex)
    pairs in `over`, those guarded vertices (rows of `vertices`) too, an equal share each, adding up to one."""
    row_of = dict(zip(vertices.tolist(), range(len(vertices)), strict=True))
    at = {v: r for r, v in enumerate(skin.tolist())}
    extra = [[] for _ in range(len(skin))]
    for vertex, source in over.tolist():
        if vertex in at and source in row_of and vertex != source:
            extra[at[vertex]].append(row_of[source])
    width = max(map(len, extra), default=0)
    more_sources, more_shares = np.zeros((len(skin), width), np.intp), np.zeros((len(skin), width))
    for r, found in enumerate(extra):
        if found:
            more_sources[r, : len(found)], more_shares[r, : len(found)] = found, 1.0 / len(found)
    return np.concatenate([sources, more_sources], axis=1), np.concatenate([shares, more_shares], axis=1)


def _nearest(graph: tuple[np.ndarray, np.ndarray, np.ndarray], sources: np.ndarray, k: int, unit: float) -> dict:
    """`_nearest_sources` by the compiled kernel where it is (the same lists; 10x faster), else by Python."""
    found = fused.nearest_sources(*graph, sources, k, CARRY_RADIUS * unit, TIE * unit)
    return _nearest_sources(tuple(a.tolist() for a in graph), sources, k, unit) if found is None else found


def _nearest_sources(graph: tuple[list, list, list], sources: np.ndarray, k: int, unit: float) -> dict[int, list]:
    """{vertex: [(distance along the edges, row into `sources`), ...]}: up to `k` nearest of `sources`, nearest
    first, for every vertex within CARRY_RADIUS of one. Dijkstra from all sources at once, each vertex
    settled once per source until it has k: a source beaten k times at a vertex is beaten beyond it too."""
    starts, ends, length = graph
    radius, tie = CARRY_RADIUS * unit, TIE * unit
    heap = [(0.0, v, row) for row, v in enumerate(sources.tolist())]
    heapq.heapify(heap)
    found: dict[int, list] = {}
    rows_at: dict[int, list] = {}  # the rows of found[v]: a short list, quicker to search than a set of pairs
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        d, v, row = pop(heap)
        near = found.get(v)
        if near is None:
            near, rows = [], []
            found[v], rows_at[v] = near, rows
        else:
            rows = rows_at[v]
            if (len(near) >= k and d > near[k - 1][0] + tie) or row in rows:
                continue  # ties with the k-th are all kept: which of two mirror sources came first must not matter
        near.append((d, row))
        rows.append(row)
        for e in range(starts[v], starts[v + 1]):
            du = d + length[e]
            if du > radius:
                continue
            u = ends[e]
            there = found.get(u)
            if there is None or ((len(there) < k or du <= there[k - 1][0] + tie) and row not in rows_at[u]):
                push(heap, (du, u, row))  # else it would be passed over
    return found


def _bound(guard: LipGuard, x: np.ndarray, knots_x: np.ndarray, knots_y: np.ndarray) -> np.ndarray:
    """(V,) the height each guarded vertex must stay above (upper lip), or minus the height the vertex must
    stay below (lower lip).

    The seam itself, but where it bends the other lip's triangles cut across the bend: an upper-lip
    triangle with its corners on a peak's two flanks sags below the peak, and a lower-lip one rises above
    a valley. So the lower lip stays below the chord of the seam over the upper lip's widest triangle
    where that is lower (and the upper lip above the chord over the lower lip's widest triangle where that
    is higher), for chords of CHORDS x that width (one width alone misses a bend whose far side drops
    away); on a straight seam the chords lie on it and the lips meet on it. Each bound is sampled where
    its pieces bend (the seam's knots and the knots shifted by each chord's half-width); between samples
    it is the greatest of straight lines (signed by side), so the straight line between samples errs on
    the safe side."""
    stretch = max(1.0, (knots_x[-1] - knots_x[0]) / guard.width)  # triangles stretch with the mouth
    reach = np.array(guard.reach)[:, None] * stretch  # (2, 1): the upper lip's bound, then the lower's
    grid = np.sort((knots_x + SHIFTS[:, None, None] * reach).transpose(1, 0, 2).reshape(2, -1))
    ends = np.interp(grid + ENDS[:, None, None] * reach, knots_x, knots_y)  # the seam, then each chord's ends
    heights = np.concatenate([ends[:1], 0.5 * (ends[1::2] + ends[2::2])])
    envelope = (np.array([[1.0], [-1.0]]) * heights).max(axis=0)
    # one lookup for both lips: the lower lip's grid and vertices moved far to the right (LOWER_SHIFT)
    return np.interp(x + guard.shift, (grid + [[0.0], [LOWER_SHIFT * guard.unit]]).ravel(), envelope.ravel())
