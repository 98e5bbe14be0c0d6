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

from ..mpeg4.feature_points import fp_index
from .scipy_modules import cKDTree
from .surface import loose_parts

REACH = 0.5  # an opening's centre lies within this share of the carried corners' distance of their midpoint
SIZE = (0.5, 2.0)  # and its width along the face's left is within these shares of that distance
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
    edges = np.sort(np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    if not len(boundary):
        return []
    labels = loose_parts(n_vertices, np.column_stack([boundary, boundary[:, 1]]))[boundary[:, 0]]
    return [boundary[labels == label] for label in np.unique(labels)]


def _crossings(vertices: np.ndarray, edges: np.ndarray, axis: np.ndarray, level: float) -> np.ndarray:
    """Points (C, 3) where the loop's edges cross the plane axis . x = level."""
    a = vertices[edges[:, 0]] @ axis - level
    b = vertices[edges[:, 1]] @ axis - level
    crossing = (a * b <= 0) & (a != b)
    t = a[crossing] / (a[crossing] - b[crossing])
    start, end = vertices[edges[crossing, 0]], vertices[edges[crossing, 1]]
    return start + t[:, None] * (end - start)


def refine_openings(
    placed: np.ndarray, vertices: np.ndarray, loops: list[np.ndarray], axes: np.ndarray, skin: np.ndarray
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
        for upper, lower, share in middles:
            level = middle + share * (corners[0] @ left - middle)
            crossing = _crossings(vertices, loop, left, level)
            if len(crossing) < 2:
                continue
            height = crossing @ up
            placed[fp_index(upper)] = crossing[np.argmax(height)]
            placed[fp_index(lower)] = crossing[np.argmin(height)]
            moved += [upper, lower]
    return moved


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
