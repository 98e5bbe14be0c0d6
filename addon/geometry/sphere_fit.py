"""The least-squares sphere through a set of points (an eyeball mesh -> its turning centre)."""

from __future__ import annotations

import numpy as np


class SphereFitError(ValueError):
    """Too few points, or points that fix no sphere (all on one plane or line)."""


def fit_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """(N, 3) points -> (centre (3,), radius) of the sphere that best fits them.

    Algebraic least squares: |p|^2 = 2 c.p + (r^2 - |c|^2) is linear in c and d = r^2 - |c|^2, so one
    linear solve gives the sphere; for points on a sphere it is exact. Coordinates are taken relative to
    the points' mean so a mesh far from the origin keeps its precision.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 4 or not np.all(np.isfinite(points)):
        raise SphereFitError("a sphere fit needs at least 4 finite 3D points")
    mean = points.mean(axis=0)
    p = points - mean
    a = np.hstack([2.0 * p, np.ones((len(p), 1))])
    b = np.einsum("ij,ij->i", p, p)
    scale = float(np.sqrt(b.max()))
    if scale == 0.0:
        raise SphereFitError("the points coincide")
    solution, _res, rank, sv = np.linalg.lstsq(a, b, rcond=None)
    if rank < 4 or sv[-1] < 1e-9 * sv[0] * max(scale, 1.0):
        raise SphereFitError("the points lie on one plane or line: they fix no sphere")
    centre = solution[:3]
    radius_sq = solution[3] + centre @ centre
    if radius_sq <= 0.0:
        raise SphereFitError("the points fix no real sphere")
    return centre + mean, float(np.sqrt(radius_sq))
