"""Values smoothed over a mesh's surface along its edges (no bpy, numpy only).

`smooth_over_edges` takes steps that move each vertex's value halfway to the mean of its neighbours' values
(the edges given: a cut opening stays cut); each step adds edge_length² / 2 to the spread's variance, so
`smoothing_steps` gives the number of steps that spread a value over a width on the face whatever the mesh's
resolution (Elastic Bones' skin weights, Still Skin Around Eyes' fade to rest).
"""

from __future__ import annotations

import numpy as np

MAX_STEPS = 400


def smooth_over_edges(values: np.ndarray, edges: np.ndarray, steps: int) -> np.ndarray:
    """(N,) or (N, K) `values` after `steps` steps of v <- (v + mean of the neighbours' v) / 2 over (E, 2)
    `edges`; a vertex with no edge keeps its value."""
    values = np.asarray(values, dtype=np.float64)
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    if steps <= 0 or len(edges) == 0:
        return values.copy()
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    order = np.argsort(rows, kind="stable")
    rows, cols = rows[order], cols[order]
    joined, starts, degree = np.unique(rows, return_index=True, return_counts=True)
    shape = (-1,) + (1,) * (values.ndim - 1)
    for _ in range(steps):
        mean = np.add.reduceat(values[cols], starts, axis=0) / degree.reshape(shape)
        values = values.copy()
        values[joined] = 0.5 * (values[joined] + mean)
    return values


def smoothing_steps(width: float, edge_length: float) -> int:
    """Steps of `smooth_over_edges` that spread a value over about `width` on edges of `edge_length` (at most
    MAX_STEPS)."""
    if width <= 0.0 or edge_length <= 0.0:
        return 0
    return min(MAX_STEPS, round(2.0 * (width / edge_length) ** 2))
