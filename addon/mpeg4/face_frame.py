"""The face frame (x to the face's own left, y up, z forward) of a mesh, read from its feature points.

A user's mesh need not be a Blender character (Z up, facing -Y): a Y-up import keeps Y-up mesh data under a
90° object rotation, and a face may look along +Y. The frame is read from the FPs themselves: x from the
mirror pairs (each left FP minus its right partner; one swapped pair is outvoted by the others), y from the
mouth and jaw (groups 2 and 8) toward the eyes and brows (groups 3 and 4), made perpendicular to x, and
z = x × y. A frame within SNAP_DEGREES of an axis-aligned one is taken as that one, so that a mesh modelled
along its axes (the usual case, the sample among them) keeps exactly its axes and the figures measured on it.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .feature_points import FEATURE_POINTS

SNAP_DEGREES = 20.0
UPPER_GROUPS, LOWER_GROUPS = (3, 4), (2, 8)


def _aligned_frames() -> np.ndarray:
    """The 24 rotations that map the coordinate axes onto signed coordinate axes."""
    frames = []
    for order in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            m[range(3), order] = signs
            if np.linalg.det(m) > 0:
                frames.append(m)
    return np.array(frames)


ALIGNED = _aligned_frames()


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > 0 and np.isfinite(n) else None


def frame_from_fps(positions: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """(3, 3) the face frame's axes as rows, in mesh coordinates, from FP id -> (3,) positions; None when the
    FPs give no left-right pair or nothing above and below."""
    found = {k: np.asarray(p, dtype=np.float64) for k, p in positions.items() if np.all(np.isfinite(p))}
    pairs = [(fp.id, fp.mirror) for fp in FEATURE_POINTS if fp.side == "L" and {fp.id, fp.mirror} <= found.keys()]
    lefts = [v for v in (_unit(found[a] - found[b]) for a, b in pairs) if v is not None]
    x = _unit(np.sum(lefts, axis=0)) if lefts else None
    upper = [found[fp.id] for fp in FEATURE_POINTS if fp.group in UPPER_GROUPS and fp.id in found]
    lower = [found[fp.id] for fp in FEATURE_POINTS if fp.group in LOWER_GROUPS and fp.id in found]
    if x is None or not upper or not lower:
        return None
    up = np.mean(upper, axis=0) - np.mean(lower, axis=0)
    y = _unit(up - (up @ x) * x)
    if y is None:
        return None
    frame = np.array([x, y, np.cross(x, y)])
    nearest = ALIGNED[np.argmax(np.einsum("kij,ij->k", ALIGNED, frame))]
    cos = np.clip((np.trace(nearest.T @ frame) - 1.0) / 2.0, -1.0, 1.0)
    return nearest if np.degrees(np.arccos(cos)) <= SNAP_DEGREES else frame


def face_frame(positions: Mapping[str, np.ndarray]) -> np.ndarray:
    """`frame_from_fps`, or a Blender character's frame when the FPs cannot tell."""
    frame = frame_from_fps(positions)
    return BLENDER_FACE_AXES.copy() if frame is None else frame
