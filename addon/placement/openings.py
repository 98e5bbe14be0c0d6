"""Eye and lip points from the openings themselves, where the mesh has them: a character modelled with
separate eyeballs has a hole in its skin for each eye, and one with a mouth cavity a hole between its
lips. Each opening is a loop of boundary edges (edges of one triangle only). Near the carried guess, the
opening's corners are its loop's extreme points along the face's left axis (the eye corners 3.7/3.11 and
3.8/3.12, the inner lip corners 2.4/2.5); the lid middles (3.1-3.4) and the inner lip points (2.2, 2.3,
2.6-2.9) are where the loop crosses the plane across the face at the middle between the corners (for
2.6-2.9 midway between the middle and a corner), the upper crossing on the upper lid or lip and the lower
on the lower. A closed surface (a scan, a head whose lids meet) has no such loop and keeps its points, and
so does an eye whose loop is hidden behind skin seen from the front (lids tucked round an eyeball: the lid
edge a viewer sees is then not the loop); a mouth's loop is taken wherever it is (where the lips part).
"""

from __future__ import annotations

import numpy as np

from ..deform.face_checks import joined_over_skin
from ..mpeg4.feature_points import fp_index
from .nicp import border_edges, edges_of
from .scipy_modules import cKDTree, csr_matrix, dijkstra
from .section import front, section
from .surface import loose_parts

REACH = 0.5  # an opening's centre lies within this share of the carried corners' distance of their midpoint
SIZE = (0.5, 2.0)  # and its width along the face's left is within these shares of that distance
SEALED_BAND = 0.25  # a sealed mouth's lips are looked for this share of its width above and below its opening
NOTCH_BANDS = 40  # the section seen from in front of the lips in bands of this share of the lips' height
VISIBLE_SHARE = 0.05  # the neighbourhood, against the opening's width, in which skin in front hides its loop

# (outer or left corner, inner or right corner, [(upper FP, lower FP, share of the way from the middle to
# the first corner)], only when seen from the front) for each opening: the left eye, the right eye, the
# mouth. The mouth's loop is taken even when the lips hide it: it is where the lips part, and set-up opens
# the mouth between 2.2 and 2.3 only when they lie on either side of it.
OPENINGS = (
    ("3.7", "3.11", [("3.1", "3.3", 0.0)], True),
    ("3.8", "3.12", [("3.2", "3.4", 0.0)], True),
    ("2.4", "2.5", [("2.2", "2.3", 0.0), ("2.6", "2.8", 0.5), ("2.7", "2.9", -0.5)], False),
)


def boundary_loops(n_vertices: int, triangles: np.ndarray) -> list[np.ndarray]:
    """The mesh's boundary edges grouped into connected loops (a list of (k, 2) vertex pairs); an edge is
    labelled as a triangle with a repeated corner."""
    boundary = border_edges(triangles)
    if not len(boundary):
        return []
    labels = loose_parts(n_vertices, np.column_stack([boundary, boundary[:, 1]]))[boundary[:, 0]]
    return [boundary[labels == label] for label in np.unique(labels)]


def plane_crossings(vertices: np.ndarray, edges: np.ndarray, axis: np.ndarray, level: float) -> np.ndarray:
    """Points (C, 3) where the loop's edges cross the plane axis . x = level."""
    a = vertices[edges[:, 0]] @ axis - level
    b = vertices[edges[:, 1]] @ axis - level
    crossing = (a * b <= 0) & (a != b)
    t = a[crossing] / (a[crossing] - b[crossing])
    start, end = vertices[edges[crossing, 0]], vertices[edges[crossing, 1]]
    return start + t[:, None] * (end - start)


def refine_openings(
    placed: np.ndarray,
    vertices: np.ndarray,
    triangles: np.ndarray,
    loops: list[np.ndarray],
    axes: np.ndarray,
    skin: np.ndarray,
) -> list[str]:
    """Move the eye and inner lip points of `placed` (84, 3; changed in place) onto the openings found near
    them (`axes`: rows left, up, forward; `skin`: area samples of the skin). Returns the FP ids moved."""
    left, up = axes[0], axes[1]
    moved = []
    for first, second, middles, seen in OPENINGS:
        a, b = placed[fp_index(first)], placed[fp_index(second)]
        width = abs((a - b) @ left)
        loop = _opening(vertices, loops, 0.5 * (a + b), width, left)
        if loop is None or (seen and _hidden(vertices[np.unique(loop)], skin, axes)):
            continue
        ring = vertices[np.unique(loop)]
        extreme = ring[[np.argmax(ring @ left), np.argmin(ring @ left)]]
        corners = extreme if (a - b) @ left > 0 else extreme[::-1]
        placed[fp_index(first)], placed[fp_index(second)] = corners
        moved += [first, second]
        middle = 0.5 * (corners[0] + corners[1]) @ left
        span = float(np.linalg.norm(corners[0] - corners[1]))
        sealed = None if seen or not _hidden(ring, skin, axes) else _Sealed(vertices, triangles, loop, width, span)
        for upper, lower, share in middles:
            level = middle + share * (corners[0] @ left - middle)
            crossing = plane_crossings(vertices, loop, left, level)
            if len(crossing) < 2:
                continue
            height = crossing @ up
            top, bottom = crossing[np.argmax(height)], crossing[np.argmin(height)]
            if sealed is not None:
                top, bottom = sealed.meeting(top, bottom, level, axes)
            placed[fp_index(upper)], placed[fp_index(lower)] = top, bottom
            moved += [upper, lower]
    return moved


def _notch(segments: np.ndarray, centre: np.ndarray, axes: np.ndarray, band: float) -> np.ndarray | None:
    """Where lips that meet begin to touch, seen from the front: the section's `segments` (S, 2, 3: each
    triangle's cut by the plane) seen from in front (`section.front`: per NOTCH_BANDS-th of `band` of height
    the most forward sample), in front of `centre`, and of those between the most forward one above `centre`
    (the upper lip's front) and the most forward one below it (the lower lip's) the one furthest back: the
    bottom of the groove between the lips. None when either lip has no front."""
    points, height, depth = front(segments, axes[1], axes[2], float(centre @ axes[1]), band, band / NOTCH_BANDS)
    depth = depth - centre @ axes[2]
    keep = depth > 0
    points, height, depth = points[keep], height[keep], depth[keep]
    above, below = height > 0, height <= 0
    if not above.any() or not below.any():
        return None
    low = height[below][np.argmax(depth[below])]
    high = height[above][np.argmax(depth[above])]
    between = (height >= low) & (height <= high)
    return points[between][np.argmin(depth[between])]


class _Sealed:
    """A mouth whose opening is hidden behind lips that meet in front of it (a face modelled with its lips
    closed, the mouth's inside cut away or never made): the inner lip points are where the lips meet, seen
    from the front, not the opening's edge behind them. In each plane across the face the skin's section,
    seen from inside the mouth (the middle of the opening there), has a notch where the lips meet (the
    mouth's crease: the section's point nearest that middle among those in front of it); each lip's point
    is its own section point nearest the notch, a point belonging to the lip it is nearer to over the skin
    (shortest paths along the edges from the opening's upper and lower edge: the lips join only round the
    mouth's corners, behind the notch they do not). Where the lips are one surface at the notch (a path over
    the skin joins the two points by a path less than half the opening's width longer than the straight
    line, the rule Set Up Face checks openings by), they part only at the opening
    behind them, so the points stay on its edge."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray, loop: np.ndarray, width: float, span: float):
        self.vertices, self.triangles = vertices, triangles
        self.edges = edges_of(triangles)
        length = np.linalg.norm(vertices[self.edges[:, 0]] - vertices[self.edges[:, 1]], axis=1)
        n = len(vertices)
        self.graph = csr_matrix((length, (self.edges[:, 0], self.edges[:, 1])), shape=(n, n))
        self.loop_vertices = np.unique(loop)
        self.reach = width
        self.span = span  # the distance between the opening's corners

    def meeting(self, top: np.ndarray, bottom: np.ndarray, level: float, axes: np.ndarray):
        """The upper and lower lip's points where the lips meet in the plane left . x = `level`, from the
        opening's upper and lower edge there (`top`, `bottom`); those unchanged when no notch is found."""
        left, up, forward = axes
        crossings, ends, segments = section(self.vertices, self.triangles, left, level)
        centre = 0.5 * (top + bottom)
        band = SEALED_BAND * self.reach
        near = ((crossings - centre) @ forward > 0) & (np.abs((crossings - centre) @ up) < band)
        notch = _notch(crossings[segments], centre, axes, band)
        if notch is None or not near.any():
            return top, bottom
        points, ends = crossings[near], ends[near]
        lips = self._nearer_lip(points, ends, top, bottom)
        found = []
        for lip in (0, 1):
            own = np.flatnonzero(lips == lip)
            if not len(own):
                return top, bottom
            found.append(points[own[np.argmin(np.linalg.norm(points[own] - notch, axis=1))]])
        # lips that are one surface where they meet (sealed in front) part only at the opening behind them:
        # their points stay on its edge, where Set Up Face can open the mouth; judged as Set Up Face judges
        # it, from the vertices nearest the two points
        a, b = (int(np.argmin(np.linalg.norm(self.vertices - point, axis=1))) for point in found)
        if joined_over_skin(self.graph, self.vertices, a, b, self.span, dijkstra):
            return top, bottom
        return found[0], found[1]

    def _nearer_lip(self, points: np.ndarray, ends: np.ndarray, top: np.ndarray, bottom: np.ndarray) -> np.ndarray:
        """0 for the section `points` (on edges `ends`) nearer the opening's upper edge over the skin (through
        their edge's nearer end), 1 for those nearer its lower edge."""
        ring = self.vertices[self.loop_vertices]
        sources = [self.loop_vertices[np.argmin(np.linalg.norm(ring - p, axis=1))] for p in (top, bottom)]
        paths = dijkstra(self.graph, directed=False, indices=sources, limit=3.0 * self.reach)
        start, end = (np.linalg.norm(points - self.vertices[ends[:, k]], axis=1) for k in (0, 1))
        nearest = np.where(start < end, ends[:, 0], ends[:, 1])
        return np.argmin(paths[:, nearest], axis=0)


def _hidden(ring: np.ndarray, skin: np.ndarray, axes: np.ndarray) -> bool:
    """Whether most of an opening's loop `ring` is hidden from the front by skin in front of it (a lid or a
    lip tucked behind over an eyeball or into a mouth cavity): its visible edge is then not the loop. Skin
    `skin` samples within a twentieth of the loop's width across the face and more than twice that in
    front of a loop vertex hide it."""
    radius = VISIBLE_SHARE * np.ptp(ring @ axes[0])
    flat = skin @ axes[:2].T
    tree = cKDTree(flat)
    depth = skin @ axes[2]
    hidden = [
        bool(len(near)) and depth[near].max() > point @ axes[2] + 2.0 * radius
        for point, near in zip(ring, tree.query_ball_point(ring @ axes[:2].T, radius), strict=True)
    ]
    return np.mean(hidden) > 0.5


def _opening(vertices, loops, centre, width, left):
    """The loop near `centre` about `width` wide along `left`, or None."""
    best = None
    for loop in loops:
        ring = vertices[np.unique(loop)]
        distance = np.linalg.norm(ring.mean(axis=0) - centre)
        extent = np.ptp(ring @ left)
        if distance <= REACH * width and SIZE[0] * width <= extent <= SIZE[1] * width:
            if best is None or distance < best[0]:
                best = (distance, loop)
    return None if best is None else best[1]
