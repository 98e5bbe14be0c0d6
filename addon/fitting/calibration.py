"""Fit the generic face onto a calibration model: a scan or another character with its own FPs (§3.3).

Escher et al.: unroll both meshes on cylinders; map the generic face's unrolled vertices onto the
calibration mesh's unrolled surface with the FPs the two share ("exactly the same" procedure as the
texture fit of §3.2, the calibration mesh's unrolled FPs standing in for texture coordinates); locate
each generic vertex in the calibration mesh's projected triangles and interpolate its 3D position.

Our readings:
- The map between the two unrolled faces is the expanded triangulation of §3.2 (`expansion`) over the
  shared FPs, the copies of the calibration FPs shifted and mirrored with the calibration face's own
  period and lines, so that every generic vertex has an image.
- "Interpolation" is along the projection ray: a point of the unrolled calibration face stands for the
  horizontal ray from the cylinder's axis at that height and angle, and the generic vertex goes where
  that ray meets the calibration triangle (exactly the surface point that unrolls there; the paper's
  barycentric mix of the triangle's corners, its §3.1 formula, is off the surface wherever the cylinder
  curves the triangle). Candidate triangles come from a grid over the unrolled plane; the exact
  ray-triangle test decides.

Where it distorts, and what we do (the paper: "for specific regions with high complexity such as the
ears, some distortions may appear"):
- Ears (and nostrils, lips in profile): a ray meets the surface several times (the front of the ear,
  its back, the head behind it). We take the hit whose distance from the axis is closest to the generic
  vertex's own, scaled by the ratio of the two cylinders' radii: a vertex behind the ear lands on the
  head, a vertex on the rim on the rim.
- Rays tangent to the surface (under the chin, the crown of the head, the rim of the ear): the hit
  slides far along the surface for a small error of the unrolled map, and the ray may meet other
  surfaces squarely. Tangent hits are still kept (they are on the right surface) and the same
  distance-from-the-axis rule picks among the hits; a ray parallel to a triangle never hits it. A vertex
  with no hit but a triangle around it in the unrolled plane (where a projected edge curves away) takes
  the barycentric mix of that triangle's corners (the paper's formula).
- A generic vertex whose image lies outside the calibration mesh (a face-only scan has no neck or scalp)
  takes `fallback` (e.g. the DFFD fit to the same FPs) or, without one, refuses the fit naming how many.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .cylinder import FaceCylinder
from .errors import CalibrationError
from .expansion import Band, ExpandedTriangulation, expand_values
from .feature_point_set import check_vertices, fp_array
from .plane_triangulation import refuse_folds

CANDIDATE_SLACK = 0.05  # barycentric slack for the triangle a point without a ray hit sits in
HIT_SLACK = 1e-9  # barycentric slack of the exact ray-triangle test


@dataclass(frozen=True)
class CalibrationFit:
    vertices: np.ndarray  # (N, 3) the generic face on the calibration mesh
    on_ray: np.ndarray  # (N,) bool: where its projection ray meets the calibration surface
    interpolated: np.ndarray  # (N,) bool: barycentric mix of a calibration triangle's corners (no clean hit)
    fallback: np.ndarray  # (N,) bool: outside the calibration mesh, took the fallback position


def fit_to_calibration_mesh(
    generic_vertices: np.ndarray,
    generic_fps: Mapping[str, object],
    mesh_vertices: np.ndarray,
    mesh_triangles: np.ndarray,
    mesh_fps: Mapping[str, object],
    axes: np.ndarray = BLENDER_FACE_AXES,
    fallback: np.ndarray | None = None,
) -> CalibrationFit:
    """The (N, 3) generic face with FPs `generic_fps` laid onto the calibration mesh with FPs `mesh_fps`.

    Both in the same mesh coordinates, with face frame `axes`; `mesh_triangles` is (T, 3) vertex indices.
    `fallback` (N, 3) positions are used for generic vertices the calibration mesh does not cover.
    """
    generic = check_vertices(generic_vertices, "generic face")
    mesh = check_vertices(mesh_vertices, "calibration mesh")
    triangles = _check_triangles(mesh_triangles, len(mesh))
    if fallback is not None:
        fallback = np.asarray(fallback, dtype=np.float64)
        if fallback.shape != generic.shape or not np.all(np.isfinite(fallback)):
            raise CalibrationError(
                f"fallback positions must be finite and shaped {generic.shape}, got {fallback.shape}"
            )
    if not len(mesh_fps):
        raise CalibrationError("the calibration mesh has no feature points; place its FPs first")
    generic_ids, generic_points = fp_array(generic_fps, "generic face")
    mesh_ids, mesh_points = fp_array(mesh_fps, "calibration mesh")
    on_mesh = dict(zip(mesh_ids, mesh_points, strict=True))
    rows = [row for row, fp_id in enumerate(generic_ids) if fp_id in on_mesh]

    generic_cylinder = FaceCylinder.around(generic, axes, "generic face")
    mesh_cylinder = FaceCylinder.around(mesh, axes, "calibration mesh")
    shared_ids = [generic_ids[row] for row in rows]
    usable = [rows[k] for k in generic_cylinder.unrollable(shared_ids, generic_points[rows])]
    ids = [generic_ids[row] for row in usable]
    generic_unrolled = generic_cylinder.project(generic_points[usable].reshape(-1, 3))
    mesh_fp_unrolled = mesh_cylinder.unwrap(
        mesh_cylinder.project(np.array([on_mesh[fp_id] for fp_id in ids]).reshape(-1, 3)),
        generic_unrolled[:, 0] / generic_cylinder.radius,
    )
    generic_flat = generic_cylinder.project(generic)
    mesh_flat = mesh_cylinder.project(mesh)
    expanded = ExpandedTriangulation.build(
        generic_unrolled,
        ids,
        Band.of(generic_cylinder.period, generic_unrolled),
        "FPs shared by the generic face and the calibration mesh, unrolled",
    )
    originals = expanded.original_triangles()
    refuse_folds(
        generic_unrolled,
        mesh_fp_unrolled,
        originals,
        ids,
        "the calibration mesh's FPs fold the face",
        "the generic face (are left and right swapped, or a point placed on the wrong feature?)",
    )

    # §3.3: the generic face's unrolled vertices mapped onto the calibration mesh's unrolled surface
    corners, weights = expanded.locate(generic_flat)
    mesh_band = Band.of(mesh_cylinder.period, mesh_fp_unrolled)
    images = np.einsum("nk,nkd->nd", weights, expand_values(mesh_fp_unrolled, mesh_band)[corners])
    half = 0.5 * mesh_cylinder.period
    images[:, 0] = np.mod(images[:, 0] + half, mesh_cylinder.period) - half
    expected = generic_cylinder.axis_distance(generic) * (mesh_cylinder.radius / generic_cylinder.radius)
    placed, on_ray, interpolated = _lay_on_mesh(images, expected, mesh, mesh_flat, triangles, mesh_cylinder)

    missed = ~(on_ray | interpolated)
    if np.any(missed):
        if fallback is None:
            raise CalibrationError(
                f"{int(missed.sum())} generic vertices (first: {int(np.flatnonzero(missed)[0])}) fall outside the "
                "calibration mesh; give a fallback (the fit to its feature points) or a mesh that covers the head"
            )
        placed[missed] = fallback[missed]
    return CalibrationFit(placed, on_ray, interpolated, missed)


def _check_triangles(triangles: np.ndarray, n_vertices: int) -> np.ndarray:
    triangles = np.asarray(triangles)
    if triangles.ndim != 2 or triangles.shape[1] != 3 or not len(triangles):
        raise CalibrationError(f"calibration mesh: triangles must be a (T, 3) array with T >= 1, got {triangles.shape}")
    if triangles.dtype.kind not in "iu":
        raise CalibrationError(f"calibration mesh: triangle corners must be vertex indices, got {triangles.dtype}")
    bad = np.flatnonzero(np.any((triangles < 0) | (triangles >= n_vertices), axis=1))
    if len(bad):
        raise CalibrationError(
            f"calibration mesh: triangle {bad[0]} refers to vertex {triangles[bad[0]].tolist()}; "
            f"the mesh has {n_vertices} vertices"
        )
    return triangles.astype(np.intp)


def _lay_on_mesh(
    images: np.ndarray,
    expected: np.ndarray,
    mesh: np.ndarray,
    mesh_flat: np.ndarray,
    triangles: np.ndarray,
    cylinder: FaceCylinder,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each unrolled point's position on the mesh: (positions, on its ray, barycentric mix instead)."""
    flat = mesh_flat[triangles]
    period = cylinder.period
    seam = np.ptp(flat[:, :, 0], axis=1) > 0.5 * period  # corners on both sides of the back of the head
    flat[seam] += np.where(flat[seam, :, :1] < 0.0, period, 0.0) * np.array([1.0, 0.0])
    owner = np.concatenate([np.arange(len(triangles)), np.flatnonzero(seam)])
    flat = np.concatenate([flat, flat[seam] - np.array([period, 0.0])])
    point, candidate = _TriangleGrid(flat).candidates(images)
    a, b, c = flat[candidate, 0], flat[candidate, 1], flat[candidate, 2]
    area = _cross2(b - a, c - a)
    with np.errstate(divide="ignore", invalid="ignore"):
        wb = _cross2(images[point] - a, c - a) / area
        wc = _cross2(b - a, images[point] - a) / area
        flat_weights = np.column_stack([1.0 - wb - wc, wb, wc])
    candidate = owner[candidate]

    origins, directions = cylinder.rays(images)
    corners = mesh[triangles[candidate]]
    distance, hit = _ray_hits(origins[point], directions[point], corners)
    hit &= distance >= 0.0
    positions = np.zeros((len(images), 3))
    on_ray = np.zeros(len(images), dtype=bool)
    interpolated = np.zeros(len(images), dtype=bool)

    # several hits (ears): the one nearest the distance from the axis the generic vertex had
    chosen = np.flatnonzero(hit)[_first_per_point(point[hit], np.abs(distance[hit] - expected[point[hit]]))]
    at = point[chosen]
    positions[at] = origins[at] + distance[chosen, None] * directions[at]
    on_ray[at] = True

    # no hit (a projected edge curves away, a small hole): the triangle it sits deepest in, within the
    # slack, and the barycentric mix of its corners (§3.1 formula)
    near = ~on_ray[point] & np.isfinite(area) & (area != 0.0) & np.all(flat_weights >= -CANDIDATE_SLACK, axis=1)
    depth = flat_weights[near].min(axis=1)
    chosen = np.flatnonzero(near)[_first_per_point(point[near], -depth)]
    at = point[chosen]
    mix = np.clip(flat_weights[chosen], 0.0, None)
    mix /= mix.sum(axis=1, keepdims=True)
    positions[at] = np.einsum("nk,nkd->nd", mix, corners[chosen])
    interpolated[at] = True
    return positions, on_ray, interpolated


def _cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _first_per_point(point: np.ndarray, score: np.ndarray) -> np.ndarray:
    """Index (into `point`) of the lowest `score` for each distinct point."""
    order = np.lexsort((score, point))
    _, first = np.unique(point[order], return_index=True)
    return order[first]


def _ray_hits(origins: np.ndarray, directions: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance along each ray, whether it meets its triangle) for rays and (M, 3, 3) triangles."""
    edge1, edge2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal = np.cross(edge1, edge2)
    normal_length = np.linalg.norm(normal, axis=1)
    facing = np.einsum("mk,mk->m", normal, directions)
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.einsum("mk,mk->m", normal, corners[:, 0] - origins) / facing
        point = origins + distance[:, None] * directions - corners[:, 0]
        wb = np.einsum("mk,mk->m", np.cross(point, edge2), normal) / normal_length**2
        wc = np.einsum("mk,mk->m", np.cross(edge1, point), normal) / normal_length**2
    within = (wb >= -HIT_SLACK) & (wc >= -HIT_SLACK) & (wb + wc <= 1.0 + HIT_SLACK)
    return distance, within & np.isfinite(distance)


class _TriangleGrid:
    """Triangles of the unrolled plane binned by the grid cells their bounding boxes cover."""

    def __init__(self, flat: np.ndarray):
        low, high = flat.min(axis=1), flat.max(axis=1)
        self.origin = low.min(axis=0)
        size = np.median(np.max(high - low, axis=1))
        self.cell = float(size) if size > 0 else float(np.max(np.ptp(flat.reshape(-1, 2), axis=0))) or 1.0
        first = np.floor((low - self.origin) / self.cell).astype(np.int64)
        last = np.floor((high - self.origin) / self.cell).astype(np.int64)
        self.rows = int(last[:, 1].max()) + 1
        span = last - first + 1
        count = span[:, 0] * span[:, 1]
        triangle = np.repeat(np.arange(len(flat)), count)
        local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        column = first[triangle, 0] + local % span[triangle, 0]
        row = first[triangle, 1] + local // span[triangle, 0]
        keys = column * self.rows + row
        order = np.argsort(keys, kind="stable")
        self.keys, self.triangles = keys[order], triangle[order]
        self.columns = int(last[:, 0].max()) + 1

    def candidates(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point index, triangle index) pairs whose triangle's box covers the point's cell."""
        cell = np.floor((points - self.origin) / self.cell).astype(np.int64)
        size = np.array([self.columns, self.rows])
        # a point a rounding error outside the outermost triangles still meets them (slack decides)
        valid = np.all((cell >= -1) & (cell <= size), axis=1)
        cell = np.clip(cell, 0, size - 1)
        keys = np.where(valid, cell[:, 0] * self.rows + cell[:, 1], -1)
        start = np.searchsorted(self.keys, keys, side="left")
        count = np.where(valid, np.searchsorted(self.keys, keys, side="right") - start, 0)
        point = np.repeat(np.arange(len(points)), count)
        local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        return point, self.triangles[np.repeat(start, count) + local]
