"""How the add-on binds a whole head to its FP control mesh: the one configuration that set-up, the
accuracy benchmark and the performance benchmark share.

A head is covered by the control mesh only in part, so two choices sit on top of the paper
(planar_bones notes, "Coverage" and "Partial coverage"):
- the vertices that must lie in an affection volume are those of the face: within a quarter of the eye
  separation ES0 (about 15 mm on an adult) of the control mesh, over its inside;
- a vertex whose eq. 9 weights add up to less than FADE_BELOW fades toward its rest shape, so motion
  ends smoothly where the volumes end. At 0.2 rather than 0.05 the fade spans about the outer
  half of the volumes' reach instead of their outer third, and the skin where the face ends (temples,
  under the chin, the mouth corners' inside) stretches over a wider band and folds far less; measured on
  the sample head's expression units and .fap streams (docs/accuracy.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .planar_bones import Binding, bind, cover_over_control_mesh

FADE_BELOW = 0.2
FACE_DEPTH_PER_ES0 = 0.25


def face_depth(es0: float, control_rest: np.ndarray) -> float:
    """How far from the control mesh the face reaches: FACE_DEPTH_PER_ES0 x ES0, or a tenth of the control
    mesh's width when ES0 is unknown (0)."""
    return FACE_DEPTH_PER_ES0 * es0 if es0 > 0 else 0.1 * float(np.ptp(control_rest, axis=0).max())


def face_cover(rest: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray, es0: float) -> np.ndarray:
    return cover_over_control_mesh(rest, control_rest, triangles, face_depth(es0, control_rest))


def bind_face(
    rest: np.ndarray,
    control_rest: np.ndarray,
    triangles: np.ndarray,
    *,
    es0: float,
    radius_fraction: float = 1.0,
    falloff_exponent: float = 2.0,
    vertex_masks: Mapping[str, np.ndarray] | None = None,
    triangle_masks: Sequence[str | None] | None = None,
    local_float32: bool = False,
) -> Binding:
    return bind(
        rest,
        control_rest,
        triangles,
        radius_fraction=radius_fraction,
        falloff_exponent=falloff_exponent,
        vertex_masks=vertex_masks,
        triangle_masks=triangle_masks,
        cover=face_cover(rest, control_rest, triangles, es0),
        fade_below=FADE_BELOW,
        local_float32=local_float32,
    )
