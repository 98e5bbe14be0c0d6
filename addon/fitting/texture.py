"""Texture coordinates for every vertex from the FPs' texture coordinates (Escher et al. §3.2).

The face mesh is unrolled on a cylinder (not projected on a plane, so the whole head gets UVs), the
FPs that carry texture coordinates are triangulated in the expanded Delaunay triangulation (`expansion`)
so that every vertex lies in a triangle, and each vertex takes the barycentric mix of its triangle's
UVs. Copies of an FP carry its UVs unchanged; the back and top of the head therefore get a smeared
copy of the picture, which the paper accepts ("visually acceptable").

A vertex's UVs are a convex combination of UVs inside the image, so they are inside [0, 1] too (the
last rounding bit is clipped). Refused before any work: UVs outside the image, two FPs with the same
UVs, and UVs whose triangles flip relative to the unrolled face (the texture would fold; a mirrored
picture flips them all). Only triangles between uncopied FPs are checked: the triangles joining an FP
to a copy across the back of the head are mirrored by construction. FPs that cannot be unrolled (teeth,
tongue, 7.1, points on the cylinder's axis: `cylinder.OUTER_SURFACES`, `AXIS_FRACTION`) are left out
and reported.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .cylinder import FaceCylinder
from .errors import FeaturePointError, TextureCoordinateError
from .expansion import Band, ExpandedTriangulation
from .feature_point_set import check_vertices, fp_array
from .plane_triangulation import refuse_folds


@dataclass(frozen=True)
class TextureFit:
    uvs: np.ndarray  # (N, 2) in [0, 1]
    fp_ids: tuple[str, ...]  # FPs whose UVs were used
    unused: tuple[str, ...]  # FPs with UVs that cannot be unrolled


def texture_coordinates(
    vertices: np.ndarray,
    fp_positions: Mapping[str, object],
    fp_uvs: Mapping[str, object],
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> TextureFit:
    """UVs of every (N, 3) vertex from `fp_uvs` (FP id -> (u, v) in [0, 1]) at the FPs `fp_positions`."""
    vertices = check_vertices(vertices, "face mesh")
    ids, points = fp_array(fp_positions, "face")
    uv_ids, uvs = fp_array(fp_uvs, "texture coordinates", dimension=2)
    position = dict(zip(ids, points, strict=True))
    foreign = [fp_id for fp_id in uv_ids if fp_id not in position]
    if foreign:
        raise FeaturePointError(f"texture coordinates given for FPs the face does not have: {', '.join(foreign)}")
    _check_uvs(uv_ids, uvs)

    cylinder = FaceCylinder.around(vertices, axes, "face mesh")
    usable = cylinder.unrollable(uv_ids, np.array([position[fp_id] for fp_id in uv_ids]))
    used = tuple(uv_ids[row] for row in usable)
    unrolled = cylinder.project(np.array([position[fp_id] for fp_id in used]).reshape(-1, 3))
    unrolled_vertices = cylinder.project(vertices)
    expanded = ExpandedTriangulation.build(
        unrolled, used, Band.of(cylinder.period, unrolled), "FPs with texture coordinates, unrolled"
    )
    used_uvs = uvs[usable]
    triangles = expanded.original_triangles()
    refuse_folds(
        unrolled,
        used_uvs,
        triangles,
        used,
        "the texture coordinates fold the texture",
        "the face (is the picture flipped, or a point's UVs on the wrong feature?)",
    )
    corners, weights = expanded.locate(unrolled_vertices)
    result = np.einsum("nk,nkd->nd", weights, used_uvs[corners % len(used)])
    unused = tuple(fp_id for fp_id in uv_ids if fp_id not in used)
    return TextureFit(np.clip(result, 0.0, 1.0), used, unused)


def _check_uvs(ids: tuple[str, ...], uvs: np.ndarray) -> None:
    outside = [
        f"{fp_id} ({u:.6g}, {v:.6g})"
        for fp_id, (u, v) in zip(ids, uvs, strict=True)
        if not (0.0 <= u <= 1.0 and 0.0 <= v <= 1.0)
    ]
    if outside:
        raise TextureCoordinateError(f"texture coordinates outside the image [0, 1]: {', '.join(outside)}")
    same = [
        f"{ids[a]} and {ids[b]}"
        for a in range(len(ids))
        for b in range(a + 1, len(ids))
        if np.array_equal(uvs[a], uvs[b])
    ]
    if same:
        raise TextureCoordinateError(f"FPs with the same texture coordinates: {'; '.join(same)}")
