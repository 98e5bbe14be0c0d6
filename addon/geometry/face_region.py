"""Which vertices of a head lie in the face region that the control mesh spans.

Planar Bones raises affection radii until every vertex "of the targeted face geometry" is covered
(paper 000, section 3). On a whole head the back of the skull and the neck are not face geometry:
covering them would blow the radii of the border triangles up to the size of the head. The face
region is what lies inside the control mesh's outline (its longest boundary loop; the holes at the
mouth and eyes are inside) seen from the head's vertical axis, i.e. inside the outline in the
cylindrical projection that also unrolls the face for triangulation.
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.frame import BLENDER_FACE_AXES
from .cylindrical import cylindrical_projection


def boundary_loops(triangles: np.ndarray) -> list[list[int]]:
    """Closed loops of edges used by exactly one triangle, each as an ordered vertex list."""
    tris = np.asarray(triangles)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    neighbours: dict[int, list[int]] = {}
    for a, b in unique[counts == 1].tolist():
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    loops, seen = [], set()
    for start in neighbours:
        if start in seen:
            continue
        loop, previous, current = [start], None, start
        seen.add(start)
        while True:
            options = [n for n in neighbours[current] if n != previous and (n not in seen or n == start)]
            if not options or options[0] == start:
                break
            previous, current = current, options[0]
            loop.append(current)
            seen.add(current)
        loops.append(loop)
    return loops


def face_region(vertices: np.ndarray, points: np.ndarray, triangles: np.ndarray, centre: np.ndarray,
                axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:  # fmt: skip
    """(N,) bool: the vertices inside the control mesh's outer outline, seen from the head's axis."""
    points = np.asarray(points, dtype=np.float64)
    loops = boundary_loops(triangles)
    if not loops:
        return np.ones(len(vertices), dtype=bool)
    outline = max(loops, key=lambda loop: float(np.linalg.norm(np.diff(points[loop + loop[:1]], axis=0), axis=1).sum()))
    radius = float(np.mean(np.linalg.norm((points - centre) @ np.asarray(axes)[[0, 2]].T, axis=1)))
    polygon = cylindrical_projection(points[outline], centre, axes, radius)
    query = cylindrical_projection(vertices, centre, axes, radius)
    # even-odd rule: count crossings of a ray toward +arc with each outline edge
    x0, y0 = polygon[:, 0], polygon[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    qx, qy = query[:, :1], query[:, 1:]
    straddles = (y0 > qy) != (y1 > qy)
    with np.errstate(divide="ignore", invalid="ignore"):
        crossing_x = x0 + (qy - y0) * (x1 - x0) / (y1 - y0)
    crossings = np.count_nonzero(straddles & (qx < crossing_x), axis=1)
    # only the face side of the head: the outline never reaches around behind it
    front = np.abs(query[:, 0]) < np.pi * radius * 0.75
    return (crossings % 2 == 1) & front
