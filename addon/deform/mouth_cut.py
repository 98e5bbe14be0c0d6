"""Opening a mouth whose lips the mesh seals (no bpy): where to cut, and which faces go to which lip.

Some meshes close the mouth: a scan or a sculpt whose lips are one surface over a crease, a coarse remesh, lips
welded together. Their lips cannot part: the skin between them stretches instead, and the triangles that bridge
the crease belong to both lips, so the lip guard cannot keep them on either side. Set-up says so (`face_checks`);
"Open Sealed Mouth" cuts the mesh open along the mouth line on the user's word. This module finds the cut.

- **Sealed?** Each pair of inner-lip FPs across the mouth (2.2/2.3 at the middle, 2.6/2.8 and 2.7/2.9 halfway to
  the corners) must be joined over the skin (`face_checks.joined_near`: a path along the edges between them
  hardly longer than the straight line; an opening's width there is twice the pair's distance to the nearer
  corner, which a path round the opening goes to and back). Lips open at any of them are open already, or sealed
  only in part; the cut is not made (a cut along a lip's open rim would split the lip itself).
- **The FPs in order**: the upper FP of each pair must not lie above the lower one by more than an edge of the
  mesh there (FPs on the crease may coincide: the standard's neutral face has its lips closed). Inner-lip FPs on
  one lip (a placement that missed the crease) would put the cut through that lip's skin.
- **The path**: the edges from 2.4 to 2.5 through the crease, leg by leg between the waypoints 2.4, (2.6+2.8)/2,
  (2.2+2.3)/2, (2.7+2.9)/2, 2.5 (the inner lip contour the standard puts these FPs on), each leg the shortest
  along the edges with each edge's length weighted by how little the surface folds into a valley there:
  (1 + cos fold) / 2 for a valley folding by `fold` (1 flat or over a ridge, 0 folded shut), 0 where more than
  two faces share the edge (lips welded: the surface meets itself there). A crease is the cheapest way along.
- **A crease**: the cut's edges must fold into a valley by 60 degrees on average (`CREASE`): a path over smooth
  skin is not where lips meet (inner-lip FPs placed on one lip).
- **The sides**: the faces around the path's inner vertices, joined across their edges that are not cut, fall
  into pieces; each piece is the upper or the lower lip's by whether its faces lie above or below the path in
  the face frame. The lower side's corners at the path's inner vertices get new vertices (`split_corners`); the
  corners 2.4 and 2.5 stay one vertex each, so the cut is a slit that ends at the mouth's corners.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import Mpeg4Error
from ..geometry.pieces import connected_pieces
from . import face_checks

LIP_PAIRS = (("2.6", "2.8"), ("2.2", "2.3"), ("2.7", "2.9"))  # (upper, lower) inner-lip FPs across the mouth
CORNERS = ("2.4", "2.5")
CUT_FPS = (*CORNERS, *(fp for pair in LIP_PAIRS for fp in pair))
# the most a cut's edges may weigh on average (length-weighted `edge_weights`): a surface folding by 60 degrees along
# it. Lips sealed over a crease fold by far more (walls 0.1-0.5 mm apart: about 150 degrees, weight 0.07; welded: 0);
# a path over smooth skin (inner-lip FPs that missed the crease) by little (weight 0.95-1)
CREASE = 0.75


class MouthCutError(Mpeg4Error):
    """The mouth cannot or need not be cut: the message says why and what to do."""


@dataclass
class MouthCut:
    path: np.ndarray  # (P,) vertex indices from 2.4's vertex to 2.5's, along edges
    upper: np.ndarray  # polygon indices on the upper side of the path's inner vertices
    lower: np.ndarray  # polygon indices on the lower side: their corners at the path's inner vertices get new ones
    length: float  # along the path, mesh units

    @property
    def edges(self) -> np.ndarray:
        """(P-1, 2) the path's edges."""
        return np.stack([self.path[:-1], self.path[1:]], axis=1)


def _polygon_edges(sizes: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(L, 2) each corner's edge to the next corner of its polygon, and (L,) the polygon of each corner."""
    sizes = np.asarray(sizes, dtype=np.int64)
    corners = np.asarray(corners, dtype=np.int64)
    polygon = np.repeat(np.arange(len(sizes)), sizes)
    start = np.repeat(np.cumsum(sizes) - sizes, sizes)
    position = np.arange(len(corners)) - start
    following = start + (position + 1) % np.repeat(sizes, sizes)
    return np.stack([corners, corners[following]], axis=1), polygon


def _polygon_normals(vertices: np.ndarray, sizes: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, 3) unit normals (Newell's method: any planar or slightly bent polygon) and (F, 3) centroids."""
    pairs, polygon = _polygon_edges(sizes, corners)
    a, b = vertices[pairs[:, 0]], vertices[pairs[:, 1]]
    newell = np.stack([(a[:, 1] - b[:, 1]) * (a[:, 2] + b[:, 2]), (a[:, 2] - b[:, 2]) * (a[:, 0] + b[:, 0])], axis=1)
    newell = np.column_stack([newell, (a[:, 0] - b[:, 0]) * (a[:, 1] + b[:, 1])])
    normals = np.zeros((len(sizes), 3))
    np.add.at(normals, polygon, newell)
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, norm, out=np.zeros_like(normals), where=norm > 0.0)
    centroids = np.zeros((len(sizes), 3))
    np.add.at(centroids, polygon, a)
    return normals, centroids / np.maximum(np.asarray(sizes, dtype=np.float64), 1.0)[:, None]


def edge_weights(vertices: np.ndarray, sizes: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's unique edges (E, 2) (smaller index first) and each one's weight along the cut: (1 + cos fold) / 2
    where its two faces fold into a valley by `fold` (one face's centroid lies on the other's front), 1 where they
    are flat or form a ridge or the edge is open, 0 where more than two faces share it."""
    vertices = np.asarray(vertices, dtype=np.float64)
    pairs, polygon = _polygon_edges(sizes, corners)
    keys = np.sort(pairs, axis=1)
    edges, inverse, count = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    weight = np.ones(len(edges))
    weight[count > 2] = 0.0
    normals, centroids = _polygon_normals(vertices, sizes, corners)
    two = np.flatnonzero(count == 2)
    order = np.argsort(inverse, kind="stable")
    first = np.searchsorted(inverse[order], two)
    f1, f2 = polygon[order[first]], polygon[order[first + 1]]
    cos_fold = np.clip(np.einsum("ij,ij->i", normals[f1], normals[f2]), -1.0, 1.0)
    middle = 0.5 * (vertices[edges[two, 0]] + vertices[edges[two, 1]])
    valley = np.einsum("ij,ij->i", normals[f1], centroids[f2] - middle) > 0.0
    weight[two] = np.where(valley, 0.5 * (1.0 + cos_fold), 1.0)
    return edges, weight


def _graph(vertices: np.ndarray, edges: np.ndarray, weight: np.ndarray):
    from scipy.sparse import coo_matrix

    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    # a stored zero must stay an edge (scipy drops none, but a path through it must still cost something)
    cost = np.maximum(length * weight, np.finfo(float).tiny)
    n = len(vertices)
    return coo_matrix((cost, (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()


def _leg(graph, a: int, b: int) -> list[int]:
    """The cheapest path of vertices from `a` to `b` (both included); [] when `b` cannot be reached."""
    from scipy.sparse.csgraph import dijkstra

    dist, previous = dijkstra(graph, directed=False, indices=a, return_predecessors=True)
    if not np.isfinite(dist[b]):
        return []
    path = [b]
    while path[-1] != a:
        path.append(int(previous[path[-1]]))
    return path[::-1]


def _without_loops(path: list[int]) -> list[int]:
    """The path with any stretch that comes back to a vertex already passed taken out (legs that double back)."""
    out: list[int] = []
    seen: dict[int, int] = {}
    for v in path:
        if v in seen:
            for dropped in out[seen[v] + 1 :]:
                del seen[dropped]
            del out[seen[v] + 1 :]
            continue
        seen[v] = len(out)
        out.append(v)
    return out


def _nearest(vertices: np.ndarray, point: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(vertices - point, axis=1)))


def find_mouth_cut(
    vertices: np.ndarray,
    sizes: np.ndarray,
    corners: np.ndarray,
    positions: Mapping[str, np.ndarray],
    axes: np.ndarray,
) -> MouthCut:
    """Where to cut a sealed mouth open. `vertices` (N, 3) and the polygons as `sizes` (F,) corner counts and
    `corners` (L,) vertex indices, polygon after polygon; `positions` the FPs (id -> (3,), mesh coordinates; the
    corners and inner-lip FPs `CUT_FPS` are needed); `axes` (3, 3) the face frame's rows (x left, y up, z forward)
    in mesh coordinates. MouthCutError (nothing to cut, or the FPs do not say where) names the FPs."""
    missing = [fp for fp in CUT_FPS if fp not in positions]
    if missing:
        raise MouthCutError(
            f"feature points missing: FP {', '.join(missing)} (the mouth's corners and inner lips say where to cut)"
        )
    try:
        import scipy.sparse.csgraph  # noqa: F401
    except ImportError as exc:  # a platform without a scipy wheel
        raise MouthCutError("Open Sealed Mouth needs scipy, which this Blender has not got") from exc
    vertices = np.asarray(vertices, dtype=np.float64)
    sizes = np.asarray(sizes, dtype=np.int64)
    corners = np.asarray(corners, dtype=np.int64)
    fps = {fp: np.asarray(positions[fp], dtype=np.float64) for fp in CUT_FPS}
    if not all(np.isfinite(p).all() for p in fps.values()) or len(vertices) == 0 or len(sizes) == 0:
        raise MouthCutError("the mesh has no faces, or the mouth's feature points have no position")
    edges, weight = edge_weights(vertices, sizes, corners)
    lengths = _graph(vertices, edges, np.ones(len(edges)))
    from scipy.sparse.csgraph import dijkstra

    opened = []
    for upper, lower in LIP_PAIRS:
        # an opening's width as seen from this pair: a path between them round the nearer corner and back
        middle = 0.5 * (fps[upper] + fps[lower])
        width = 2.0 * min(float(np.linalg.norm(middle - fps[corner])) for corner in CORNERS)
        if not face_checks.joined_near(lengths, vertices, fps[upper], fps[lower], width, dijkstra):
            opened.append(f"FP {upper} and {lower}")
    if len(opened) == len(LIP_PAIRS):
        raise MouthCutError("the mesh has an opening between the lips already (between their inner FPs): nothing cut")
    if opened:
        raise MouthCutError(
            f"the lips are open between {', '.join(opened)} and sealed elsewhere: cut the sealed part by hand "
            "(Edit Mode: select its edges, Edge > Split > Faces by Edges)"
        )
    up = np.asarray(axes, dtype=np.float64)[1]
    order = []
    for upper, lower in LIP_PAIRS:
        a, b = _nearest(vertices, fps[upper]), _nearest(vertices, fps[lower])
        near = np.isin(edges, [a, b]).any(axis=1)
        edge = float(np.linalg.norm(vertices[edges[near, 0]] - vertices[edges[near, 1]], axis=1).max())
        if (fps[lower] - fps[upper]) @ up > edge:
            order.append(f"FP {lower} lies above FP {upper}")
    if order:
        raise MouthCutError(
            f"the inner-lip feature points are not on the line where the lips meet ({'; '.join(order)}): place "
            "them on it (Place Feature Points) and run Open Sealed Mouth again"
        )
    waypoints = [_nearest(vertices, fps["2.4"])]
    waypoints += [_nearest(vertices, 0.5 * (fps[u] + fps[lo])) for u, lo in LIP_PAIRS]
    waypoints.append(_nearest(vertices, fps["2.5"]))
    graph = _graph(vertices, edges, weight)
    path: list[int] = [waypoints[0]]
    for a, b in zip(waypoints[:-1], waypoints[1:], strict=True):
        if a == b:
            continue
        leg = _leg(graph, a, b)
        if not leg:
            raise MouthCutError("the mouth's corners (FP 2.4, 2.5) are not joined along the mesh's edges: nothing cut")
        path += leg[1:]
    path = _without_loops(path)
    if len(path) < 3:
        raise MouthCutError("the mouth's corners (FP 2.4, 2.5) are one or two edges apart: nothing to cut")
    fold = _mean_weight(vertices, edges, weight, np.array(path))
    if fold > CREASE:
        degrees = np.degrees(np.arccos(2.0 * fold - 1.0))
        raise MouthCutError(
            f"no crease along the inner-lip feature points: the skin there folds by {degrees:.0f} degrees on average, "
            "not where two lips meet; place FP 2.2-2.9 on the line where the lips meet and run Open Sealed Mouth "
            "again (nothing cut)"
        )
    upper, lower = _sides(vertices, sizes, corners, np.array(path), up)
    if not len(upper) or not len(lower):
        raise MouthCutError("a cut from FP 2.4 to 2.5 would not part the lips here: nothing cut")
    path = np.array(path)
    length = float(np.linalg.norm(np.diff(vertices[path], axis=0), axis=1).sum())
    return MouthCut(path, upper, lower, length)


def _mean_weight(vertices: np.ndarray, edges: np.ndarray, weight: np.ndarray, path: np.ndarray) -> float:
    """The path's edges' `edge_weights`, averaged over its length."""
    on = np.sort(np.stack([path[:-1], path[1:]], axis=1), axis=1)
    rows = np.searchsorted(edges[:, 0] * len(vertices) + edges[:, 1], on[:, 0] * len(vertices) + on[:, 1])
    length = np.linalg.norm(vertices[on[:, 0]] - vertices[on[:, 1]], axis=1)
    return float((weight[rows] * length).sum() / max(length.sum(), np.finfo(float).tiny))


def _sides(
    vertices: np.ndarray, sizes: np.ndarray, corners: np.ndarray, path: np.ndarray, up: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The polygons around the path's inner vertices, upper and lower: pieces joined across edges at those vertices
    that are not cut, each on the side of the path its centroid lies on (mean height above the nearest inner
    vertex, along `up`)."""
    inner = np.zeros(len(vertices), bool)
    inner[path[1:-1]] = True
    pairs, polygon = _polygon_edges(sizes, corners)
    touching = np.unique(polygon[inner[corners]])
    cut = {(int(min(a, b)), int(max(a, b))) for a, b in zip(path[:-1], path[1:], strict=True)}
    keys = np.sort(pairs, axis=1)
    # edges at an inner vertex, not cut: the faces on either side of one are on the same side of the path
    joins = inner[keys].any(axis=1) & np.array([tuple(k) not in cut for k in keys.tolist()], dtype=bool)
    joins &= np.isin(polygon, touching)
    keys, owners = keys[joins], polygon[joins]
    order = np.lexsort((keys[:, 1], keys[:, 0]))
    keys, owners = keys[order], owners[order]
    same = np.flatnonzero((keys[1:] == keys[:-1]).all(axis=1))
    index = {int(f): k for k, f in enumerate(touching)}
    rows = [index[int(f)] for f in owners[same]]
    cols = [index[int(f)] for f in owners[same + 1]]
    pieces = connected_pieces(len(touching), np.array([rows, cols], dtype=np.int64).reshape(2, -1).T)
    first, label = np.unique(pieces, return_inverse=True)
    count = len(first)
    _normals, centroids = _polygon_normals(vertices, sizes, corners)
    points = vertices[path[1:-1]]
    nearest = np.argmin(np.linalg.norm(centroids[touching][:, None] - points[None], axis=2), axis=1)
    height = (centroids[touching] - points[nearest]) @ up
    piece_height = np.bincount(label, weights=height, minlength=count) / np.bincount(label, minlength=count)
    above = piece_height[label] > 0.0
    return touching[above], touching[~above]


def split_corners(
    vertex_count: int, sizes: np.ndarray, corners: np.ndarray, cut: MouthCut
) -> tuple[np.ndarray, np.ndarray]:
    """The polygons' corners after the cut and (M,) the vertex each new vertex copies (new vertex k is
    `vertex_count + k`): the lower side's corners at the path's inner vertices move to the copies."""
    corners = np.array(corners, dtype=np.int64)
    _pairs, polygon = _polygon_edges(sizes, corners)
    sources = np.asarray(cut.path[1:-1], dtype=np.int64)
    new = np.full(vertex_count, -1, dtype=np.int64)
    new[sources] = vertex_count + np.arange(len(sources))
    moving = np.isin(polygon, cut.lower) & (new[corners] >= 0)
    corners[moving] = new[corners[moving]]
    return corners, sources
