"""How the add-on binds a whole head to its FP control mesh: the one configuration that set-up, the
accuracy benchmark and the performance benchmark share.

A head is covered by the control mesh only in part, so two choices sit on top of the paper
(planar_bones notes, "Coverage" and "Partial coverage"):
- the vertices that must lie in an affection volume are those of the face: within a quarter of the eye
  separation ES0 (about 15 mm on an adult) of the control mesh, over its inside;
- a vertex whose eq. 9 weights add up to less than FADE_BELOW fades toward its rest shape, so motion
  ends smoothly where the volumes end. At 0.2 rather than 0.05 the fade spans about the outer
  half of the volumes' reach instead of their outer third, and the skin where the face ends (temples,
  under the chin, the mouth corners' inside) stretches over a wider band and folds far less; measured on
  the sample head's expression units and .fap streams (docs/accuracy.md).

Still skin around the eyes and brows (``triangle_parts``, docs/eyes_brows.md): raising radii to cover every
face vertex is what spreads a brow's or a lid's motion over the forehead, temple and cheek, which sculpted
expressions leave still (eq. 8 normalises a far vertex's one faint weight to the triangle's full motion). So
only the skin over the mouth-and-jaw triangles must be covered, by raising those triangles' radii alone; the
upper face's triangles keep a fraction of their own §3 radius (LOCAL_RADIUS_FRACTIONS, by part of the face)
and skin beyond their reach fades to rest (``fade_below``) instead of following. The eyes' triangles reach least:
the lids' own motion is their turn over the eyeballs (`eyelids`), and what the eye corners' FPs move in a sculpt
is the lid margin, not the skin around it; the brows' triangles reach further, over the band above the brow.
Whether a vertex lies within a local radius depends on how far the skin bulges off its triangle's plane, not on
where it lies on the face, so the share of the control mesh's motion a vertex takes (the sum of its eq. 8 weights,
the rest staying at rest) jumps from vertex to vertex at the edge of the moving skin (a ragged outline, a crease
at a brow lowering). Given the mesh's edges, that share is smoothed over FOLLOW_SMOOTHING_PER_ES0 x ES0 of skin
(`smooth_follow`), never raised (a vertex takes no more of the motion than the paper's weights give it) and kept at
the control FPs (within half that width of one, at d from it, the share may fall only to 1 - (2 d / width)²: skin at
an FP the user drags still follows it, and the share is flat at the FP, so the skin right around it moves with it;
falling linearly, 1-3 % less of a 10 mm motion on the lips' corners' 0.5 mm triangles passed them through each
other at the demo's widest mouth); it is smoothed among the skin within SMOOTHED_REACH widths of a control FP, so
that a body joined under the head leaves the face as it is on the head alone. No vertex keeps more of it than the
skin joining it to the skin at the control FPs takes (`joined_share`): an island of skin the eyes' short reach
left moving among still skin stays still.

The mouth's falloff over the cheek (``mouth_rows``, `fall_from_mouth`, docs/eyes_brows.md): the mouth and jaw's
triangles span the cheek up to the cheek FPs and move it linearly, while sculpted expressions move the cheek less
away from the lips, so their pairs' weights fall with the distance along the skin from the nearest lip or jaw FP.
Past an outline edge or corner of theirs that other parts' FPs hold (the nose's base, the cheeks' points), they reach
no skin at all (`stop_at_held_outline`): eq. 12-14 would swing it with the triangle's turn; the nose's and the
cheeks' triangles move it, through the FPs they share.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ..geometry.pieces import connected_pieces
from ..geometry.surface_smoothing import smooth_over_edges, smoothing_steps
from ..mpeg4.control_mesh import BROWS, EYES, MOUTH_AND_JAW, OTHER_UPPER
from .auto_masks import geodesic_distance
from .planar_bones import Binding, bind, cover_over_control_mesh
from .regions import APEX, EDGE, triangle_frames

FADE_BELOW = 0.2
FACE_DEPTH_PER_ES0 = 0.25
# of the §3 radius, by `control_mesh.triangle_parts` (the mouth and jaw's triangles still cover their skin);
# chosen on a grid over the development units with leave-one-unit-and-twin-out checks
# (`scripts.bench.still_skin_fractions`, docs/eyes_brows.md)
LOCAL_RADIUS_FRACTIONS = {EYES: 0.05, BROWS: 0.3, OTHER_UPPER: 0.5, MOUTH_AND_JAW: 1.5}
FOLLOW_SMOOTHING_PER_ES0 = 0.4  # the width of skin `smooth_follow` spreads a vertex's share of the motion over
# the mouth and jaw's triangles move skin fully at their lips' and jaw's FPs, less away along the skin; the reach
# a leave-one-unit-and-twin-out check picks (32 of 34 times on 1.0-1.6, `scripts.bench.mouth_reach`), not the one
# meeting the cheeks' target (eyes_brows.md)
MOUTH_REACH_PER_ES0 = 1.2
# `stop_at_held_outline`: a pair this share of its triangle's longest edge or less past the edge or corner is on it:
# enough for the sample's vertices on a rim when the head is turned Y-up (at 1e-12 one went past), small enough that
# the head modelled in millimetres and in metres keep the same pairs (at 1e-6 they did not: vertices nm from a rim)
ON_RIM = 1e-9
SMOOTHED_REACH = 3.0  # widths from the nearest control FP: the skin `smooth_follow` smooths among


def face_depth(es0: float, control_rest: np.ndarray) -> float:
    """How far from the control mesh the face reaches: FACE_DEPTH_PER_ES0 x ES0, or a tenth of the control
    mesh's width when ES0 is unknown (0)."""
    return FACE_DEPTH_PER_ES0 * es0 if es0 > 0 else 0.1 * float(np.ptp(control_rest, axis=0).max())


def face_cover(rest: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray, es0: float) -> np.ndarray:
    return cover_over_control_mesh(rest, control_rest, triangles, face_depth(es0, control_rest))


def bind_face(
    rest: np.ndarray,
    control_rest: np.ndarray,
    triangles: np.ndarray,
    *,
    es0: float,
    radius_fraction: float = 1.0,
    falloff_exponent: float = 2.0,
    vertex_masks: Mapping[str, np.ndarray] | None = None,
    triangle_masks: Sequence[str | None] | None = None,
    triangle_parts: Sequence[int] | None = None,
    edges: np.ndarray | None = None,
    local_float32: bool = False,
    mouth_rows: Sequence[int] | None = None,
) -> Binding:
    """`bind` as the add-on binds a face; ``triangle_parts`` (T,) `control_mesh.triangle_parts`: the upper face's
    triangles reach only locally (None: the paper's cover everywhere), and with the mesh's (E, 2) ``edges`` each
    vertex's share of the motion is smoothed over the skin (`smooth_follow`); with ``mouth_rows`` (the control rows
    of groups 2 and 8, `control_mesh.mouth_rows`) the mouth and jaw's triangles move the cheek less away from them
    (`fall_from_mouth`)."""
    cover = face_cover(rest, control_rest, triangles, es0)
    fraction, raisable = radius_fraction, None
    if triangle_parts is not None:
        parts = np.asarray(triangle_parts)
        scale = np.ones(len(parts))
        for part, local_fraction in LOCAL_RADIUS_FRACTIONS.items():
            scale[parts == part] = local_fraction
        raisable = parts == MOUTH_AND_JAW
        lower = triangles[raisable]
        cover &= len(lower) > 0 and cover_over_control_mesh(rest, control_rest, lower, face_depth(es0, control_rest))
        fraction = scale * radius_fraction
    binding = bind(
        rest,
        control_rest,
        triangles,
        radius_fraction=fraction,
        falloff_exponent=falloff_exponent,
        vertex_masks=vertex_masks,
        triangle_masks=triangle_masks,
        cover=cover,
        fade_below=FADE_BELOW,
        raisable=raisable,
        local_float32=local_float32,
    )
    covered = binding  # the skin the volumes reach, which counts the smoothing's steps
    if triangle_parts is not None and mouth_rows is not None and len(mouth_rows):
        mouth = np.asarray(triangle_parts) == MOUTH_AND_JAW
        binding = stop_at_held_outline(binding, mouth, mouth_rows)
        if es0 > 0:
            binding = fall_from_mouth(binding, mouth, mouth_rows, es0, edges)
    if triangle_parts is None or edges is None:
        return binding
    width = FOLLOW_SMOOTHING_PER_ES0 * es0 if es0 > 0 else face_depth(es0, control_rest)
    # the skin at a control FP follows it fully, and less so up to half the width away (flat at the FP); skin moves
    # no more than the skin joining it to the skin at the FPs (`joined_share`)
    points = np.asarray(control_rest)[np.unique(triangles)]
    near = _nearest(rest, points)
    pinned = np.clip(1.0 - (near / (0.5 * width)) ** 2, 0.0, 1.0)
    at_points = [int(np.argmin(np.linalg.norm(rest - point, axis=1))) for point in points]
    return smooth_follow(binding, edges, width, pinned, near <= SMOOTHED_REACH * width, covered, at_points)


def smooth_follow(
    binding: Binding,
    edges: np.ndarray,
    width: float,
    pinned: np.ndarray,
    domain: np.ndarray | None = None,
    counted: Binding | None = None,
    sources: Sequence[int] | None = None,
) -> Binding:
    """`binding` with each vertex's share of the control mesh's motion (the sum of its eq. 8 weights) lowered to
    the share smoothed over about `width` of skin along the (E, 2) mesh `edges`, or to (N,) `pinned`, whichever is
    more, where that is less than the share. Smoothed among the vertices that move and those in (N,) bool `domain`
    (all when None: the add-on passes the skin within SMOOTHED_REACH widths of a control FP, so a body under the
    head does not change the face's result). The steps are counted on the mean length of the edges between
    vertices that move (in `counted` when given: the add-on passes its binding before the mouth's falloff, so that
    the falloff, which stills some skin, does not change how far the share is smoothed elsewhere), so a denser
    mesh smooths over the same skin. With `sources` (the vertices at the control FPs), no vertex keeps more than
    the skin joining it to them takes (`joined_share`)."""
    rest = binding.rest_vertices
    share = np.bincount(binding.pair_vertex, binding.pair_weight, minlength=len(rest))
    same, edges = welded(rest, edges)
    pieces = None if sources is None else connected_pieces(len(rest), edges)
    if domain is not None:
        edges = edges[(np.asarray(domain) | (share > 0.0))[edges].all(axis=1)]
    moves = share if counted is None else np.bincount(counted.pair_vertex, counted.pair_weight, minlength=len(rest))
    moving = edges[(moves[edges] > 0.0).all(axis=1)]
    if len(moving) == 0:
        return binding
    length = float(np.linalg.norm(rest[moving[:, 0]] - rest[moving[:, 1]], axis=1).mean())
    smoothed = smooth_over_edges(share, edges, smoothing_steps(width, length))[same]
    lowered = np.minimum(share, np.maximum(smoothed, pinned))
    if sources is not None:
        lowered = np.minimum(lowered, joined_share(share, edges, same, sources, pieces))
    scale = np.divide(lowered, share, out=np.zeros_like(share), where=share > 0.0)
    return dataclasses.replace(binding, pair_weight=binding.pair_weight * scale[binding.pair_vertex])


def joined_share(
    share: np.ndarray, edges: np.ndarray, same: np.ndarray, sources: Sequence[int], pieces: np.ndarray
) -> np.ndarray:
    """(N,) the most of the motion that the skin joining each vertex to a vertex of `sources` (the skin at the
    control FPs) takes, of the (N,) `share`: the largest s such that a path over the (E, 2) `edges` (between the
    stand-ins `same` of `welded`) joins the two through vertices whose share is s or more. 1 at a source, and on a
    piece of the mesh (N,) `pieces` that has none: such a piece is not held by this.

    Skin moves no more than the skin between it and an FP: a vertex, or a few, cut off from the FPs by skin that
    stays still is not skin the FPs move but an island of the ragged share that the eyes' control triangles give
    (their reach is short, `LOCAL_RADIUS_FRACTIONS`, and skin off their planes is out of it). The smoothing spreads
    such an island but, never raising a vertex, leaves it a smaller island, and the pin at an FP (by the straight
    distance) can keep it whole. On the scan, single vertices and pairs 4-8 mm from the eyes' outer corners took
    0.65-1.0 of a lower-lid control triangle's motion (3.9, 5.3, 3.7) with no neighbour moving, rose with the
    cheeks' lift (FAPs 41-42) past the still skin beside them, and crossed it (demo frames 156-184); cut to a
    fourteenth by the smoothing, a pair still crossed the fold at the corner, 0.01 mm deep at rest."""
    share = np.asarray(share, dtype=np.float64)
    moving = np.zeros(len(share))  # each stand-in's share: the most of its copies'
    np.maximum.at(moving, same, share)
    held = np.zeros(len(share))
    held[same[np.asarray(sources, dtype=np.intp)]] = 1.0
    held[~np.isin(pieces, pieces[held > 0.0])] = 1.0
    edges = edges[((moving > 0.0) | (held > 0.0))[edges].all(axis=1)]  # still skin carries nothing
    while len(edges):  # each round carries it one edge further; it only rises, so this ends
        reached = np.zeros(len(share))
        np.maximum.at(reached, edges[:, 0], held[edges[:, 1]])
        np.maximum.at(reached, edges[:, 1], held[edges[:, 0]])
        wider = np.maximum(held, np.minimum(moving, reached))
        if np.array_equal(wider, held):
            break
        held = wider
    return held[same]


def fall_from_mouth(
    binding: Binding,
    mouth_triangles: np.ndarray,
    mouth_rows: Sequence[int],
    es0: float,
    edges: np.ndarray | None = None,
) -> Binding:
    """`binding` with the weights of its pairs on the (T,) bool `mouth_triangles` scaled by 1 - (d / R)² (at least
    0), d a vertex's distance from the nearest of the control rows `mouth_rows` (the lips' and jaw's FPs, groups 2
    and 8) and R = MOUTH_REACH_PER_ES0 x `es0`: the mouth and jaw's triangles span the cheek to the cheekbone, and
    interpolating their FPs' motion linearly over it moves the cheek's skin more than sculpted expressions do
    (their motion falls off away from the lips). With the mesh's (E, 2) `edges`, d is measured along the skin
    (shortest paths over the edges and the steps across two of them, `_two_ring`, from each FP's nearest vertex):
    skin the lips' motion reaches only around a fold or an opening (the mouth's, the nostrils', the nasolabial
    fold) is farther than the straight line says; without them, the straight distance."""
    rest, control = binding.rest_vertices, np.asarray(binding.control_rest)
    mouth_rows = np.asarray(mouth_rows, dtype=np.intp)
    reach = MOUTH_REACH_PER_ES0 * es0
    if edges is None:
        distance = _nearest(rest, control[mouth_rows])
    else:
        same, edges = welded(rest, edges)
        sources = [same[np.argmin(np.linalg.norm(rest - point, axis=1))] for point in control[mouth_rows]]
        distance = geodesic_distance(rest, _two_ring(edges), sources, reach)[same]
    cap = np.clip(1.0 - (distance / reach) ** 2, 0.0, 1.0)
    # the triangles' other FPs (the cheeks', 5.x, which FAPs 39-42 move): skin at them still follows them fully, as
    # at every control FP (`bind_face`'s pin, same width); only the lips' motion carried across the cheek falls
    others = np.setdiff1d(np.unique(np.asarray(binding.triangles)[np.asarray(mouth_triangles)]), mouth_rows)
    if len(others):
        pin_reach = 0.5 * FOLLOW_SMOOTHING_PER_ES0 * es0
        cap = np.maximum(cap, np.clip(1.0 - (_nearest(rest, control[others]) / pin_reach) ** 2, 0.0, 1.0))
    scale = np.where(np.asarray(mouth_triangles)[binding.pair_triangle], cap[binding.pair_vertex], 1.0)
    return dataclasses.replace(binding, pair_weight=binding.pair_weight * scale)


def stop_at_held_outline(binding: Binding, mouth_triangles: np.ndarray, mouth_rows: Sequence[int]) -> Binding:
    """`binding` without the pairs of the (T,) bool `mouth_triangles` on skin past an outline edge or corner of
    theirs that FPs of other parts hold: an edge region (eq. 12) whose edge has neither end among the control rows
    `mouth_rows` (the lips' and jaw's FPs), or an apex region (eq. 13-14) whose corner is not among them: the
    nose's base 9.x and the cheeks' 5.x. Eq. 12-14 carry a triangle's turn to the skin past its edge (the edge's
    frame turns with it), so a lip moving 8 mm turned the mouth's triangles about their nose edges and swung the
    nose's wing and the cheek above the nasolabial line with it, skin the sculpts keep still while the lips move
    (docs/eyes_brows.md, "Fourth round"). That skin is the other parts' triangles' (the nose's, the cheeks'), and
    what the lips' motion does to it comes through the FPs they share, which those triangles follow; skin past an
    edge with a lip or jaw FP at an end (the lips' inside, the chin, the jaw line) keeps the mouth's pairs. No
    constant: which pairs go follows from the control mesh and the FP groups; a vertex left with no pair stays at
    rest, and `smooth_follow` smooths the share of the motion where it ends."""
    triangles = np.asarray(binding.triangles)
    held = np.ones(len(binding.control_rest), dtype=bool)
    held[np.asarray(mouth_rows, dtype=np.intp)] = False
    region = binding.pair_region.astype(np.intp)
    corners = triangles[binding.pair_triangle]
    j = (region - EDGE) % 3  # the edge (V_j, V_j+1) of an edge region, the corner V_j of an apex region
    first = held[np.take_along_axis(corners, j[:, None], axis=1)[:, 0]]
    second = held[np.take_along_axis(corners, ((j + 1) % 3)[:, None], axis=1)[:, 0]]
    past = np.where(region >= APEX, first, (region >= EDGE) & first & second)
    # past the edge or corner, not on it: a vertex on the triangle's rim (an FP's own vertex at its corner, a vertex
    # on its edge) is the triangle's whichever region float rounding files it under, where eq. 12-14 give the
    # same image as the face region (`regions.locate`); without this, the sample's cheek vertex under FP 5.1 kept
    # 7 or 8 of its 8 pairs as the head was bound Z-up or Y-up, and followed 5.1 by 7/8 or all of its motion
    size = triangle_frames(np.asarray(binding.control_rest)[triangles]).edge_lengths.max(axis=1)  # (T,) longest edge
    beyond = np.where(region >= APEX, binding.pair_apex_distance, binding.pair_region_local[:, 1])
    past &= beyond > ON_RIM * size[binding.pair_triangle]
    drop = np.asarray(mouth_triangles, dtype=bool)[binding.pair_triangle] & past
    if not drop.any():
        return binding
    keep = ~drop
    pairs = [f.name for f in dataclasses.fields(Binding) if f.name.startswith("pair_")]
    return dataclasses.replace(binding, **{name: getattr(binding, name)[keep] for name in pairs})


def welded(rest: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) each vertex's stand-in, the first vertex at its rest position, and the (E, 2) `edges` between stand-ins
    (each once): the skin as one surface where the mesh is cut into pieces whose copies of a vertex coincide (a
    downloaded character's face sewn to its scalp by coincident vertices, UV seams split). What is measured along the
    skin is then measured across such a seam as across any edge, and a vertex's copies take its stand-in's value
    (`values[same]`): measured on each piece alone, the Rocketbox male's copies at the seam by its ear (FP 10.5) were
    smoothed to 0.35 and 0.50 of the motion, moved apart, and their faces crossed (every frame of joy.fap). A
    mesh with no coincident vertices keeps its edges as they are."""
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    _, first, inverse = np.unique(np.asarray(rest), axis=0, return_index=True, return_inverse=True)
    same = first[inverse.ravel()].astype(np.intp)
    if len(first) == len(same):
        return same, edges
    joined = np.sort(same[edges], axis=1)
    return same, np.unique(joined[joined[:, 0] != joined[:, 1]], axis=0)


def _nearest(points: np.ndarray, sources: np.ndarray) -> np.ndarray:
    """(N,) each point's distance from the nearest of the (K, 3) sources (inf with none)."""
    near = np.full(len(points), np.inf)
    for source in sources:
        near = np.minimum(near, np.linalg.norm(points - source, axis=1))
    return near


def _two_ring(edges: np.ndarray) -> np.ndarray:
    """(F, 2) the (E, 2) `edges` and each vertex's pairs with its neighbours' neighbours: straight steps across
    two triangles, so that shortest paths over them zig-zag less than along the edges alone."""
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    both = np.concatenate([edges, edges[:, ::-1]])
    both = both[np.argsort(both[:, 0], kind="stable")]
    start = np.searchsorted(both[:, 0], np.arange(int(both.max(initial=-1)) + 2))
    degree = np.diff(start)[both[:, 1]]
    firsts = np.repeat(both[:, 0], degree)
    # the neighbours of each edge's end: its rows of `both`, counted on from where they start
    rows = np.arange(int(degree.sum())) + np.repeat(start[both[:, 1]] - (np.cumsum(degree) - degree), degree)
    seconds = both[rows, 1]
    pairs = np.concatenate([edges, np.stack([firsts, seconds], axis=1)])
    pairs = np.sort(pairs[pairs[:, 0] != pairs[:, 1]], axis=1)
    span = len(start)
    return np.column_stack(np.divmod(np.unique(pairs[:, 0] * span + pairs[:, 1]), span))
