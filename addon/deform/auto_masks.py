"""Lip and eyelid masks made from the feature points, for a face that has none (no bpy; scipy's shortest paths where
there is scipy, the same in Python where not).

The masks say which side of an opening a vertex is on (paper 000, section 3: the texture masks that keep
control triangles from moving skin across the mouth and eye openings), with the meaning the hand-made
ones have: `lower_lip` is the jaw side of the mouth, `upper_lip` = 1 - `lower_lip`; `upper_eyelid` is 0
on the lower lids and 1 elsewhere, `lower_eyelid` 0 on the upper lids.

A vertex's side is decided by geodesic distance along the mesh's edges to each side of the opening: where
the mouth or an eye is an opening in the mesh, paths between the two sides must go round its corners, so
the sides part along the opening itself. Each side is measured from its edge of the opening (`rim_vertices`:
the vertices along the curve through the corners and the side's middle FP) and its FPs. Measured from the
FPs alone (as before), a lid's membership was a disc about its FPs: it faded along the lid's own margin
toward the corners, so a blink closed the middle of a lid ahead of the rest (the zig-zag edge and the
bunched skin above it on the sample with its groups deleted), and on a remesh it followed whichever edges
led there. From the edge curve it is a band along the whole margin, the same on any topology. The sides
blend over a band of `SIDE_BAND` (x the opening's width) so the masks are soft, and a lid's membership fades
out between `LID_REACH` x the eye's width from its side: the hand-made lids of the sample end 2-3 mm above
the margin (its tarsal plate), where skin farther up, turned with the lid, bunched at the blink.
"""

from __future__ import annotations

import heapq

import numpy as np

from ..mpeg4.control_mesh import MASK_SETS
from ..mpeg4.feature_points import fp_index

SIDE_BAND = 0.15  # x mouth or eye width: the band over which a vertex goes from one side to the other
LID_REACH = (0.1, 0.3)  # x eye width: a lid's membership is 1 up to the first, 0 past the second
EYE_WIDTH_FPS = (("3.7", "3.11"), ("3.8", "3.12"))
MOUTH_WIDTH_FPS = ("2.4", "2.5")
# each eye's (corner, corner, upper lid's middle, lower lid's middle) FPs, for its edges (`rim_vertices`)
EYE_OPENINGS = ((*EYE_WIDTH_FPS[0], "3.1", "3.3"), (*EYE_WIDTH_FPS[1], "3.2", "3.4"))
RIM_SAMPLES, RIM_CORNER = 24, 0.1  # points along an opening's edge; the share of it left out at each corner


def geodesic_distance(
    vertices: np.ndarray, edges: np.ndarray, sources: np.ndarray, limit: float = np.inf
) -> np.ndarray:
    """(N,) length of the shortest edge path from each vertex to the nearest of `sources` (inf: unreached, or
    farther than `limit`): scipy's Dijkstra, or where a platform has no scipy wheel, `_geodesic_distance_heap`
    (equal, `tests/core/test_auto_masks.py`)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    sources = np.unique(np.asarray(sources, dtype=np.intp))
    try:
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra
    except ImportError:
        return _geodesic_distance_heap(vertices, edges, sources, limit)
    n = len(vertices)
    if not len(sources):
        return np.full(n, np.inf)
    # one entry per vertex pair, at its shortest length: a sparse matrix would add up repeated pairs, and a stored
    # zero (two vertices at one place) must stay an edge, so lengths are kept above zero by the least float
    pairs = np.sort(edges, axis=1)
    length = np.maximum(np.linalg.norm(vertices[pairs[:, 0]] - vertices[pairs[:, 1]], axis=1), np.finfo(float).tiny)
    order = np.lexsort((length, pairs[:, 1], pairs[:, 0]))
    pairs, length = pairs[order], length[order]
    first = np.ones(len(pairs), bool)
    first[1:] = np.any(pairs[1:] != pairs[:-1], axis=1)
    pairs, length = pairs[first], length[first]
    graph = csr_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return dijkstra(graph, directed=False, indices=sources, min_only=True, limit=limit)


def _geodesic_distance_heap(
    vertices: np.ndarray, edges: np.ndarray, sources: np.ndarray, limit: float = np.inf
) -> np.ndarray:
    """`geodesic_distance` by a binary heap in Python, for a platform without scipy."""
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    order = np.argsort(np.concatenate([edges[:, 0], edges[:, 1]]), kind="stable")
    nbr = np.concatenate([edges[:, 1], edges[:, 0]])[order].tolist()
    wgt = np.concatenate([length, length])[order].tolist()
    start = np.searchsorted(np.concatenate([edges[:, 0], edges[:, 1]])[order], np.arange(len(vertices) + 1)).tolist()
    dist = [np.inf] * len(vertices)
    heap = []
    for s in sources.tolist():
        dist[s] = 0.0
        heap.append((0.0, s))
    heapq.heapify(heap)
    while heap:
        d, v = heapq.heappop(heap)
        if d > dist[v]:
            continue
        for k in range(start[v], start[v + 1]):
            nd = d + wgt[k]
            u = nbr[k]
            if nd < dist[u] and nd <= limit:
                dist[u] = nd
                heapq.heappush(heap, (nd, u))
    return np.array(dist)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def nearest_vertices(vertices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Index of the vertex nearest each point."""
    d = np.linalg.norm(np.asarray(vertices)[None] - np.asarray(points)[:, None], axis=2)
    return np.argmin(d, axis=1)


def edge_curves(
    neutral: np.ndarray, opening: tuple[str, str, str, str], samples: int = 24, corner: float = RIM_CORNER
) -> np.ndarray | None:
    """(2, samples, 3) points along the upper and the lower edge of an opening: the parabola through its corners
    and that side's middle FP (`opening` = (corner, corner, upper middle, lower middle) FP ids), leaving out the
    `corner` share of its length at each corner, where the two edges meet; None when an FP is missing."""
    points = np.array([neutral[fp_index(f)] for f in opening])
    if not np.all(np.isfinite(points)):
        return None
    chord = points[1] - points[0]
    s = np.linspace(corner, 1.0 - corner, samples)[:, None]
    curves = []
    for middle in points[2:]:
        # where along the corner-to-corner line the middle FP falls: the parabola's parameter there
        at = float(np.clip((middle - points[0]) @ chord / (chord @ chord), 0.2, 0.8))
        # Lagrange's quadratic through (0, corner), (at, middle), (1, other corner)
        curves.append(
            points[0] * ((s - at) * (s - 1.0)) / at
            + middle * (s * (s - 1.0)) / (at * (at - 1.0))
            + points[1] * (s * (s - at)) / (1.0 - at)
        )
    return np.stack(curves)


def rim_vertices(vertices: np.ndarray, neutral: np.ndarray, opening: tuple[str, str, str, str]) -> tuple | None:
    """(upper rim, lower rim): the vertices nearest `RIM_SAMPLES` points along each edge of an opening
    (`edge_curves`); None when an FP is missing. The edges are curves in space, so their vertices are the same
    on any topology, with or without a hole in the mesh there."""
    curves = edge_curves(neutral, opening, RIM_SAMPLES)
    if curves is None:
        return None
    return tuple(np.unique(nearest_vertices(vertices, curve)) for curve in curves)


def _side(vertices, edges, neutral, upper_ids, lower_ids, band, rims=None):
    """(N,) how far each vertex is on the lower side (0..1), and its distance to the lower and the upper side
    (the side's FPs, with its edge of each opening: `rim_vertices`)."""
    seeds = {}
    for k, (name, ids) in enumerate((("upper", upper_ids), ("lower", lower_ids))):
        points = [neutral[fp_index(f)] for f in sorted(ids) if np.all(np.isfinite(neutral[fp_index(f)]))]
        near = nearest_vertices(vertices, np.array(points)) if points else np.array([], dtype=np.intp)
        seeds[name] = _twin_on_side(vertices, edges, near)
        if rims is not None:
            seeds[name] = np.concatenate([seeds[name], rims[k]])
    d_up = geodesic_distance(vertices, edges, seeds["upper"])
    d_low = geodesic_distance(vertices, edges, seeds["lower"])
    with np.errstate(invalid="ignore"):
        lower = _smoothstep(0.5 + (d_up - d_low) / band)
    return np.where(np.isfinite(d_up) | np.isfinite(d_low), np.nan_to_num(lower, nan=0.0), 0.0), d_low, d_up


def _twin_on_side(vertices: np.ndarray, edges: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """`seeds` (one side's FPs' nearest vertices) with each vertex that shares its place with others (a mesh cut
    open along a line, Open Sealed Mouth: one vertex for each side of the cut) replaced by the one nearest, over
    the skin, to the side's seeds that share their place with none (its other FPs: on the cut, the nearest vertex
    to an FP is otherwise whichever comes first, as often the other side's)."""
    seeds = np.asarray(seeds, dtype=np.intp)
    if not len(seeds):
        return seeds
    _places, group, count = np.unique(vertices, axis=0, return_inverse=True, return_counts=True)
    group = group.reshape(-1)
    shared = count[group[seeds]] > 1
    if not shared.any() or shared.all():
        return seeds
    reach = geodesic_distance(vertices, edges, seeds[~shared])
    out = seeds.copy()
    for k in np.flatnonzero(shared):
        twins = np.flatnonzero(group == group[seeds[k]])
        out[k] = twins[np.argmin(reach[twins])]
    return out


def _width(neutral, pair) -> float:
    a, b = (neutral[fp_index(f)] for f in pair)
    return float(np.linalg.norm(a - b)) if np.all(np.isfinite(a)) and np.all(np.isfinite(b)) else np.nan


def _rims(vertices, neutral, openings) -> tuple[np.ndarray, np.ndarray] | None:
    """The upper and lower edges' vertices of those of `openings` whose FPs are placed (`rim_vertices`), joined;
    None when there are none (then the FPs alone say the sides)."""
    rims = [r for r in (rim_vertices(vertices, neutral, ids) for ids in openings) if r is not None]
    if not rims:
        return None
    return np.concatenate([r[0] for r in rims]), np.concatenate([r[1] for r in rims])


def make_masks(vertices: np.ndarray, edges: np.ndarray, neutral: np.ndarray) -> dict[str, np.ndarray]:
    """The four masks of a rest mesh ((N, 3) vertices, (E, 2) edges) from its (84, 3) neutral FPs.

    A mask whose FPs are missing (no inner-lip or eyelid points, or no mouth or eye corners to measure the
    opening's width) is left out.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    masks = {}
    mouth = _width(neutral, MOUTH_WIDTH_FPS)
    if np.isfinite(mouth) and mouth > 0:
        # the lips' edges are not taken: the inner lips of a closed mouth touch, so the nearest vertices to one
        # lip's edge curve are as often the other lip's (with them, 62 crossing pairs at the demo's speech on the
        # sample with its groups deleted; 0 without)
        jaw, _d, _u = _side(vertices, edges, neutral, MASK_SETS["upper_lip"], MASK_SETS["lower_lip"], SIDE_BAND * mouth)
        masks["upper_lip"] = 1.0 - jaw
        masks["lower_lip"] = jaw
    widths = [w for w in (_width(neutral, pair) for pair in EYE_WIDTH_FPS) if np.isfinite(w)]
    eye = float(np.mean(widths)) if widths else np.nan
    if np.isfinite(eye) and eye > 0:
        rims = _rims(vertices, neutral, EYE_OPENINGS)
        lower, d_low, d_up = _side(
            vertices, edges, neutral, MASK_SETS["upper_eyelid"], MASK_SETS["lower_eyelid"], SIDE_BAND * eye, rims
        )
        near, far = LID_REACH[0] * eye, LID_REACH[1] * eye
        if rims is not None:
            # a lid is a band along its margin (the tarsal plate), so its reach is measured from the margin alone:
            # measured from its FPs too, the upper lid took a disc of full members about 3.13 / 3.14, which lie on
            # the lid's surface and, on a head with a deep lid crease (ICT FaceKit's), 8.6 mm above the margin,
            # inside a ring of skin that is not: a blink turned that disc with the lid and left its ring, spikes
            # (the rims' curves pass through the middle FPs 3.1-3.4, on the margin)
            d_up, d_low = (geodesic_distance(vertices, edges, rim) for rim in rims)
        lower_lid = lower * _smoothstep((far - d_low) / (far - near))
        upper_lid = (1.0 - lower) * _smoothstep((far - d_up) / (far - near))
        masks["upper_eyelid"] = 1.0 - lower_lid
        masks["lower_eyelid"] = 1.0 - upper_lid
    return masks
