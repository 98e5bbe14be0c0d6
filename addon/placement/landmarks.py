"""Points the surface itself says where they are, refined after the registration carried them near: the
nose tip is the skin's most forward point near the carried guess on the mid-plane (pronasale), whatever
the template's nose looked like; the top of the spine (7.1) is where the ears say it is (`spine_top`)."""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .surface import Surface
from .symmetry import MidPlane

NOSE_REACH = 0.015  # template metres: the nose tip is looked for this near the carried guess
MID_REACH = 0.003  # template metres: and this near the mid-plane


def nose_tip(surface: Surface, guess: np.ndarray, forward: np.ndarray, plane: MidPlane) -> np.ndarray:
    """The skin vertex furthest along `forward` within NOSE_REACH of `guess` and MID_REACH of the mid-plane,
    moved onto the mid-plane and snapped back onto the skin (or the guess when no vertex is that near)."""
    near = surface.tree.query_ball_point(guess, NOSE_REACH)
    if not near:
        return guess
    near = np.asarray(near)
    candidates = surface.vertices[near]
    on_mid = np.abs(candidates @ plane.normal - plane.offset) <= MID_REACH
    if not on_mid.any():
        return guess
    tip = candidates[on_mid][np.argmax(candidates[on_mid] @ forward)]
    snapped, _normal = surface.closest(plane.project(tip)[None])
    return snapped[0]


def spine_top(points: np.ndarray) -> np.ndarray:
    """FP 7.1, the top of the spine, from the other points (84, 3): the midpoint of the ear lobes 10.5/10.6.

    The standard defines 7.1 as the top of the spine, the centre the head turns about (FAPs 48-50), and
    draws it inside the neck; it gives no construction. Read here: the skull turns on the atlas at the
    occipital condyles, on the mid-plane between the ears at about the height of the ear lobes (the mastoid
    tips), so 7.1 is the lobes' midpoint. The development heads' own head joint (MakeHuman's `joint-head`)
    lies 2-17 mm from it; the sample's lies 44 mm away (38 mm further back, near the back of the neck)."""
    return 0.5 * (points[fp_index("10.5")] + points[fp_index("10.6")])


def refine(placed: np.ndarray, surface: Surface, forward: np.ndarray, plane: MidPlane) -> np.ndarray:
    """`placed` (84, 3) with the points local geometry fixes moved there."""
    placed = placed.copy()
    row = fp_index("9.3")
    placed[row] = nose_tip(surface, placed[row], forward, plane)
    placed[fp_index("7.1")] = spine_top(placed)
    return placed
