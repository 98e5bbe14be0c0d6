"""Rigid 4x4 transforms (column convention, x' = M @ [x, 1]) used to pose the bones."""

from __future__ import annotations

import numpy as np


def translation(offset: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = offset
    return m


def rotation_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) right-handed rotation by `angle` about the unit `axis` (Rodrigues)."""
    x, y, z = np.asarray(axis, dtype=np.float64)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def rotation_matrices(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(K, 3, 3) `rotation_matrix` for K unit axes (K, 3) and angles (K,)."""
    axes = np.asarray(axes, dtype=np.float64)
    k = np.zeros((len(axes), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axes[:, 2], axes[:, 1], -axes[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = axes[:, 2], -axes[:, 1], axes[:, 0]
    angles = np.asarray(angles, dtype=np.float64)[:, None, None]
    return np.eye(3) + np.sin(angles) * k + (1.0 - np.cos(angles)) * (k @ k)


def about_point(rotation: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """(4, 4) the (3, 3) rotation about `pivot`."""
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = pivot - rotation @ pivot
    return m
