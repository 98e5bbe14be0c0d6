"""Missing feature point interpolation (Escher et al. §3.1.1).

The Sibson coordinates are computed once per generic face for all its FPs, so an FDP that gives only
some FPs is completed first: unroll the generic face's FPs on a cylinder, triangulate the given ones
(Delaunay), and move each missing FP with the displacements of the three given FPs bounding it,
weighted by its barycentric coordinates in their triangle (the paper's formula, §3.1.1):

    Xf = Xi + Wa (Xfa - Xia) + Wb (Xfb - Xib) + Wc (Xfc - Xic)

Readings where the paper is silent:
- "all the feature points of the generic face" are unrolled, except those a cylinder around the head
  cannot see (`cylinder.OUTER_SURFACES`, `AXIS_FRACTION`): the teeth, the tongue and 7.1 inside the
  head, and FPs on the axis (the skull top). A missing FP of that kind moves with the robust affine fit
  of the given FPs' motion (`affine_fit`: a local motion of a few FPs does not carry it).
- A missing FP outside the given FPs' triangulation takes the nearest point of its boundary: the
  displacement of the nearest boundary edge, interpolated along it (two weights, both in [0, 1]), so it
  never extrapolates. The expanded triangulation of §3.2 would wrap around the back of the head, but
  the paper uses it for texture, not here.
- FPs that coincide on the generic face (the sample head's 11.4 and 11.5) are one point: a missing one
  takes its partner's displacement.
- The given FPs must not fold: every triangle (but slivers, `plane_triangulation.folded_triangles`)
  keeps its orientation from the generic face to the given FPs (each unrolled on its own cylinder,
  `FaceCylinder.around` the same FPs), or a FoldError names it (swapped left/right points, a point on
  the wrong feature).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .affine_fit import robust_affine_fit
from .cylinder import FaceCylinder, on_outer_surface
from .errors import CoincidentFeaturePointsError, FeaturePointError
from .feature_point_set import COINCIDENT_FRACTION, coincident_groups, extent, fp_array, require_spatial
from .plane_triangulation import locate, refuse_folds, triangulate


@dataclass(frozen=True)
class CompletedFeaturePoints:
    positions: dict[str, np.ndarray]  # every FP of the generic face: the given ones as given
    interpolated: tuple[str, ...]  # placed by the barycentric displacement transfer
    outside: tuple[str, ...]  # of those, outside the given FPs' triangulation (nearest boundary point)
    affine: tuple[str, ...]  # off the unrolled surface: carried by the affine fit of the given FPs


def complete_feature_points(
    generic: Mapping[str, object], given: Mapping[str, object], axes: np.ndarray = BLENDER_FACE_AXES
) -> CompletedFeaturePoints:
    """Every FP of `generic` (FP id -> (3,) rest position): `given` where given, interpolated elsewhere.

    Positions are in the mesh's coordinates; `axes` is the face frame (rows: left, up, forward).
    """
    generic_ids, generic_points = fp_array(generic, "generic face")
    given_ids, given_points = fp_array(given, "given FPs")
    foreign = [fp_id for fp_id in given_ids if fp_id not in generic_ids]
    if foreign:
        raise FeaturePointError(f"given FPs {', '.join(foreign)} are not on the generic face")
    rest = dict(zip(generic_ids, generic_points, strict=True))
    target = dict(zip(given_ids, given_points, strict=True))
    partner = _given_partners(generic_ids, generic_points, target)

    positions = {fp_id: target[fp_id] for fp_id in given_ids}
    missing = [fp_id for fp_id in generic_ids if fp_id not in target]
    for fp_id in [fp_id for fp_id in missing if fp_id in partner]:
        positions[fp_id] = target[partner[fp_id]]  # coincident on the generic face: same displacement
    missing = [fp_id for fp_id in missing if fp_id not in partner]

    nodes = [fp_id for fp_id in given_ids if on_outer_surface(fp_id) and partner.get(fp_id, fp_id) == fp_id]
    if len(nodes) < 3:
        raise FeaturePointError(
            f"given FPs: {len(nodes)} on the face surface ({', '.join(nodes) or 'none'}); at least 3 are needed "
            "to triangulate (FPs of the teeth, tongue and 7.1 do not count)"
        )
    # both faces unrolled on cylinders around the same FPs, so that their triangles compare
    generic_cylinder = FaceCylinder.around(np.array([rest[f] for f in nodes]), axes, "generic face")
    target_cylinder = FaceCylinder.around(np.array([target[f] for f in nodes]), axes, "given FPs")
    nodes = [nodes[row] for row in generic_cylinder.unrollable(nodes, np.array([rest[f] for f in nodes]))]
    node_rest = np.array([rest[f] for f in nodes]).reshape(-1, 3)
    node_target = np.array([target[f] for f in nodes]).reshape(-1, 3)
    unrolled = generic_cylinder.project(node_rest)
    triangulation = triangulate(unrolled, nodes, "given FPs on the unrolled generic face")
    angles = unrolled[:, 0] / generic_cylinder.radius
    target_unrolled = target_cylinder.unwrap(target_cylinder.project(node_target), angles)
    refuse_folds(
        unrolled,
        target_unrolled,
        triangulation.simplices,
        nodes,
        "the given FPs fold the face",
        "the generic face (are left and right swapped, or a point placed on the wrong feature?)",
    )

    on_surface = [missing[row] for row in generic_cylinder.unrollable(missing, np.array([rest[f] for f in missing]))]
    interpolated, outside = [], []
    if on_surface:
        unrolled_missing = generic_cylinder.project(np.array([rest[f] for f in on_surface]))
        corners, weights, inside = locate(triangulation, unrolled_missing)
        motion = node_target - node_rest
        for row, fp_id in enumerate(on_surface):
            positions[fp_id] = rest[fp_id] + weights[row] @ motion[corners[row]]  # §3.1.1, Xf = Xi + sum W dX
            interpolated.append(fp_id)
            if not inside[row]:
                outside.append(fp_id)

    affine = [f for f in missing if f not in on_surface]
    if affine:
        require_spatial(given_ids, given_points, "given FPs (to carry FPs off the face surface)")
        given_rest = np.array([rest[f] for f in given_ids])
        fit = robust_affine_fit(given_rest, given_points - given_rest)
        for fp_id in affine:
            positions[fp_id] = rest[fp_id] + np.append(rest[fp_id], 1.0) @ fit

    ordered = {fp_id: np.asarray(positions[fp_id], dtype=np.float64) for fp_id in generic_ids}
    return CompletedFeaturePoints(ordered, tuple(interpolated), tuple(outside), tuple(affine))


def _given_partners(ids: tuple[str, ...], points: np.ndarray, target: dict[str, np.ndarray]) -> dict[str, str]:
    """FP -> the given FP standing for its coincident group; refuses a group given at two places."""
    partner = {}
    tolerance = COINCIDENT_FRACTION * extent(np.array(list(target.values())).reshape(-1, 3))
    for group in coincident_groups(ids, points):
        given = [fp_id for fp_id in group if fp_id in target]
        if not given:
            continue
        for fp_id in given[1:]:
            if np.linalg.norm(target[fp_id] - target[given[0]]) > tolerance:
                raise CoincidentFeaturePointsError(
                    f"FPs {given[0]} and {fp_id} are one point on the generic face but given "
                    f"{1000 * np.linalg.norm(target[fp_id] - target[given[0]]):.3g} mm apart; give only one of them"
                )
        partner.update({fp_id: given[0] for fp_id in group})
    return partner
