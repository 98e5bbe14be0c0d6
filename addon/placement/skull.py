"""The hairline and skull points 11.1-11.6 by their definitions, read off the head's outline.

The standard names them (11.1 the middle of the hair-forehead border, 11.2/11.3 its right and left ends,
11.4 the top of the skull, 11.5 the hair's thickness over 11.4, 11.6 the back of the skull) and draws
them, but gives no construction; on a bald head there is no hair border to find. Read here, as the sample
head's FP rules read them (`scripts/sample/makehuman/fp_rules.py`), in the head's own Frankfurt frame:

- the frame: left is the face's mid-plane normal; forward runs from the tragi (10.3/10.4, standing in for
  the porions) to the lower lids' middles (3.9/3.10, standing in for the orbitales), in the mid-plane;
  up completes it (the Frankfurt horizontal, the anthropometric "head upright", so the top and back of the
  skull do not move with how a mesh happens to be pitched);
- the outline: the mid-plane's section of the skin, seen from the tragi's midpoint (per direction its
  outermost crossing), so teeth, tongue and the mouth's inside are not on it;
- nasion: the outline's deepest point (least forward) between the nose tip 9.3 and the brows 4.3/4.4;
  11.1 (trichion) the forehead's outline point as high above the nasion as the nasion is above the
  subnasale 9.15 (the upper facial third as tall as the middle one); 11.2/11.3 the same in the sagittal
  plane through the outer brow 4.6/4.5, a third of the way down from 11.1's height to the brow's;
- 11.4 (vertex) the outline's highest point; 11.5 = 11.4 (no hair: zero thickness); 11.6 the outline's
  rearmost point above the tragi.

Everything is a ratio or an extreme, so the rules hold in any units. `evaluate_placement` scores 11.x
against the same rules applied to the truth's own mesh and points, as it does 7.1 (`landmarks.spine_top`).
"""

from __future__ import annotations

import numpy as np

from ..mpeg4.feature_points import fp_index
from .nicp import edges_of
from .openings import plane_crossings

ANGLE_STEP = np.radians(0.5)  # the outline's resolution, seen from its centre
WINDOW = np.radians(3.0)  # a crossing is on the outline when no crossing within this angle lies further out
OUTER_SHARE = 0.95  # by more than this share of its distance from the centre
ROWS = ("11.1", "11.2", "11.3", "11.4", "11.5", "11.6")


def ear_centre(points: np.ndarray) -> np.ndarray:
    """The mean of the ten ear points 10.1-10.10."""
    return points[[fp_index(f"10.{k}") for k in range(1, 11)]].mean(axis=0)


def frankfurt_axes(points: np.ndarray, left: np.ndarray, up_hint: np.ndarray) -> np.ndarray:
    """Rows left, up, forward of the head's Frankfurt frame from its FPs `points` (84, 3); `left` is the
    mid-plane's normal and `up_hint` any vector on the head's upper side (it picks the sign)."""
    left = left / np.linalg.norm(left)
    forward = 0.5 * (points[fp_index("3.9")] + points[fp_index("3.10")])
    forward = forward - ear_centre(points)
    forward = forward - (forward @ left) * left
    forward /= np.linalg.norm(forward)
    up = np.cross(forward, left)
    if up @ up_hint < 0:
        up = -up
    return np.array([left, up, forward])


def head_frame(points: np.ndarray, left: np.ndarray, up_hint: np.ndarray, template_points, template_axes):
    """Rows left, up, forward of the frame the sample head's FP rules use (MakeHuman's, `template_axes`),
    carried to a head by its Frankfurt frame: the Frankfurt frame of the head's FPs `points` turned about
    left by the angle between the template's own Frankfurt frame (from `template_points`) and its axes."""
    reference = frankfurt_axes(template_points, template_axes[0], template_axes[1])
    angle = np.arctan2(template_axes[2] @ reference[1], template_axes[2] @ reference[2])
    frame = frankfurt_axes(points, left, up_hint)
    forward = np.cos(angle) * frame[2] + np.sin(angle) * frame[1]
    up = np.cos(angle) * frame[1] - np.sin(angle) * frame[2]
    return np.array([frame[0], up, forward])


def outline(vertices: np.ndarray, edges: np.ndarray, axes: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """The outline (K, 3) of the mesh's section by the plane through `centre` normal to `axes[0]`, seen
    from `centre`: per ANGLE_STEP of direction (in the plane of `axes[1]` up and `axes[2]` forward) the
    outermost crossing, kept only where nothing within WINDOW lies much further out (a direction the
    section's edges happen to miss would otherwise show an inner piece). Ordered by angle."""
    points = plane_crossings(vertices, edges, axes[0], float(centre @ axes[0]))
    if not len(points):
        return points
    relative = points - centre
    angle = np.arctan2(relative @ axes[1], relative @ axes[2])
    radius = np.hypot(relative @ axes[1], relative @ axes[2])
    bins = np.round(angle / ANGLE_STEP).astype(np.int64)
    order = np.lexsort((radius, bins))
    last = np.r_[bins[order][1:] != bins[order][:-1], True]
    best = order[last]  # the outermost crossing of each direction, by angle
    a, r = angle[best], radius[best]
    near = np.abs(a[:, None] - a[None, :]) <= WINDOW
    keep = r >= OUTER_SHARE * np.where(near, r[None, :], 0.0).max(axis=1)
    return points[best[keep]]


def _level(path: np.ndarray, values: np.ndarray, level: float, gap: float = np.inf) -> np.ndarray:
    """Points (C, 3) where `values` (K,), given at the points of `path` (K, 3) in order, pass `level`, each
    linearly interpolated between its two path points (a step of `gap` or more in value is not a crossing:
    an angle wrapping round)."""
    a, b = values[:-1] - level, values[1:] - level
    crossing = (a * b <= 0) & (a != b) & (np.abs(a - b) < gap)
    t = a[crossing] / (a[crossing] - b[crossing])
    start, end = path[:-1][crossing], path[1:][crossing]
    return start + t[:, None] * (end - start)


def _centre(points: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The tragi's midpoint put on the mid-plane (through the mid-line points of the face)."""
    left = axes[0]
    ears = ear_centre(points)
    mid = np.array([fp_index(i) for i in ("9.3", "9.15", "2.10", "2.1", "8.1", "8.2")])
    return ears - (ears @ left - float(np.mean(points[mid] @ left))) * left


def ray_angles(points: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The directions (radians from forward towards up, about the tragi's midpoint, in the frame `axes`)
    in which 11.4 and 11.6 of `points` (84, 3) lie: measured on the template, they carry its top and back
    of the skull to another head as the outline points in the same directions."""
    relative = points[[fp_index("11.4"), fp_index("11.6")]] - _centre(points, axes)
    return np.arctan2(relative @ axes[1], relative @ axes[2])


def skull_points(
    vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray, axes: np.ndarray, angles: np.ndarray
) -> np.ndarray:
    """`points` (84, 3) with 11.1-11.6 put where their definitions (the module's doc) say on the mesh;
    `axes` rows left, up, forward of the head's frame (`head_frame`), `angles` the template's directions of
    11.4 and 11.6 (`ray_angles`). A rule whose outline has nothing where it looks leaves its point as it
    was."""
    points = points.copy()
    left, up, forward = axes
    edges = edges_of(triangles)
    centre = _centre(points, axes)
    profile = outline(vertices, edges, axes, centre)
    if len(profile) < 3:
        return points
    height, depth = profile @ up, (profile - centre) @ forward
    direction = np.arctan2(height - centre @ up, depth)
    for rows, angle in ((("11.4", "11.5"), angles[0]), (("11.6",), angles[1])):
        ray = _level(profile, np.angle(np.exp(1j * (direction - angle))), 0.0, gap=np.pi)
        if len(ray):
            for fp_id in rows:
                points[fp_index(fp_id)] = ray[np.argmax(np.linalg.norm(ray - centre, axis=1))]
    top = int(np.argmax(height))
    brow = 0.5 * (points[fp_index("4.3")] + points[fp_index("4.4")]) @ up
    tip = points[fp_index("9.3")] - centre
    # the face's front above the nose tip: the outline from the tip's direction round to the top's
    front = (direction >= np.arctan2(tip @ up, tip @ forward)) & (direction <= direction[top])
    bridge = front & (height < brow)
    if not bridge.any():
        return points
    nasion = profile[bridge][np.argmin(depth[bridge])] @ up
    hairline = 2.0 * nasion - points[fp_index("9.15")] @ up
    forehead = front & (height > nasion)
    if not forehead.any():
        return points
    hairline_points = _level(profile[forehead], height[forehead], hairline)
    if not len(hairline_points):
        return points
    points[fp_index("11.1")] = hairline_points[np.argmax(hairline_points @ forward)]
    end_height = hairline - (hairline - brow) / 3.0
    for end, outer in (("11.3", "4.5"), ("11.2", "4.6")):
        side = points[fp_index(outer)]
        plane_centre = centre + ((side - centre) @ left) * left
        section = outline(vertices, edges, axes, plane_centre)
        front = section[((section - plane_centre) @ forward > 0) & (section @ up > brow)]
        ends = _level(front, front @ up, end_height)
        if len(ends):
            points[fp_index(end)] = ends[np.argmax(ends @ forward)]
    return points


def read_skull(vertices, triangles, points, left, up_hint, template_points, template_axes) -> np.ndarray:
    """`points` (84, 3) with 11.1-11.6 read off the mesh (`skull_points`) in the head's frame (`head_frame`,
    from its mid-plane normal `left` and `up_hint`), with the template's rays (`template_points` in its
    `template_axes`). Placement reads the user's mesh with it; `evaluate_placement` the truth's."""
    axes = head_frame(points, left, up_hint, template_points, template_axes)
    return skull_points(vertices, triangles, points, axes, ray_angles(template_points, template_axes))
