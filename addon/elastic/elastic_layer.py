"""The elastic layer (paper 004, eq. 3-4): moved bones pull or push their neighbours.

For a bone at rest position p̄ whose first (rule) transformation took it to p̂, and each neighbour i
that went from p̄_i to p̂_i:

    u_i = (p̂_i − p̄_i) + δ_i (p̄ − p̄_i)                        (3)
    p   = p̂ + Σ_i w_i u_i / ‖u_i‖ · ‖p̂_i − p̄_i‖                 (4)

δ_i is "the sign of the scalar product of the two vectors in the summation", (p̂_i − p̄_i)·(p̄ − p̄_i):
a neighbour moving away from the bone (negative product) pulls it after itself, one moving toward it
(positive) pushes it ahead. Reading chosen where the paper is silent: a neighbour moving square to the
segment has δ_i = 0 (the sign of 0), so u_i is its own motion and the bone follows it sideways; a
neighbour that does not move has no effect (‖p̂_i − p̄_i‖ = 0). The layer is one pass: it reads the
neighbours' first-pass positions p̂_i, never positions the layer itself produced.
"""

from __future__ import annotations

import numpy as np


def elastic_terms(rest: np.ndarray, moved: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """(K, 3) the summands of eq. 4 without their weight, u_i / ‖u_i‖ · ‖p̂_i − p̄_i‖, one per pair.

    `rest` (B, 3) holds p̄ and `moved` (B, 3) p̂ for every bone; `pairs` (K, 2) rows are (bone, neighbour i).
    """
    rest = np.asarray(rest, dtype=np.float64)
    moved = np.asarray(moved, dtype=np.float64)
    pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    bone, neighbour = pairs[:, 0], pairs[:, 1]
    motion = moved[neighbour] - rest[neighbour]  # p̂_i − p̄_i
    segment = rest[bone] - rest[neighbour]  # p̄ − p̄_i
    delta = np.sign(np.einsum("kj,kj->k", motion, segment))
    u = motion + delta[:, None] * segment  # eq. 3
    length = np.linalg.norm(u, axis=1)
    magnitude = np.linalg.norm(motion, axis=1)
    scale = np.divide(magnitude, length, out=np.zeros_like(length), where=length > 0.0)
    return u * scale[:, None]


def elastic_positions(rest: np.ndarray, moved: np.ndarray, pairs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(B, 3) final bone positions p (eq. 4); `weights` (K,) are the pairs' w_i."""
    pairs = np.asarray(pairs, dtype=np.intp).reshape(-1, 2)
    terms = np.asarray(weights, dtype=np.float64)[:, None] * elastic_terms(rest, moved, pairs)
    out = np.array(moved, dtype=np.float64)
    np.add.at(out, pairs[:, 0], terms)
    return out
