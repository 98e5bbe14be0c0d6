"""Input checks shared by the deformers: one error type, messages that say what is wrong and where."""

import numpy as np

from ..errors import Mpeg4Error

COINCIDENCE = 1e-9  # relative to the control mesh extent: closer control points are the same point


class DeformError(Mpeg4Error):
    """Bad input to a deformer: NaN coordinates, bad triangle indices, wrong shapes, bad masks."""


def check_points(array: np.ndarray, name: str) -> np.ndarray:
    result = np.asarray(array, dtype=np.float64)
    if result.ndim != 2 or result.shape[1] != 3:
        raise DeformError(f"{name} must have shape (n, 3), got {result.shape}")
    bad = ~np.isfinite(result).all(axis=1)
    if bad.any():
        raise DeformError(f"{name} has non-finite coordinates at rows {np.flatnonzero(bad)[:10].tolist()}")
    return result


def check_triangles(triangles: np.ndarray, n_control: int) -> np.ndarray:
    tris = np.asarray(triangles)
    if tris.ndim != 2 or tris.shape[1] != 3 or len(tris) == 0:
        raise DeformError(f"triangles must have shape (T, 3) with T > 0, got {tris.shape}")
    if not np.issubdtype(tris.dtype, np.integer):
        raise DeformError(f"triangles must hold integer indices, got {tris.dtype}")
    bad = ((tris < 0) | (tris >= n_control)).any(axis=1)
    if bad.any():
        raise DeformError(
            f"triangles {np.flatnonzero(bad)[:10].tolist()} index outside 0..{n_control - 1} control points"
        )
    return tris.astype(np.intp)


def check_positive(value: float, name: str) -> float:
    number = float(value)
    if not (np.isfinite(number) and number > 0.0):
        raise DeformError(f"{name} must be a positive finite number, got {value!r}")
    return number
