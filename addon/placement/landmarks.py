"""Points the surface itself says where they are, refined after the registration carried them near: the
nose tip is the skin's most forward point near the carried guess on the mid-plane (pronasale), whatever
the template's nose looked like."""

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


def refine(placed: np.ndarray, surface: Surface, forward: np.ndarray, plane: MidPlane) -> np.ndarray:
    """`placed` (84, 3) with the points local geometry fixes moved there."""
    placed = placed.copy()
    row = fp_index("9.3")
    placed[row] = nose_tip(surface, placed[row], forward, plane)
    return placed
