"""A shape prior for the registration: the template's decimated skin moved within the span of MakeHuman's
own head and face targets to the user's skin, before the non-rigid step.

Optimal-step NICP pulls each template vertex to its closest point; on smooth skin (skull, jaw, cheeks) the
closest point slides along the surface and the template's points with it. A linear shape model moves all
vertices together the way heads differ (a longer jaw, a rounder skull), so a point on the jaw follows the
jaw's shape, not its nearest skin. The basis (`template.shape_basis`, k principal shapes, each scaled to one
standard deviation) is written by `scripts/sample/build_placement_template.py`.

Fitted as a regularised Gauss-Newton on point-to-plane distances (Chen and Medioni 1992):

    min_{c, t}  sum_i w_i (n_i . (q_i - (v_i + sum_k c_k b_ki + t)))^2 / sigma^2  +  |c|^2

with q_i, n_i the closest skin point of the shaped vertex and its normal, w_i the correspondences kept as
in the registration (normals agreeing, not far, not on the template's border), sigma the spread of a
correspondence about the true surface and t a translation, re-found for SHAPE_STEPS steps.
"""

from __future__ import annotations

import numpy as np

from ..geometry.normals import vertex_normals
from .surface import Surface

SHAPE_STEPS = 8
SPREAD = 0.002  # template metres: sigma, how far a correspondence may lie from where it belongs
NORMAL_AGREEMENT = 0.5  # cos 60 deg
FAR = 0.02  # template metres: correspondences further than this are not used


def fit_shape(
    vertices: np.ndarray, triangles: np.ndarray, basis: np.ndarray, surface: Surface, border: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """`vertices` (m, 3) moved within the span of `basis` (k, m, 3) and translated onto `surface`, and the
    k + 3 numbers that do it (the shapes' coefficients, then the translation)."""
    k = len(basis)
    coefficients = np.zeros(k + 3)
    prior = np.r_[np.ones(k), np.zeros(3)] * SPREAD**2
    shaped = vertices
    for _step in range(SHAPE_STEPS):
        target, target_normals = surface.closest(shaped)
        agree = (vertex_normals(shaped, triangles) * target_normals).sum(1)
        keep = (agree > NORMAL_AGREEMENT) & (np.linalg.norm(target - shaped, axis=1) < FAR) & ~border
        normal = target_normals[keep]
        residual = ((target[keep] - shaped[keep]) * normal).sum(1)
        jacobian = np.hstack([(basis[:, keep] * normal).sum(axis=2).T, normal])
        lhs = jacobian.T @ jacobian + np.diag(prior)
        coefficients += np.linalg.solve(lhs, jacobian.T @ residual - prior * coefficients)
        shaped = vertices + np.tensordot(coefficients[:k], basis, axes=1) + coefficients[k:]
    return shaped, coefficients
