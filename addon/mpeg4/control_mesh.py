"""The control mesh: the template triangulation of the skin feature points (Planar Bones' control mesh).

`CONTROL_TRIANGLES` are FP-id triples over the 57 skin FPs, the hairline points 11.1-11.3 that close the
forehead (on a bald or short-haired head they lie on skin) and the points where the ears meet the head
(10.1-10.4, 10.7, 10.8) that close the sides of the face, wound so that normals face out of the face
(counter-clockwise seen from the front). The template is its own mirror image (every triangle's mirror,
left and right FPs swapped, is a triangle with the same mask), so a symmetric face deforms symmetrically.
No triangle bridges the mouth opening (the inner lip contour 2.2-2.9 has upper-lip triangles above it
and lower-lip triangles below it only) or an eye opening (the upper-lid triangles 3.11/3.1/3.13/3.7 and
the lower-lid triangles 3.11/3.3/3.9/3.7 meet only at the eye corners), so the openings are holes in the
mesh. `TRIANGLE_MASKS[t]` names the vertex group that limits
triangle t's influence: triangles touching an upper-lip FP (8.1, 8.5, 8.6, 8.9, 8.10, 2.2, 2.6, 2.7) use
"upper_lip", the lower-lip ones (8.2, 8.7, 8.8, 2.3, 2.8, 2.9) "lower_lip", the eyelid ones
"upper_eyelid" (3.1, 3.2, 3.13, 3.14) / "lower_eyelid" (3.3, 3.4, 3.9, 3.10); all others None.

An incomplete FP set gets a Delaunay triangulation of the present points in a cylindrical projection
instead (`triangulate_present`), with the same rules at the openings.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import Mpeg4Error
from ..geometry.cylindrical import cylindrical_projection
from ..geometry.delaunay import delaunay
from ..geometry.face_axes import BLENDER_FACE_AXES

# The openings (mouth, eyes) in feature point terms. Motion must not cross them (paper 000, section 3):
# no control triangle may join a point above an opening to one below it, and the triangles on each side
# are limited by a mask so their affection volumes stop at the opening.
UPPER_LIP = frozenset({"2.2", "2.6", "2.7", "8.1", "8.5", "8.6", "8.9", "8.10"})
LOWER_LIP = frozenset({"2.3", "2.8", "2.9", "8.2", "8.7", "8.8"})
UPPER_EYELID = frozenset({"3.1", "3.2", "3.13", "3.14"})
LOWER_EYELID = frozenset({"3.3", "3.4", "3.9", "3.10"})
OPENINGS = ((UPPER_LIP, LOWER_LIP), (UPPER_EYELID, LOWER_EYELID))
MASK_SETS = {"upper_lip": UPPER_LIP, "lower_lip": LOWER_LIP, "upper_eyelid": UPPER_EYELID, "lower_eyelid": LOWER_EYELID}
MASK_NAMES = tuple(MASK_SETS)

_TEMPLATE: tuple[tuple[tuple[str, str, str], str | None], ...] = (
    (("4.1", "9.7", "3.11"), None),
    (("4.2", "3.8", "9.6"), None),
    (("4.1", "3.11", "3.13"), "upper_eyelid"),
    (("4.2", "3.14", "3.8"), "upper_eyelid"),
    (("4.1", "3.13", "4.3"), "upper_eyelid"),
    (("4.2", "4.4", "3.14"), "upper_eyelid"),
    (("4.3", "3.13", "3.7"), "upper_eyelid"),
    (("4.4", "3.12", "3.14"), "upper_eyelid"),
    (("4.3", "3.7", "4.5"), None),
    (("4.4", "4.6", "3.12"), None),
    (("3.11", "3.1", "3.13"), "upper_eyelid"),
    (("3.8", "3.14", "3.2"), "upper_eyelid"),
    (("3.1", "3.7", "3.13"), "upper_eyelid"),
    (("3.2", "3.14", "3.12"), "upper_eyelid"),
    (("3.11", "3.9", "3.3"), "lower_eyelid"),
    (("3.8", "3.4", "3.10"), "lower_eyelid"),
    (("3.3", "3.9", "3.7"), "lower_eyelid"),
    (("3.4", "3.12", "3.10"), "lower_eyelid"),
    (("3.11", "9.7", "9.13"), None),
    (("3.8", "9.14", "9.6"), None),
    (("3.11", "9.13", "3.9"), "lower_eyelid"),
    (("3.8", "3.10", "9.14"), "lower_eyelid"),
    (("3.9", "9.13", "5.3"), "lower_eyelid"),
    (("3.10", "5.4", "9.14"), "lower_eyelid"),
    (("3.9", "5.3", "3.7"), "lower_eyelid"),
    (("3.10", "3.12", "5.4"), "lower_eyelid"),
    (("3.7", "5.3", "5.1"), None),
    (("3.12", "5.2", "5.4"), None),
    # the temple: split along 3.7-10.3, not along 4.5-5.1, which passes just beside the eye corner and made
    # a sliver that carried cheek motion up to the brow
    (("4.5", "3.7", "10.3"), None),
    (("4.6", "10.4", "3.12"), None),
    (("9.7", "9.12", "9.13"), None),
    (("9.6", "9.14", "9.12"), None),
    (("9.13", "9.12", "9.3"), None),
    (("9.14", "9.3", "9.12"), None),
    (("9.13", "9.3", "9.1"), None),
    (("9.14", "9.2", "9.3"), None),
    (("9.3", "9.15", "9.1"), None),
    (("9.3", "9.2", "9.15"), None),
    (("9.1", "9.15", "9.5"), None),
    (("9.2", "9.4", "9.15"), None),
    (("9.13", "9.1", "5.3"), None),
    (("9.14", "5.4", "9.2"), None),
    (("9.1", "9.5", "5.3"), None),
    (("9.2", "5.4", "9.4"), None),
    (("5.3", "9.5", "5.1"), None),
    (("5.4", "5.2", "9.4"), None),
    (("9.15", "8.1", "8.10"), "upper_lip"),
    (("9.15", "8.9", "8.1"), "upper_lip"),
    (("9.15", "8.10", "9.5"), "upper_lip"),
    (("9.15", "9.4", "8.9"), "upper_lip"),
    (("9.5", "8.10", "8.5"), "upper_lip"),
    (("9.4", "8.6", "8.9"), "upper_lip"),
    (("9.5", "8.5", "8.3"), "upper_lip"),
    (("9.4", "8.4", "8.6"), "upper_lip"),
    (("9.5", "8.3", "5.1"), None),
    (("9.4", "5.2", "8.4"), None),
    (("8.1", "2.2", "2.6"), "upper_lip"),
    (("8.1", "2.7", "2.2"), "upper_lip"),
    (("8.1", "2.6", "8.10"), "upper_lip"),
    (("8.1", "8.9", "2.7"), "upper_lip"),
    (("8.10", "2.6", "8.5"), "upper_lip"),
    (("8.9", "8.6", "2.7"), "upper_lip"),
    (("8.5", "2.6", "2.4"), "upper_lip"),
    (("8.6", "2.5", "2.7"), "upper_lip"),
    (("8.5", "2.4", "8.3"), "upper_lip"),
    (("8.6", "8.4", "2.5"), "upper_lip"),
    (("2.3", "8.2", "8.7"), "lower_lip"),
    (("2.3", "8.8", "8.2"), "lower_lip"),
    (("2.3", "8.7", "2.8"), "lower_lip"),
    (("2.3", "2.9", "8.8"), "lower_lip"),
    (("2.8", "8.7", "2.4"), "lower_lip"),
    (("2.9", "2.5", "8.8"), "lower_lip"),
    (("2.4", "8.7", "8.3"), "lower_lip"),
    (("2.5", "8.4", "8.8"), "lower_lip"),
    (("8.2", "2.10", "8.7"), "lower_lip"),
    (("8.2", "8.8", "2.10"), "lower_lip"),
    (("8.7", "2.10", "2.11"), "lower_lip"),
    (("8.8", "2.12", "2.10"), "lower_lip"),
    (("8.7", "2.11", "8.3"), "lower_lip"),
    (("8.8", "8.4", "2.12"), "lower_lip"),
    (("8.3", "2.11", "5.1"), None),
    (("8.4", "5.2", "2.12"), None),
    (("5.1", "2.11", "2.13"), None),
    (("5.2", "2.14", "2.12"), None),
    (("2.11", "2.10", "2.1"), None),
    (("2.12", "2.1", "2.10"), None),
    (("2.11", "2.1", "2.13"), None),
    (("2.12", "2.14", "2.1"), None),
    # under the jaw, from one jaw corner over the chin to the other, so that an opening jaw carries the
    # skin under the chin with it instead of folding it against the neck
    (("2.13", "2.1", "2.14"), None),
    # the nose bridge: a fan from the mid-line point 9.12, so that the mesh is its own mirror image
    (("4.1", "4.2", "9.12"), None),
    (("4.1", "9.12", "9.7"), None),
    (("4.2", "9.6", "9.12"), None),
    # the forehead, from the brows up to the hairline, so that raised brows stretch the forehead
    # instead of creasing it where the brow triangles' affection volumes end
    (("4.1", "11.1", "4.2"), None),
    (("4.3", "11.1", "4.1"), None),
    (("4.4", "4.2", "11.1"), None),
    (("4.3", "11.3", "11.1"), None),
    (("4.4", "11.1", "11.2"), None),
    (("4.5", "11.3", "4.3"), None),
    (("4.6", "4.4", "11.2"), None),
    # the sides of the face, from the outline (hairline end, outer brow, cheek, jaw corner) back to where
    # the ear meets the head, so that cheek and lip-corner motion fades over the cheek, not in a crease
    (("11.3", "4.5", "10.1"), None),
    (("4.5", "10.3", "10.1"), None),
    (("3.7", "5.1", "10.3"), None),
    (("5.1", "10.7", "10.3"), None),
    (("5.1", "2.13", "10.7"), None),
    (("4.6", "11.2", "10.2"), None),
    (("4.6", "10.2", "10.4"), None),
    (("3.12", "10.4", "5.2"), None),
    (("5.2", "10.4", "10.8"), None),
    (("5.2", "10.8", "2.14"), None),
)

CONTROL_TRIANGLES: tuple[tuple[str, str, str], ...] = tuple(triangle for triangle, _ in _TEMPLATE)
TRIANGLE_MASKS: tuple[str | None, ...] = tuple(mask for _, mask in _TEMPLATE)


class ControlMeshError(Mpeg4Error):
    """Control-mesh input that cannot be checked (wrong shapes, indices out of range, NaN)."""


def control_fp_ids(fp_order: tuple[str, ...]) -> tuple[str, ...]:
    """The FP ids the template uses, in the order of `fp_order` (e.g. `feature_points.FP_IDS`)."""
    used = {fp_id for triangle in CONTROL_TRIANGLES for fp_id in triangle}
    return tuple(fp_id for fp_id in fp_order if fp_id in used)


def template_indices(fp_ids: tuple[str, ...]) -> np.ndarray:
    """CONTROL_TRIANGLES as a (T, 3) int array of rows into `fp_ids`."""
    row = {fp_id: i for i, fp_id in enumerate(fp_ids)}
    missing = sorted({fp_id for triangle in CONTROL_TRIANGLES for fp_id in triangle} - row.keys())
    if missing:
        raise ControlMeshError(f"the control mesh needs FPs {', '.join(missing)}, not in the given ids")
    return np.array([[row[fp_id] for fp_id in triangle] for triangle in CONTROL_TRIANGLES], dtype=np.int64)


MOUTH_AND_JAW, EYES, OTHER_UPPER, BROWS = 0, 1, 2, 3  # `triangle_parts`
_PART_GROUPS = ((MOUTH_AND_JAW, frozenset({"2", "8"})), (EYES, frozenset({"3"})), (BROWS, frozenset({"4"})))
_EAR = "10"


def triangle_parts(fp_ids, triangles: np.ndarray) -> np.ndarray:
    """(T,) the part of the face each control triangle belongs to: MOUTH_AND_JAW when a corner is on the lips,
    the jaw or the chin (FP groups 2, 8) and none on an ear (10: the side of the head the jaw turns about), else
    EYES when a corner is on an eye (3), else BROWS when one is on a brow (4), else OTHER_UPPER (cheeks, nose,
    hairline and ears: groups 5, 9, 10, 11)."""
    group = np.array([fp_id.split(".")[0] for fp_id in fp_ids])
    corners = group[np.asarray(triangles, dtype=np.intp).reshape(-1, 3)]
    parts = np.full(len(corners), OTHER_UPPER, dtype=np.int8)
    for part, groups in reversed(_PART_GROUPS):  # the first of _PART_GROUPS wins
        touches = np.isin(corners, list(groups)).any(axis=1)
        if part == MOUTH_AND_JAW:
            touches &= ~(corners == _EAR).any(axis=1)
        parts[touches] = part
    return parts


def mouth_rows(fp_ids) -> tuple[int, ...]:
    """The control rows on the lips, the jaw or the chin (FP groups 2 and 8), from which the mouth and jaw's
    triangles' share of the motion falls (`face_binding.fall_from_mouth`)."""
    return tuple(i for i, fp_id in enumerate(fp_ids) if fp_id.split(".")[0] in ("2", "8"))


def check_control_mesh(points: np.ndarray, triangles: np.ndarray) -> list[str]:
    """Problems that stop (points (M, 3), triangles (T, 3)) from being a control mesh; [] if none.

    Checked: every point used, no degenerate or repeated triangle, every edge in at most two triangles,
    each vertex's triangles forming one fan (a manifold surface with boundary) and a consistent
    orientation (an edge shared by two triangles runs in opposite directions in them).
    """
    points = np.asarray(points, dtype=np.float64)
    triangles = np.asarray(triangles)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ControlMeshError(f"points must have shape (M, 3), got {points.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3 or not np.issubdtype(triangles.dtype, np.integer):
        raise ControlMeshError(f"triangles must be integers of shape (T, 3), got {triangles.dtype} {triangles.shape}")
    if not np.all(np.isfinite(points)):
        raise ControlMeshError("points contain NaN or infinity")
    if triangles.size and (triangles.min() < 0 or triangles.max() >= len(points)):
        raise ControlMeshError(f"triangle indices must lie in [0, {len(points)})")

    problems = []
    unused = sorted(set(range(len(points))) - set(triangles.ravel().tolist()))
    if unused:
        problems.append(f"points used by no triangle: {unused}")
    corners = points[triangles]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    repeated_corner = (triangles[:, 0] == triangles[:, 1]) | (triangles[:, 1] == triangles[:, 2])
    repeated_corner |= triangles[:, 0] == triangles[:, 2]
    scale = np.ptp(points, axis=0).max() if len(points) else 0.0
    for t in np.flatnonzero(repeated_corner | (areas <= 1e-12 * scale**2)):
        problems.append(f"triangle {t} {triangles[t].tolist()} is degenerate")
    seen: dict[tuple[int, ...], int] = {}
    for t, triangle in enumerate(triangles.tolist()):
        key = tuple(sorted(triangle))
        if key in seen:
            problems.append(f"triangles {seen[key]} and {t} have the same corners {list(key)}")
        seen.setdefault(key, t)

    directed: dict[tuple[int, int], list[int]] = {}
    for t, (a, b, c) in enumerate(triangles.tolist()):
        for edge in ((a, b), (b, c), (c, a)):
            directed.setdefault(edge, []).append(t)
    undirected: dict[tuple[int, int], list[int]] = {}
    for (a, b), ts in directed.items():
        undirected.setdefault((min(a, b), max(a, b)), []).extend(ts)
        if len(ts) > 1:
            problems.append(f"edge {a}->{b} runs the same way in triangles {ts}: inconsistent orientation")
    for edge, ts in undirected.items():
        if len(ts) > 2:
            problems.append(f"edge {list(edge)} is shared by {len(ts)} triangles {ts}: non-manifold")

    for v in range(len(points)):
        around = [t for t in range(len(triangles)) if v in triangles[t]]
        if len(around) > 1 and not _one_fan(triangles, around, v):
            problems.append(f"the triangles around point {v} form more than one fan: non-manifold vertex")
    return problems


def _one_fan(triangles: np.ndarray, around: list[int], v: int) -> bool:
    """Whether the triangles around v are connected through edges that contain v."""
    spokes = {t: set(triangles[t].tolist()) - {v} for t in around}
    reached, frontier = {around[0]}, [around[0]]
    while frontier:
        t = frontier.pop()
        for u in around:
            if u not in reached and spokes[t] & spokes[u]:
                reached.add(u)
                frontier.append(u)
    return len(reached) == len(around)


def spans_opening(ids) -> bool:
    """True when a triangle's FP ids lie on both sides of the mouth or of an eye."""
    s = set(ids)
    return any(s & upper and s & lower for upper, lower in OPENINGS)


def triangle_mask(ids) -> str | None:
    """The mask limiting a triangle that touches one side of an opening (None elsewhere)."""
    s = set(ids)
    for name, members in MASK_SETS.items():
        if s & members:
            return name
    return None


def triangulate_present(
    positions: Mapping[str, np.ndarray], centre: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES
) -> tuple[list[str], np.ndarray, list[str | None]]:
    """Control mesh over whichever FPs are present: Delaunay in a cylindrical projection about `centre`.

    Returns the FP ids (vertex order), (T, 3) triangles with outward normals, and each triangle's mask.
    Triangles across the mouth or an eye are dropped. Points that coincide on the neutral face (closed
    lips) are separated by a hair in the projection only, upper side up, so both stay in the mesh.
    """
    ids = sorted(positions, key=lambda s: tuple(int(p) for p in s.split(".")))
    pts = np.array([positions[i] for i in ids], dtype=np.float64)
    uv = cylindrical_projection(pts, centre, axes)
    span = float(np.ptp(uv, axis=0).max()) or 1.0
    key = np.round(uv / (1e-9 * span))
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    for k in np.flatnonzero(first[inverse.ravel()] != np.arange(len(ids))):
        uv[k, 1] += (1e-6 if ids[k] in UPPER_LIP | UPPER_EYELID else -1e-6) * span
    tris = delaunay(uv)
    keep = [t for t in tris if not spans_opening(ids[k] for k in t)]
    tris = np.array(keep, dtype=np.int64).reshape(-1, 3)
    # the projection is seen from outside (angle grows toward the face's left), so counter-clockwise in
    # (arc, height) is counter-clockwise seen from the front: normals face out of the head
    return ids, tris, [triangle_mask(ids[k] for k in t) for t in tris]
