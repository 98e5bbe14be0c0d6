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


def about_point(rotation: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """(4, 4) the (3, 3) rotation about `pivot`."""
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = pivot - rotation @ pivot
    return m


def apply(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    return np.asarray(points) @ m[:3, :3].T + m[:3, 3]


def aligning_axis_angle(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit axis and angle of the smallest rotation turning the direction of `a` into that of `b`."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    sin = np.linalg.norm(axis)
    if sin < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0  # parallel (an antiparallel pupil is not a pose an eye takes)
    return axis / sin, float(np.arctan2(sin, a @ b))
