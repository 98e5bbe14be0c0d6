"""Skin weights and Skeleton Subspace Deformation (paper 004, eq. 1-2).

    v = Σ_i w_i T_i T̂_i⁻¹ v̂        (1)        Σ_i w_i = 1        (2)

`linear_blend_skinning` takes the products T_i T̂_i⁻¹ directly: (B, 4, 4) bone transforms relative to
rest, which is what `pose` returns and what Blender's Armature modifier applies.

Weights (`skin_weights`; the paper does not say how its weights are made). Our method, in five steps:
The masks are the Planar Bones vertex groups (`deform.masks`): `upper_lip` is where the upper-lip side
may act (1, except 0 on the lower lip), `lower_lip` the converse, and the same for the eyelids.
1. the openings are cut: every mesh edge joining the two sides of the mouth (a vertex the `upper_lip`
   mask shuts out, < 0.5, to one the `lower_lip` mask shuts out) or of an eye, across which the mask
   jumps by CUT_JUMP or more, is removed, so distances along the skin go around the lip and eye corners,
   never across a gap. Beyond the corners the masks fade over a few edges; an edge there joins the two
   sides too, but cutting it would extend the gap onto the cheek, where the weights would then drop from
   1 to 0 along one edge and tear the skin at the mouth corners. The mouth is cut only along the lips'
   edge (`edge_of_lips`): inside the mouth the masks' boundary wanders over the lining, one piece of skin;
2. per skinned bone, the geodesic distance g (Dijkstra on the remaining edge graph, edge length =
   Euclidean) from the vertices nearest its segment (head-tail, or its `skin` polyline; within SEED_BAND
   of the nearest, each starting at its own distance to the segment, none that the bone's side mask
   shuts out);
3. a falloff (1 − (g / r)²)² inside the bone's radius r = `Bone.reach` · RADIUS_PER_SCALE · skeleton scale,
   times the bone's side mask for a bone on one side of an opening, so that e.g. the upper-lip bones
   leave the lower lip alone even where the lips touch;
   then smoothed over the skin (`smooth_over_edges`: steps that move each vertex's value halfway to the mean
   of its neighbours' across the remaining edges, as many as spread it over SMOOTHING_WIDTH · skeleton scale
   (about 2 (width / mean edge length)² steps: 4 on the sample head, more on a denser mesh, so the blur is the
   same on the face whatever its resolution). Distances along mesh edges zigzag, so the raw falloff's outline
   is jagged (a brow raise showed it) and its slope uneven, which turned faces over where two bones pull apart
   (an open jaw creased the chin and the skin from the mouth corners down); the openings stay cut;
4. the root (head) bone takes what the face bones leave, max(0, 1 − Σ), and every row is divided by its
   sum (eq. 2), so a vertex far from every face bone moves rigidly with the head. (Squaring what is left
   made the head's share rise steeply where the face bones fade, e.g. between the lower lip and the chin,
   which then stayed behind the jaw in a seam.) Except on the mouth's lining (`mouth_lining`: the pocket
   the lips' edge separates from the outer skin), which the gums hold: behind the lower lip the jaw takes
   what the lip bones leave, behind the upper lip the head (`lining_jaw_share`, from the geodesic distances
   to the two inner lip contours); the jaw's own weight from the jaw line does not reach in there. Held by
   the head, the lining behind the lower lip stayed behind as the lip dropped with the jaw, and an open jaw
   turned it over (14 faces at 20 mm on the sample head).
5. where the lip bones and the jaw act, the rows are smoothed once more (LIP_SMOOTHING times step 3's steps,
   over the same cut edges), each vertex moved toward its smoothed row by the lip bones' and the jaw's share
   of it: step 3 smooths the falloffs, but the side masks multiply them afterwards and fade over a few edges
   at the mouth corners, and the head's leftover rises as steeply as the lip bones fall, so a lip corner
   pulled back or a lip parted turned faces over where the weights changed most (a face folds where a bone's
   displacement times the slope of its weight across the face passes 1). Rows stay normalised: each is a
   mean of normalised rows; a lip bone stays within its side mask, the head taking what that leaves. On the
   mouth's lining the move is LINING_REACH of it (in full it turned a sliver in the second sample's mouth
   corner over at a small open jaw). The jaw's share (SMOOTHED_WITH_LIPS) counts too: where its weight gives
   way to the head's below the chin and on the cheek at the jaw's corner, an open jaw turned faces over
   (docs/elastic_bones.md). The rest of the face keeps its weights (smoothing them all blurred the brows and
   lids).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..geometry.pieces import connected_pieces
from ..geometry.surface_smoothing import smooth_over_edges, smoothing_steps
from .errors import ScipyMissingError, SkinWeightError
from .skeleton import JAW, LIP_LINES, Skeleton

RADIUS_PER_SCALE = 0.25  # falloff radius per skeleton scale (outer eye corner distance), bone reach 1
SEED_BAND = 0.02  # seeds: vertices within this fraction of the scale of the nearest to the segment
CUT_JUMP = 0.5  # an edge is cut where a side mask jumps by at least this much along it (a gap, not a gradient)
WEIGHT_TOLERANCE = 1e-6
LINING_SHARPNESS = 4  # the lining's jaw share u^p / (u^p + l^p): held by the gums, stretched where the sides meet
SMOOTHING_WIDTH = 0.085  # step 3's smoothing, per skeleton scale (docs/eyes_brows.md: folds and E against it)
LIP_SMOOTHING = 1  # step 5's smoothing on the lips' skin, in step 3's steps (docs/elastic_bones.md: folds, E)
SMOOTHED_WITH_LIPS = (JAW,)  # bones whose share of a row also counts in step 5 (docs/elastic_bones.md)
LINING_REACH = 0.75  # step 5's move on the mouth's lining, per its move on the skin (docs/elastic_bones.md)


def segment_distances(points: np.ndarray, heads: np.ndarray, tails: np.ndarray) -> np.ndarray:
    """(N, B) Euclidean distance from each point to each segment head-tail."""
    axis = tails - heads  # (B, 3)
    rel = points[:, None, :] - heads[None]  # (N, B, 3)
    length2 = np.einsum("bj,bj->b", axis, axis)
    t = np.clip(
        np.divide(np.einsum("nbj,bj->nb", rel, axis), length2, out=np.zeros(rel.shape[:2]), where=length2 > 0), 0, 1
    )
    return np.linalg.norm(rel - t[..., None] * axis[None], axis=2)


def polyline_seeds(
    vertices: np.ndarray, segments: np.ndarray, band: float, side_mask: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The seed vertices of a geodesic distance from (S, 2, 3) segments and each one's starting cost: the
    vertices within `band` of the nearest to the segments, at their distance to them, none that the side
    mask shuts out (< 0.5; a side mask shutting out every vertex leaves no seed)."""
    d = segment_distances(vertices, segments[:, 0], segments[:, 1]).min(axis=1)
    if side_mask is not None:
        d[side_mask < 0.5] = np.inf
    seed = np.flatnonzero(d <= d.min() + band) if np.isfinite(d.min()) else np.zeros(0, np.intp)
    return seed, d[seed]


def line_seeds(
    vertices: np.ndarray, segments: np.ndarray, spacing: float, side_mask: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The seed vertices of a geodesic distance from a line drawn on the skin ((S, 2, 3) segments): the
    vertex nearest each point along it (every `spacing`), none that the side mask shuts out (< 0.5),
    each at its distance to the line."""
    allowed = np.flatnonzero(side_mask >= 0.5) if side_mask is not None else np.arange(len(vertices))
    if not len(allowed):
        return np.zeros(0, np.intp), np.zeros(0)
    length = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    samples = np.concatenate(
        [a + np.linspace(0.0, 1.0, max(2, int(np.ceil(n / spacing)) + 1))[:, None] * (b - a)
         for (a, b), n in zip(segments, length, strict=True)]
    )  # fmt: skip
    near = allowed[np.argmin(np.linalg.norm(vertices[allowed][:, None] - samples[None], axis=2), axis=0)]
    seed = np.unique(near)
    return seed, segment_distances(vertices[seed], segments[:, 0], segments[:, 1]).min(axis=1)


def lip_bones(skeleton: Skeleton) -> list[int]:
    """Rows of the bones along the lips (`LIP_LINES`), each once."""
    return [skeleton.index(name) for name in dict.fromkeys(name for line in LIP_LINES for name in line)]


def inner_lip_lines(skeleton: Skeleton) -> list[tuple[np.ndarray, str]]:
    """(segments, side) of the upper and the lower inner lip contour: the lip bones' heads (FPs 2.x), corner
    to corner (`LIP_LINES`), each line on its side of the mouth."""
    lines = []
    for names, side in zip(LIP_LINES, ("upper_lip", "lower_lip"), strict=True):
        points = skeleton.heads[[skeleton.index(name) for name in names]]
        lines.append((np.stack([points[:-1], points[1:]], axis=1), side))
    return lines


def edge_of_lips(vertices: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(N,) True within half a lip width (inner to outer contour, the lip bones' mean length) of the inner
    lip contour: where the lips meet, between the outer skin and the mouth's lining."""
    rows = lip_bones(skeleton)
    lip_width = float(np.linalg.norm(skeleton.tails[rows] - skeleton.heads[rows], axis=1).mean())
    segments = np.concatenate([segments for segments, _side in inner_lip_lines(skeleton)])
    return segment_distances(vertices, segments[:, 0], segments[:, 1]).min(axis=1) < lip_width / 2


def mouth_lining(vertices: np.ndarray, edges: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(N,) 1 on the mouth's lining, 0 on the outer skin, 1/2 where the lips meet (`edge_of_lips`): with those
    vertices taken out, what the skin's edges no longer join to the outer lip contour (its FPs' nearest
    vertices, the lip bones' tails) is the lining. A mesh without a mouth pocket has none."""
    rows = lip_bones(skeleton)
    meeting = edge_of_lips(vertices, skeleton)
    joined = edges[~meeting[edges[:, 0]] & ~meeting[edges[:, 1]]]
    outer = np.argmin(np.linalg.norm(vertices[:, None] - skeleton.tails[rows][None], axis=2), axis=0)
    component = connected_pieces(len(vertices), joined)
    lining = np.where(np.isin(component, component[outer[~meeting[outer]]]), 0.0, 1.0)
    lining[meeting] = 0.5
    return lining


def lining_jaw_share(lining: np.ndarray, upper: np.ndarray, lower: np.ndarray, jaw_radius: float) -> np.ndarray:
    """(N,) the share of a vertex's leftover weight that goes to the jaw rather than the head (step 4), from
    its geodesic distances to the upper and the lower inner lip contour (around the mouth corners): on the
    mouth's lining (`mouth_lining`) the part behind the lower lip follows the jaw, the part behind the upper
    lip the skull, u^p / (u^p + l^p) with p = LINING_SHARPNESS (the gums hold each side; the two meet at
    the back of the mouth and in its corners), and the jaw's share falls off from the lower lip with the
    jaw's own radius, as its weight does on the outer skin from the jaw line."""
    near_lower = falloff(lower, jaw_radius)
    upper, lower = upper**LINING_SHARPNESS, lower**LINING_SHARPNESS
    total = upper + lower
    lower_side = np.divide(upper, total, out=np.full_like(total, 0.5), where=np.isfinite(total) & (total > 0))
    lower_side = np.where(np.isinf(upper) & np.isfinite(lower), 1.0, np.where(np.isinf(lower), 0.0, lower_side))
    return lining * lower_side * near_lower


def falloff(distance: np.ndarray, radius: np.ndarray | float) -> np.ndarray:
    """(1 − (g / r)²)² inside the radius, 0 beyond (and where unreachable, g = inf)."""
    return (1.0 - np.clip(distance / radius, 0.0, 1.0) ** 2) ** 2


def cut_openings(
    edges: np.ndarray, masks: Mapping[str, np.ndarray], near: Mapping[str, np.ndarray] | None = None
) -> np.ndarray:
    """The edges that do not join the two sides of an opening (step 1); `near` (opening's upper mask name ->
    (N,) bool) keeps an opening's cut to the edges touching those vertices (the lips' edge: inside the
    mouth the masks' boundary wanders over the lining, which is one piece of skin)."""
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    keep = np.ones(len(edges), bool)
    a, b = edges[:, 0], edges[:, 1]
    for upper, lower in (("upper_lip", "lower_lip"), ("upper_eyelid", "lower_eyelid")):
        if upper not in masks or lower not in masks:
            continue
        # the lower side is what the upper mask shuts out, and conversely
        mask = np.asarray(masks[upper])
        low, up = mask < 0.5, np.asarray(masks[lower]) < 0.5
        jump = np.abs(mask[a] - mask[b]) >= CUT_JUMP
        cut = ((up[a] & low[b]) | (low[a] & up[b])) & jump
        if near is not None and upper in near:
            cut &= near[upper][a] | near[upper][b]
        keep &= ~cut
    return edges[keep]


def _scipy_graph():
    """scipy's sparse matrix and Dijkstra, imported when weights are first made (Blender ships numpy, not
    scipy; the extension's scipy wheel may be missing, and the add-on must still load), or ScipyMissingError."""
    try:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra
    except ImportError as error:
        raise ScipyMissingError(
            f"Elastic Bones' skin weights need scipy (sparse graphs), which Blender does not ship and which is not "
            f"installed ({error}); install the MPEG-4 Face extension from its zip, which brings scipy's wheel for "
            "Windows x64, macOS and Linux x64, or install scipy into Blender's Python"
        ) from None
    return coo_matrix, dijkstra


def geodesic_distances(
    vertices: np.ndarray, edges: np.ndarray, seeds: list[np.ndarray], seed_costs: list[np.ndarray]
) -> np.ndarray:
    """(N, S) shortest edge-path distance from each seed set (a virtual source joined to its seed
    vertices by edges of the given costs) to every vertex; inf where unreachable."""
    coo_matrix, dijkstra = _scipy_graph()
    n = len(vertices)
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    rows = [edges[:, 0], edges[:, 1]]
    cols = [edges[:, 1], edges[:, 0]]
    data = [length, length]
    for s, (seed, cost) in enumerate(zip(seeds, seed_costs, strict=True)):
        rows.append(np.full(len(seed), n + s))
        cols.append(seed)
        data.append(np.maximum(cost, 1e-12))  # a zero would read as "no edge"
    size = n + len(seeds)
    graph = coo_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))
    dist = dijkstra(graph.tocsr(), directed=True, indices=np.arange(n, size))
    return dist[:, :n].T


def skin_weights(
    vertices: np.ndarray,
    edges: np.ndarray,
    skeleton: Skeleton,
    masks: Mapping[str, np.ndarray] | None = None,
    radius_per_scale: float = RADIUS_PER_SCALE,
) -> np.ndarray:
    """(N, B) skin weights, rows summing to 1 (eq. 2), columns in `skeleton.bones` order.

    `vertices` (N, 3) and `edges` (E, 2) are the rest mesh in the skeleton's coordinates, `masks` the
    opening vertex groups by name (`upper_lip`, `lower_lip`, `upper_eyelid`, `lower_eyelid`; (N,) weights
    in 0..1; absent ones cut nothing).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.all(np.isfinite(vertices)):
        raise SkinWeightError(f"vertices must be a finite (N, 3) array, got shape {vertices.shape}")
    n = len(vertices)
    edges = np.asarray(edges)
    if edges.size and (edges.ndim != 2 or edges.shape[1] != 2 or edges.min() < 0 or edges.max() >= n):
        raise SkinWeightError(f"edges must be (E, 2) indices into the {n} vertices")
    masks = {name: np.clip(np.asarray(m, dtype=np.float64), 0.0, 1.0) for name, m in (masks or {}).items()}
    for name, m in masks.items():
        if m.shape != (n,):
            raise SkinWeightError(f"mask {name!r} has shape {m.shape}, expected ({n},)")

    bones = skeleton.bones
    skinned = [b for b, bone in enumerate(bones) if bone.skinned and bone.kind != "root"]
    band = SEED_BAND * skeleton.scale
    starts = [polyline_seeds(vertices, skeleton.skin_segments(b), band, masks.get(bones[b].side)) for b in skinned]
    mouth = "upper_lip" in masks and "lower_lip" in masks and {JAW, *LIP_LINES[0], *LIP_LINES[1]} <= set(skeleton.rows)
    if mouth:
        starts += [line_seeds(vertices, segments, band, masks[side]) for segments, side in inner_lip_lines(skeleton)]
    seeds, costs = zip(*starts, strict=True)
    kept = cut_openings(edges, masks, {"upper_lip": edge_of_lips(vertices, skeleton)} if mouth else None)
    distances = geodesic_distances(vertices, kept, list(seeds), list(costs))
    geodesic = distances[:, : len(skinned)]
    radii = np.array([bones[b].reach * radius_per_scale * skeleton.scale for b in skinned])
    mean_edge = float(np.linalg.norm(vertices[kept[:, 0]] - vertices[kept[:, 1]], axis=1).mean()) if len(kept) else 0.0
    steps = smoothing_steps(SMOOTHING_WIDTH * skeleton.scale, mean_edge)
    falloffs = smooth_over_edges(falloff(geodesic, radii), kept, steps)

    raw = np.zeros((n, len(bones)))
    for column, b in enumerate(skinned):
        side = bones[b].side
        raw[:, b] = falloffs[:, column] * (masks[side] if side is not None and side in masks else 1.0)
    roots = [b for b, bone in enumerate(bones) if bone.kind == "root"]
    left = np.maximum(0.0, 1.0 - raw.sum(axis=1))
    if mouth:
        jaw = skeleton.index(JAW)
        lining = smooth_over_edges(mouth_lining(vertices, kept, skeleton), kept, steps)
        raw[:, jaw] *= 1.0 - lining  # on the lining the jaw takes only its share of what the lips leave
        left = np.maximum(0.0, 1.0 - raw.sum(axis=1))
        share = lining_jaw_share(lining, *distances[:, len(skinned) :].T, radii[skinned.index(jaw)])
        raw[:, jaw] += share * left
        left = (1.0 - share) * left
    raw[:, roots[0]] = left
    weights = raw / raw.sum(axis=1, keepdims=True)
    if {*LIP_LINES[0], *LIP_LINES[1]} <= set(skeleton.rows):
        sides = {b: masks[bone.side] for b, bone in enumerate(bones) if bone.side in masks}
        reach = 1.0 - (1.0 - LINING_REACH) * lining if mouth else np.ones(n)
        acting = lip_bones(skeleton) + [skeleton.index(b) for b in SMOOTHED_WITH_LIPS if b in skeleton.rows]
        weights = smooth_lips(weights, kept, LIP_SMOOTHING * steps, acting, sides, roots[0], reach)
    check_weights(weights, n, len(bones))
    return weights


def smooth_lips(
    weights: np.ndarray,
    edges: np.ndarray,
    steps: int,
    lip_rows: list[int],
    sides: Mapping[int, np.ndarray],
    root: int,
    reach: np.ndarray,
) -> np.ndarray:
    """(N, B) `weights` with each row moved toward its smoothed row (`steps` steps over `edges`) by the
    smoothed row's share of the `lip_rows` bones (step 5: the lips' and the jaw): 1 on the lips, fading to 0
    where they stop acting, times `reach` (N,) (LINING_REACH on the mouth's lining: all of it turned a sliver
    in the second sample's mouth corner over, weighted to the lip corner).
    The smoothed row keeps each bone of `sides` (row -> (N,) side mask) within its mask, as step 3 does, and
    gives what that takes off to the `root` bone, so the upper lip's bones still leave the lower lip alone."""
    smoothed = smooth_over_edges(weights, edges, steps)
    for b, mask in sides.items():
        taken = smoothed[:, b] * (1.0 - mask)
        smoothed[:, b] -= taken
        smoothed[:, root] += taken
    share = np.clip(smoothed[:, lip_rows].sum(axis=1), 0.0, 1.0)[:, None] * reach[:, None]
    return weights + share * (smoothed - weights)


def check_weights(weights: np.ndarray, n_vertices: int, n_bones: int) -> np.ndarray:
    """The weights as float64 if they are (n_vertices, n_bones), finite, ≥ 0 and sum to 1 per vertex
    (eq. 2); otherwise SkinWeightError naming the first offending vertices."""
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape != (n_vertices, n_bones):
        raise SkinWeightError(f"skin weights must be ({n_vertices}, {n_bones}), got {weights.shape}")
    bad = ~np.all(np.isfinite(weights), axis=1) | np.any(weights < 0.0, axis=1)
    if bad.any():
        raise SkinWeightError(
            f"skin weights are negative or not finite at vertices {np.flatnonzero(bad)[:10].tolist()}"
        )
    sums = weights.sum(axis=1)
    off = np.abs(sums - 1.0) > WEIGHT_TOLERANCE
    if off.any():
        first = np.flatnonzero(off)[:10]
        raise SkinWeightError(
            "skin weights must sum to 1 per vertex (eq. 2); vertices "
            + ", ".join(f"{v} (sum {sums[v]:.6g})" for v in first)
        )
    return weights


def linear_blend_skinning(rest: np.ndarray, weights: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """(N, 3) deformed vertices v = Σ_i w_i M_i v̂ (eq. 1) with M_i = T_i T̂_i⁻¹ given as (B, 4, 4)."""
    rest = np.asarray(rest, dtype=np.float64)
    transforms = np.asarray(transforms, dtype=np.float64)
    weights = check_weights(weights, len(rest), len(transforms))
    return apply_blended(blended_matrices(weights, transforms), rest)


def blended_matrices(weights: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """(N, 3, 4) each vertex's Σ_i w_i M_i (eq. 1's matrix, its last row dropped) for (N, B) weights, an array or
    a scipy sparse matrix (a vertex has a few bones: a tenth of the time at 17k vertices), and (B, 4, 4)
    transforms."""
    transforms = np.asarray(transforms, dtype=np.float64)
    flat = transforms[:, :3, :].reshape(len(transforms), 12)
    weights = weights if hasattr(weights, "tocsr") else np.asarray(weights, dtype=np.float64)
    return np.asarray(weights @ flat).reshape(-1, 3, 4)


def apply_blended(matrices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 3) each point moved by its own (3, 4) matrix of `blended_matrices`."""
    return np.einsum("nij,nj->ni", matrices[:, :, :3], points) + matrices[:, :, 3]
