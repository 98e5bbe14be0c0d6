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

Still skin around the eyes and brows (``triangle_parts``, docs/eyes_brows.md): raising radii to cover every
face vertex is what spreads a brow's or a lid's motion over the forehead, temple and cheek, which sculpted
expressions leave still (eq. 8 normalises a far vertex's one faint weight to the triangle's full motion). So
only the skin over the mouth-and-jaw triangles must be covered, by raising those triangles' radii alone; the
upper face's triangles keep a fraction of their own §3 radius (LOCAL_RADIUS_FRACTIONS, by part of the face)
and skin beyond their reach fades to rest (``fade_below``) instead of following. The eyes' triangles reach least:
the lids' own motion is their turn over the eyeballs (`eyelids`), and what the eye corners' FPs move in a sculpt
is the lid margin, not the skin around it; the brows' triangles reach further, over the band above the brow.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..mpeg4.control_mesh import BROWS, EYES, MOUTH_AND_JAW, OTHER_UPPER
from .planar_bones import Binding, bind, cover_over_control_mesh

FADE_BELOW = 0.2
FACE_DEPTH_PER_ES0 = 0.25
# of the §3 radius, by `control_mesh.triangle_parts` (the mouth and jaw's triangles still cover their skin);
# chosen on a grid over the development units with leave-one-unit-and-twin-out checks
# (`scripts.bench.still_skin_fractions`, docs/eyes_brows.md)
LOCAL_RADIUS_FRACTIONS = {EYES: 0.05, BROWS: 0.3, OTHER_UPPER: 0.5, MOUTH_AND_JAW: 1.5}


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
    triangle_parts: Sequence[int] | None = None,
    local_float32: bool = False,
) -> Binding:
    """`bind` as the add-on binds a face; ``triangle_parts`` (T,) `control_mesh.triangle_parts`: the upper face's
    triangles reach only locally (None: the paper's cover everywhere)."""
    cover = face_cover(rest, control_rest, triangles, es0)
    fraction, raisable = radius_fraction, None
    if triangle_parts is not None:
        parts = np.asarray(triangle_parts)
        scale = np.ones(len(parts))
        for part, local_fraction in LOCAL_RADIUS_FRACTIONS.items():
            scale[parts == part] = local_fraction
        raisable = parts == MOUTH_AND_JAW
        lower = triangles[raisable]
        cover &= len(lower) > 0 and cover_over_control_mesh(rest, control_rest, lower, face_depth(es0, control_rest))
        fraction = scale * radius_fraction
    return bind(
        rest,
        control_rest,
        triangles,
        radius_fraction=fraction,
        falloff_exponent=falloff_exponent,
        vertex_masks=vertex_masks,
        triangle_masks=triangle_masks,
        cover=cover,
        fade_below=FADE_BELOW,
        raisable=raisable,
        local_float32=local_float32,
    )
