"""The subnasale 9.15 by its definition, read off the skin's mid-plane section.

The sample's rule (`scripts/sample/makehuman/fp_rules.py`): on the mid-line profile between the nose tip 9.3
and the upper lip's middle 8.1, the point furthest inside the chord 9.3-8.1 (the corner where the columella
meets the lip). Distance from a chord does not depend on how the head is pitched. The profile is the
mid-plane's section of the skin followed as a chain, crossing to crossing through the triangles, from the
crossing nearest 9.3 to the one nearest 8.1 (the shortest such chain): a concave corner stays on it, where an
outline seen from a centre (`skull.outline`) drops a notch next to a part standing further out, and the
mouth's inside is not on it. Crossings lie on the mesh's edges, so a coarse mesh gives points between its
vertices; the furthest from a chord along a chain of straight pieces is one of the crossings."""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .scipy_modules import dijkstra
from .section import chain_graph, section
from .skull import ear_centre


def mid_line_chain(vertices: np.ndarray, triangles: np.ndarray, normal: np.ndarray, offset: float, start, end):
    """Points (K, 3) of the section of the mesh by the plane normal . x = offset, followed through the
    triangles from the crossing nearest `start` to the one nearest `end` (shortest path); empty when the
    plane misses the mesh or the two are not joined."""
    points, _edges, segments = section(vertices, triangles, normal, offset)
    if not len(points):
        return np.zeros((0, 3))
    graph = chain_graph(points, segments)
    first = np.argmin(np.linalg.norm(points - start, axis=1))
    last = np.argmin(np.linalg.norm(points - end, axis=1))
    distance, previous = dijkstra(graph, directed=False, indices=first, return_predecessors=True)
    if not np.isfinite(distance[last]):
        return np.zeros((0, 3))
    chain = [last]
    while chain[-1] != first:
        chain.append(previous[chain[-1]])
    return points[chain[::-1]]


def subnasale(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray, left: np.ndarray) -> np.ndarray:
    """`points` (84, 3) with 9.15 put where its definition says on the mesh, in the mid-plane normal to
    `left` through 9.3, 9.15 and 8.1 (the ears' mean 10.1-10.10 says which side is the back); left as it was
    when the section does not join 9.3 to 8.1."""
    points = points.copy()
    left = left / np.linalg.norm(left)
    mid = np.array([fp_index(i) for i in ("9.3", "9.15", "8.1")])
    offset = float(np.mean(points[mid] @ left))
    tip, lip = points[fp_index("9.3")], points[fp_index("8.1")]
    chain = mid_line_chain(vertices, triangles, left, offset, tip, lip)
    if len(chain) < 3:
        return points
    chord = tip - lip
    chord = chord - (chord @ left) * left
    chord /= np.linalg.norm(chord)
    inner = np.cross(left, chord)  # in the plane, square to the chord
    ears = ear_centre(points)
    if (ears - lip) @ inner < 0:
        inner = -inner  # towards the back of the head
    depth = (chain[1:-1] - lip) @ inner
    points[fp_index("9.15")] = chain[1:-1][np.argmax(depth)]
    return points
