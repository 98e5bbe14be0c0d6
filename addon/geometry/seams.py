"""Pieces of a mesh sewn together by coincident vertices (no bpy): a downloaded character's face sewn to its scalp,
a mouth's lining sewn to its lips, UV seams split. Cut into pieces that way, a mesh is still one surface."""

from __future__ import annotations

import numpy as np


def welded(rest: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) each vertex's stand-in, the first vertex at its rest position, and the (E, 2) `edges` between stand-ins
    (each once): the skin as one surface where the mesh is cut into pieces whose copies of a vertex coincide (a
    downloaded character's face sewn to its scalp by coincident vertices, UV seams split). What is measured along the
    skin is then measured across such a seam as across any edge, and a vertex's copies take its stand-in's value
    (`values[same]`): measured on each piece alone, the Rocketbox male's copies at the seam by its ear (FP 10.5) were
    smoothed to 0.35 and 0.50 of the motion, moved apart, and their faces crossed (every frame of joy.fap). A
    mesh with no coincident vertices keeps its edges as they are."""
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    _, first, inverse = np.unique(np.asarray(rest), axis=0, return_index=True, return_inverse=True)
    same = first[inverse.ravel()].astype(np.intp)
    if len(first) == len(same):
        return same, edges
    joined = np.sort(same[edges], axis=1)
    return same, np.unique(joined[joined[:, 0] != joined[:, 1]], axis=0)
