"""A surface descriptor that tells ridges from creases at any mesh resolution, for correspondences.

The local height of a surface point p with unit normal n is n . (p - m), m the mean of the surface within a
ball of radius r around p (area samples, so the mesh's resolution does not enter): positive on ridges and
tips (nose, lips, brows, chin), negative in creases and pits (the mouth line, eye corners, nostrils), zero
on smooth skull. Closest points found in (x, y, z, weight * height) pair a lip with a lip and a crease with a
crease where position alone lets the template slide along the surface.
"""

from __future__ import annotations

import numpy as np

from .scipy_modules import cKDTree


def local_height(points: np.ndarray, normals: np.ndarray, samples: np.ndarray, radius: float) -> np.ndarray:
    """(K,) local height of `points` (K, 3) with `normals` over the surface `samples` (S, 3)."""
    tree = cKDTree(samples)
    balls = tree.query_ball_point(points, radius)
    counts = np.array([len(b) for b in balls])
    flat = np.concatenate([np.asarray(b, dtype=np.int64) for b in balls]) if len(balls) else np.zeros(0, np.int64)
    owner = np.repeat(np.arange(len(points)), counts)
    sums = np.stack([np.bincount(owner, weights=samples[flat, j], minlength=len(points)) for j in range(3)], axis=1)
    means = sums / np.maximum(counts, 1)[:, None]
    height = ((points - means) * normals).sum(1)
    return np.where(counts > 0, height, 0.0)


class FeatureMatcher:
    """Closest surface samples in (position, weight x local height): `match(points, heights)` -> (samples,
    their normals)."""

    def __init__(self, samples: np.ndarray, normals: np.ndarray, heights: np.ndarray, weight: float):
        self.samples, self.normals, self.weight = samples, normals, weight
        self.tree = cKDTree(np.hstack([samples, weight * heights[:, None]]))

    def match(self, points: np.ndarray, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _d, index = self.tree.query(np.hstack([points, self.weight * heights[:, None]]))
        return self.samples[index], self.normals[index]
