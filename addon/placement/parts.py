"""Eyeballs among a head's loose parts, and the pupil on each (template frame, metres).

An eyeball is a loose piece that a sphere fits (the `sphere_fit` residual small against its radius) with a
radius of a human eye, whose sphere holds the pupil estimate carried over from the template. The pupil
is where the gaze ray from the sphere's centre leaves the piece: the centre of a cornea or of a flat iris
cap alike, whatever the eyeball's topology. The gaze is the template's own (the ray through its pupil
estimate, moved by the shape prior and carried by the registration, `pipeline._transfer`), not the face's
forward: an eye need not look straight ahead (the development heads' eyes look 2.5-6 degrees down in their
own frame, and straight ahead put their pupils 1.7 mm high).
"""

from __future__ import annotations

import numpy as np

from ..geometry.sphere_fit import SphereFitError, fit_sphere

EYE_RADIUS = (0.008, 0.018)  # template metres: a human eyeball's radius is about 12 mm
SPHERE_RESIDUAL = 0.15  # of the radius: the piece's mean distance from its sphere
PUPIL_REACH = 1.5  # of the radius: the estimate lies within this of the sphere's centre


def _sphere(vertices: np.ndarray):
    try:
        centre, radius = fit_sphere(vertices)
    except SphereFitError:
        return None
    residual = np.abs(np.linalg.norm(vertices - centre, axis=1) - radius).mean()
    if not EYE_RADIUS[0] <= radius <= EYE_RADIUS[1] or residual > SPHERE_RESIDUAL * radius:
        return None
    return centre, radius


def find_eyeballs(parts: list, pupils: np.ndarray) -> list:
    """For each estimated pupil (2, 3), the part (vertices, triangles) that is its eyeball, or None."""
    found = []
    for pupil in pupils:
        best = None
        for part in parts:
            sphere = _sphere(part[0])
            if sphere is None:
                continue
            centre, radius = sphere
            distance = float(np.linalg.norm(pupil - centre))
            if distance <= PUPIL_REACH * radius and (best is None or distance < best[0]):
                best = (distance, part)
        found.append(None if best is None else best[1])
    return found


def pupil_on_eyeball(part, estimate: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """Where the ray from the eyeball's centre through the pupil's `estimate` leaves the piece
    (Moller-Trumbore); along `forward` when the estimate is not in front of the centre."""
    vertices, triangles = part
    centre, _radius = fit_sphere(vertices)
    gaze = estimate - centre
    ray = gaze / np.linalg.norm(gaze) if gaze @ forward > 0.0 else forward
    a, b, c = (vertices[triangles[:, j]] for j in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(ray, e2)
    det = (e1 * p).sum(1)
    ok = np.abs(det) > 1e-18
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = centre - a
    u = (s * p).sum(1) * inv
    q = np.cross(s, e1)
    v = (q @ ray) * inv
    t = (q * e2).sum(1) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    if not hit.any():
        return vertices[np.argmax(vertices @ ray)]
    return centre + ray * t[hit].max()
