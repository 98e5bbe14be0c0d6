"""A mesh's connected pieces along its edges (no bpy): scipy's where the platform has a scipy wheel, numpy alone
where it has none (windows-arm64)."""

from __future__ import annotations

import numpy as np


def connected_pieces(n_vertices: int, edges: np.ndarray) -> np.ndarray:
    """(N,) a label per connected piece: scipy's, or where a platform has no scipy wheel, each vertex's least
    reachable index by min-label hooking and pointer jumping (the same pieces, other numbers)."""
    try:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components
    except ImportError:
        labels = np.arange(n_vertices)
        while True:
            hooked = labels.copy()
            np.minimum.at(hooked, labels[edges[:, 0]], labels[edges[:, 1]])
            np.minimum.at(hooked, labels[edges[:, 1]], labels[edges[:, 0]])
            while not np.array_equal(hooked, hooked[hooked]):
                hooked = hooked[hooked]
            if np.array_equal(hooked, labels):
                return labels
            labels = hooked
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n_vertices, n_vertices))
    return connected_components(graph, directed=False)[1]
