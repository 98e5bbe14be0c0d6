"""A plane's section of the skin, and that section seen from in front.

`section`: where the plane cuts the triangles, as crossings on the mesh's edges and the segments joining them
(one per cut triangle, a pair of crossing indices: `crossings[segments]` are the segments' ends). A vertex
exactly on the plane counts on its positive side (the reading chosen: then every cut triangle has exactly two
crossed edges, a triangle touching the plane at a corner from the positive side is not cut, and one touching it
from the negative side gives a segment of no length at that corner; a vertex on the plane belongs to each
section once, as the crossing of the edges from it to the negative side).

`chain_graph`: the crossings joined by the segments, for shortest ways along the section.

`front`: the section seen from in front: its segments sampled along their length and, per band of height, the
most forward sample (what a viewer in front of the face sees). The bands' edges lie on the looked-at height
`centre` (the reading chosen: the bands are counted from there, up and down, so the two halves of the looked-at
height are whole bands each).
"""

from __future__ import annotations

import numpy as np

from .scipy_modules import csr_matrix

SAMPLES = 64  # at most this many samples along each segment


def section(vertices: np.ndarray, triangles: np.ndarray, normal: np.ndarray, level: float):
    """The plane normal . x = level through the mesh: the crossings (C, 3) where it cuts edges, each crossing's
    edge (C, 2), and the section's segments as pairs of crossing indices (S, 2), one per cut triangle."""
    side = vertices @ normal - level
    d = side[triangles]
    cut = (d.min(axis=1) < 0) & (d.max(axis=1) >= 0)  # a corner on the plane counts on its positive side
    triangles, negative = triangles[cut], d[cut] < 0
    if not len(triangles):
        return np.zeros((0, 3)), np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64)
    crossed = [negative[:, i] != negative[:, j] for i, j in ((0, 1), (1, 2), (2, 0))]
    edge = [np.sort(triangles[:, [i, j]], axis=1) for i, j in ((0, 1), (1, 2), (2, 0))]
    first = np.where(crossed[0][:, None], edge[0], edge[1])
    second = np.where(crossed[2][:, None], edge[2], edge[1])
    edges, index = np.unique(np.concatenate([first, second]), axis=0, return_inverse=True)
    a, b = side[edges[:, 0]], side[edges[:, 1]]
    t = a / (a - b)
    crossings = vertices[edges[:, 0]] + t[:, None] * (vertices[edges[:, 1]] - vertices[edges[:, 0]])
    return crossings, edges, index.reshape(2, -1).T


def chain_graph(crossings: np.ndarray, segments: np.ndarray):
    """The section as a sparse graph (C, C) for shortest ways along it: crossings joined by their segments,
    each weighted by its length (a segment of no length, a corner on the plane, by 1e-12 so that it still joins)."""
    length = np.linalg.norm(crossings[segments[:, 0]] - crossings[segments[:, 1]], axis=1) + 1e-12
    n = len(crossings)
    return csr_matrix((length, (segments[:, 0], segments[:, 1])), shape=(n, n))


def front(segments: np.ndarray, up: np.ndarray, forward: np.ndarray, centre: float, half: float, step: float):
    """The section's `segments` (S, 2, 3) seen from in front within `half` of height `centre` (along `up`): per
    band of height `step` (counted from `centre`) the most forward sample along the segments (each sampled
    finely enough to reach every band it crosses, at most SAMPLES times). Returns (points (B, 3), heights above
    `centre` (B,), depths along `forward` (B,)) in order of height."""
    a, b = segments[:, 0], segments[:, 1]
    rise = np.abs((b - a) @ up)
    count = int(np.clip(np.ceil(rise.max(initial=0.0) / step) + 2, 2, SAMPLES))
    t = np.linspace(0.0, 1.0, count)[None, :, None]
    samples = (a[:, None] + t * (b - a)[:, None]).reshape(-1, 3)
    height = samples @ up - centre
    samples, height = samples[np.abs(height) < half], height[np.abs(height) < half]
    depth = samples @ forward
    bins = np.floor(height / step).astype(np.int64)
    order = np.lexsort((-depth, bins))
    first = order[np.r_[True, bins[order][1:] != bins[order][:-1]]] if len(order) else order
    return samples[first], height[first], depth[first]
