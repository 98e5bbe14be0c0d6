"""Skin that overlaps or crumples without turning over, which `folds` (normals against the rest ones) misses (no bpy).

- `crossings`: pairs of triangles that share no vertex and pass through each other (an edge of one crosses the
  other), among those with a vertex off its rest: skin pushed through skin (a lid through the lid below it, a
  lip through the other) counts, however its normals point.
- `edge_roughness`: how far each vertex of an ordered chain (a lid's edge) lies off the smooth curve through its
  neighbours, the cubic through the two on each side (p = (-a + 4b + 4c - d) / 6 holds for every cubic): a
  zig-zag lid edge shows there while its faces keep their orientation.
- `edge_chain`: the vertices along a lid's edge at rest (nearest to points on the line through its FPs), and
  `lid_gap`: how far an upper lid's edge stays from the lower lid's where the lids should meet (a blink).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.columns import column_cuts

EPS = 1e-12
# a crossing counts where the segment passes through the triangle's interior by more than this share of the
# segment's length and of the triangle's barycentric range: surfaces that touch at rest (an edge ending on the
# other triangle, coincident layers) sit at exactly 0, where the sign is the rounding's; turned rigidly by 2 degrees
# in float64, the Rocketbox's full body (clothes on skin) gave 691 "crossing" pairs and 207 in float32, its head
# turns up to 181 a frame (session 10); with it, none
TOUCH = 1e-6


def _edge_hits(
    p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, touch: float = TOUCH
) -> np.ndarray:
    """(P,) True where the segment p0-p1 crosses the triangle abc (Möller-Trumbore, the segment's open interior),
    by more than `touch` inside both and with both ends off its plane by more than `touch` of its length (a
    negative `touch` takes in segments that only touch the triangle too)."""
    direction = p1 - p0
    e1, e2 = b - a, c - a
    h = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, h)
    # relative to the three lengths it multiplies: an absolute bound saw nothing on a face in metres x 0.01
    # (1 cm triangles: det about 1e-15)
    size = np.linalg.norm(direction, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    ok = np.abs(det) > EPS * size
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = inv * np.einsum("ij,ij->i", s, h)
    q = np.cross(s, e1)
    v = inv * np.einsum("ij,ij->i", direction, q)
    t = inv * np.einsum("ij,ij->i", e2, q)
    # each end of the segment off the triangle's plane by more than TOUCH of its length (a sheet lying on a sheet,
    # rounded to float32, has its edges cross the other's plane 1e-8 deep in the middle)
    normal = np.cross(e1, e2)
    normal /= np.maximum(np.linalg.norm(normal, axis=1), EPS)[:, None]
    reach = touch * np.linalg.norm(direction, axis=1)
    apart = (np.abs(np.einsum("ij,ij->i", s, normal)) > reach) & (np.abs(np.einsum("ij,ij->i", p1 - a, normal)) > reach)
    inside = (u > touch) & (v > touch) & (u + v < 1 - touch) & (t > touch) & (t < 1 - touch)
    return ok & inside & apart


def crossings(
    points: np.ndarray, triangles: np.ndarray, moving: np.ndarray | None = None, at_rest: np.ndarray | None = None
) -> int:
    """How many pairs of vertex-disjoint triangles of (K, 3) `triangles` pass through each other at (N, 3)
    `points`, among pairs with a triangle that has a corner flagged in (N,) bool `moving` (all when None), less the
    (P, 2) pairs `at_rest` (`crossing_pairs` at rest: a scanned head's surface can cross itself before anything
    moves, 241 pairs about the Lee Perry-Smith scan's closed eyes, which playback is not to be charged with)."""
    pairs = crossing_pairs(points, triangles, moving)
    if at_rest is None or not len(at_rest) or not len(pairs):
        return len(pairs)
    known = np.asarray(at_rest, dtype=np.int64)
    span = int(max(pairs.max(), known.max())) + 1
    return int(np.count_nonzero(~np.isin(pairs[:, 0] * span + pairs[:, 1], known[:, 0] * span + known[:, 1])))


def crossing_pairs(
    points: np.ndarray, triangles: np.ndarray, moving: np.ndarray | None = None, touch: float = TOUCH
) -> np.ndarray:
    """(P, 2) the pairs of `crossings` (rows of `triangles`, the smaller first); with a negative `touch`, those that
    only touch as well (`_edge_hits`)."""
    points = np.asarray(points, dtype=np.float64)
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tris) < 2:
        return np.empty((0, 2), np.int64)
    corners = points[tris]
    centres = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
    active = np.arange(len(tris)) if moving is None else np.flatnonzero(np.asarray(moving)[tris].any(axis=1))
    if len(active) == 0:
        return np.empty((0, 2), np.int64)
    # triangles in classes of similar size (factors of 2), each class searched within its own largest radius: one
    # large triangle (a neck's cap) does not widen every search
    size_class = np.floor(np.log2(np.maximum(radius, radius.max() * 1e-6))).astype(np.int64)
    firsts, seconds = [], []
    for size in np.unique(size_class):
        members = np.flatnonzero(size_class == size)
        found = cKDTree(centres[members]).query_ball_point(centres[active], radius[active] + radius[members].max())
        firsts.append(np.repeat(active, [len(f) for f in found]))
        seconds.append(members[np.concatenate([np.asarray(f, dtype=np.int64) for f in found])])
    pairs = np.unique(np.sort(np.stack([np.concatenate(firsts), np.concatenate(seconds)], axis=1), axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    shared = (tris[pairs[:, 0], :, None] == tris[pairs[:, 1], None, :]).any(axis=(1, 2))
    pairs = pairs[~shared]
    near = np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1) <= radius[pairs].sum(axis=1)
    pairs = pairs[near]
    if len(pairs) == 0:
        return pairs
    hit = np.zeros(len(pairs), bool)
    for one, other in ((0, 1), (1, 0)):
        a, b, c = (corners[pairs[:, other], k] for k in range(3))
        for i, j in ((0, 1), (1, 2), (2, 0)):
            hit |= _edge_hits(corners[pairs[:, one], i], corners[pairs[:, one], j], a, b, c, touch)
    return pairs[hit]


def edge_roughness(points: np.ndarray, chain: np.ndarray, closed: bool = True) -> np.ndarray:
    """(V,) distance of each vertex of the ordered `chain` (vertex indices) from the cubic through its two
    neighbours on each side (0 for the first and last two of an open chain)."""
    p = np.asarray(points, dtype=np.float64)[np.asarray(chain, dtype=np.int64)]
    if len(p) < 5:
        return np.zeros(len(p))
    a, b, c, d = (np.roll(p, k, axis=0) for k in (2, 1, -1, -2))
    off = np.linalg.norm(p - (-a + 4.0 * b + 4.0 * c - d) / 6.0, axis=1)
    if not closed:
        off[:2] = off[-2:] = 0.0
    return off


def edge_chain(rest: np.ndarray, candidates: np.ndarray, line: np.ndarray, samples: int) -> np.ndarray:
    """The ordered `candidates` (vertex indices) nearest `samples` points evenly along the polyline `line` (K, 3)
    at (N, 3) `rest` positions, each once, keeping one per quarter of a sample step along the line's chord (the
    row behind a margin vertex is not the edge): a lid's edge from the FPs along it (inner corner, middle,
    outer corner)."""
    rest = np.asarray(rest, dtype=np.float64)
    line = np.asarray(line, dtype=np.float64)
    candidates = np.asarray(candidates, dtype=np.int64)
    t = np.linspace(0.0, len(line) - 1.0, samples)
    k = np.minimum(t.astype(int), len(line) - 2)
    points = line[k] + (t - k)[:, None] * (line[k + 1] - line[k])
    nearest = candidates[np.argmin(np.linalg.norm(rest[candidates][None] - points[:, None], axis=2), axis=1)]
    chain = nearest[np.sort(np.unique(nearest, return_index=True)[1])]
    chord = line[-1] - line[0]
    along = (rest[chain] - line[0]) @ chord / np.linalg.norm(chord)
    step = 0.25 * np.linalg.norm(chord) / samples
    keep = [0]
    for j in range(1, len(chain)):
        if along[j] > along[keep[-1]] + step:
            keep.append(j)
    return chain[keep]


def _polyline_distances(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """(P,) distance of each point from the polyline (L, 3)."""
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    rel = points[:, None] - a[None]
    t = np.clip(np.einsum("psj,sj->ps", rel, ab) / np.maximum(np.einsum("sj,sj->s", ab, ab), EPS), 0.0, 1.0)
    return np.linalg.norm(rel - t[..., None] * ab[None], axis=2).min(axis=1)


def lid_gap(points: np.ndarray, upper: np.ndarray, lower: np.ndarray) -> float:
    """The widest distance, at (N, 3) `points`, from a vertex of the middle half of the `upper` lid's edge chain to
    the `lower` lid's edge (the polyline through its chain): 0 where the lids meet along their middle."""
    points = np.asarray(points, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.int64)
    middle = upper[len(upper) // 4 : len(upper) - len(upper) // 4]
    if len(middle) == 0 or len(lower) < 2:
        return float("nan")
    return float(_polyline_distances(points[middle], points[np.asarray(lower, dtype=np.int64)]).max())


def _column_spans(corners: np.ndarray, x: float) -> np.ndarray:
    """(S, 2) the intervals of y over which the projected triangles `corners` (T, 3, 2) cross the line at `x`."""
    lows, highs = column_cuts(corners, x)
    return np.concatenate([lows, highs], axis=1)


def _uncovered(spans: np.ndarray, low: float, high: float) -> float:
    """The length of [low, high] that the intervals `spans` (S, 2) leave uncovered."""
    spans = spans[(spans[:, 1] > low) & (spans[:, 0] < high)].clip(low, high)
    if not len(spans):
        return high - low
    spans = spans[np.argsort(spans[:, 0])]
    reached = np.maximum.accumulate(spans[:, 1])  # the covered run's top up to each interval
    holes = spans[1:, 0] - reached[:-1]
    return float(spans[0, 0] - low + holes.clip(0.0).sum() + high - reached[-1])


def seen_lid_gap(
    points: np.ndarray,
    triangles: np.ndarray,
    centre: np.ndarray,
    radius: float,
    axes: np.ndarray,
    corners: tuple[float, float],
    columns: int = 48,
) -> float:
    """The widest opening a viewer looking straight at the face sees between the lids over the middle half of the
    eye: at (N, 3) `points`, the length of each vertical line through the eyeball's outline (centre (3,) and
    `radius`; face frame `axes` (3, 3): x across, y up, z forward) that the skin in front of the eye's centre
    (the `triangles` (T, 3) with every corner in front of it) leaves uncovered, widest of `columns` lines evenly
    over the middle half of `corners` (the corners' x, relative to the centre). Unlike `lid_gap` it needs no
    lid edge, only the skin: lids closed over each other read 0 however thick their margins."""
    local = (np.asarray(points, dtype=np.float64) - centre) @ np.asarray(axes, dtype=np.float64).T
    faces = local[np.asarray(triangles, dtype=np.int64)]
    projected = faces[(faces[:, :, 2] > 0.0).all(axis=1)][:, :, :2]
    inner, outer = sorted(corners)
    quarter = 0.25 * (outer - inner)
    widest = 0.0
    for x in np.linspace(inner + quarter, outer - quarter, columns):
        half = np.sqrt(max(radius * radius - x * x, 0.0))
        if half > 0.0:
            widest = max(widest, _uncovered(_column_spans(projected, x), -half, half))
    return widest
