"""Eyelids that slide over the eyeball: a blink closes along a smooth curve and the lids meet.

Planar Bones moves an eyelid with its control triangles, and only the mid-lid feature point (3.1-3.4)
moves in a blink, so the lid margin folds into a V at that point. So the deformer is given the mid-lid
FPs at rest (`hold_lids`: the brows, cheeks and head still move the lids through it) and their motion is
added here instead. A lid is skin lying on the eyeball: its vertices turn about the eye's centre, around
the eye's horizontal axis (face x), by the angle through which the mid-lid FP turned. The angle is
weighted along the eye by the opening measured on the mesh (`opening_profile`: 1 under the mid-lid FP,
0 at the eye corners, where the lids are tied to the bone; `lid_profile`, a sine arch, when the mesh
shows no opening), so lids that meet under the FPs meet along the whole eye and the margin keeps its
curve; and by the lid's membership weight (how much of the lid a vertex is), so the skin above and below
follows smoothly. Turning keeps each vertex's distance to the centre: the lid stays on the eye.

The lids also follow the eyeball's pitch in part (`UPPER_FOLLOWS_PITCH`, `LOWER_FOLLOWS_PITCH`), as
real lids do, and the two lids of an eye stop where they meet (`decode.meet_at_closure`, in angle).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.decode import meet_at_closure
from ..mpeg4.feature_points import fp_index

# Share of the eyeball's pitch the lids follow: the upper lid tracks vertical gaze closely, the lower lid
# less (no paper of ours gives numbers; these are the usual animation values).
UPPER_FOLLOWS_PITCH = 0.7
LOWER_FOLLOWS_PITCH = 0.3
# FPs per eye: upper mid-lid, lower mid-lid, inner corner, outer corner, pupil (left eye, right eye)
EYE_FPS = (("3.1", "3.3", "3.11", "3.7", "3.5"), ("3.2", "3.4", "3.8", "3.12", "3.6"))
_TURN_ROWS = np.array([[fp_index(up), fp_index(low), fp_index(pupil)] for up, low, _i, _o, pupil in EYE_FPS])
MID_LID_FPS = frozenset(fp_id for eye in EYE_FPS for fp_id in eye[:2])
PROFILE_BINS = 24  # bins along the eye in which the opening is measured
REACH_RADII = (1.5, 2.0)  # the lids' turn fades out between these multiples of the eyeball radius from its centre


def lid_profile(x: np.ndarray, inner: float, mid: float, outer: float) -> np.ndarray:
    """Share of a lid's turn at lateral positions `x`: 0 at the corners `inner`/`outer`, 1 at `mid`.

    sin(pi tau) over the lid, with tau = 0.5 at the mid-lid point: the opening of an eye narrows to its
    corners like this, so a closed lid meets the other along its whole width; the slope is 0 at the
    mid point (no V) and the profile is 0 beyond the corners.
    """
    x = np.asarray(x, dtype=np.float64)
    t = (x - inner) / (outer - inner)
    t_mid = min(max((mid - inner) / (outer - inner), 0.05), 0.95)
    tau = np.where(t < t_mid, 0.5 * t / t_mid, 0.5 + 0.5 * (t - t_mid) / (1.0 - t_mid))
    return np.where((tau > 0.0) & (tau < 1.0), np.sin(np.pi * np.clip(tau, 0.0, 1.0)), 0.0)


def trace_margins(t: np.ndarray, elev: np.ndarray, upper: np.ndarray, lower: np.ndarray) -> list | None:
    """The lid margins along the eye, traced on the mesh: [(t, elevation) of the upper margin, of the lower].

    `t` (K,) position of the vertices from the inner (0) to the outer (1) corner, `elev` their elevation,
    `upper`/`lower` their lid membership. Each margin is traced by its lid's lowest (upper lid) or highest
    (lower lid) vertex in each bin of `t` (members at least half; up to `PROFILE_BINS` bins, about one per
    three members on a coarse mesh), and the margins meet at the corners; None when a margin has fewer
    than 3 points.
    """
    members = min(int(np.sum(upper >= 0.5)), int(np.sum(lower >= 0.5)))
    edges = np.linspace(0.0, 1.0, max(4, min(PROFILE_BINS, members // 3)) + 1)
    margins = []
    for member, pick in ((upper, np.argmin), (lower, np.argmax)):
        ts, angles = [0.0], [np.nan]
        for b in range(len(edges) - 1):
            inside = np.flatnonzero((t >= edges[b]) & (t < edges[b + 1]) & (member >= 0.5))
            if len(inside):
                k = inside[pick(elev[inside])]
                ts.append(float(t[k]))
                angles.append(float(elev[k]))
        ts.append(1.0)
        angles.append(np.nan)
        margins.append((np.array(ts), np.array(angles)))
    if min(len(m[0]) for m in margins) < 5:
        return None
    corner = [np.nanmean([m[1][1] for m in margins]), np.nanmean([m[1][-2] for m in margins])]
    for _ts, angles in margins:
        angles[0], angles[-1] = corner
    return margins


def opening_profile(margins: list, t: np.ndarray, t_mid: float) -> np.ndarray | None:
    """Share of the lids' turn along the eye: the opening between the traced `margins` at `t` over the
    opening under the mid-lid FPs (`t_mid`), so that lids that meet under the FPs meet along the whole eye."""

    def opening(x):
        return np.interp(x, *margins[0]) - np.interp(x, *margins[1])

    mid = opening(t_mid)
    if not mid > 0.0:
        return None
    return np.where((t > 0.0) & (t < 1.0), np.clip(opening(t) / mid, 0.0, 1.5), 0.0)


def _fall(x: np.ndarray) -> np.ndarray:
    """1 for x <= 0, smoothly down to 0 at x = 1 (slope at most 1.5)."""
    x = np.clip(x, 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def elevation(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Angle of face-frame points above the horizontal plane through `centre`, about the face x axis."""
    d = np.asarray(points, dtype=np.float64) - centre
    return np.arctan2(d[..., 1], d[..., 2])


@dataclass(frozen=True)
class EyelidRig:
    """What `apply` needs, computed once from the rest face."""

    vertices: np.ndarray  # (K,) indices of the vertices the lids move
    eye: np.ndarray  # (K,) 0 left eye, 1 right eye
    upper: np.ndarray  # (K,) share of the upper lid's turn (membership x profile)
    lower: np.ndarray  # (K,) share of the lower lid's turn
    local: np.ndarray  # (K, 3) rest positions relative to their eye's centre, face frame
    centres: np.ndarray  # (2, 3) eye centres, face frame
    rest_angles: np.ndarray  # (2, 3) rest elevation of the upper mid-lid FP, lower mid-lid FP, pupil
    axes: np.ndarray  # (3, 3) face frame in mesh coordinates


def bind_eyelids(
    rest: np.ndarray,
    upper_lid: np.ndarray,
    lower_lid: np.ndarray,
    neutral: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> EyelidRig | None:
    """Rig the lids of a rest face; None when an eye's lid FPs are missing.

    `rest` (N, 3) mesh positions; `upper_lid`/`lower_lid` (N,) membership weights in [0, 1] (1 on the lid);
    `neutral` (84, 3) rest FP positions (NaN where missing); `centres` (2, 3) and `radii` (2,) the left and
    right eyeballs, all in mesh coordinates.
    """
    axes = np.asarray(axes, dtype=np.float64)
    face = np.asarray(rest, dtype=np.float64) @ axes.T
    fps = np.asarray(neutral, dtype=np.float64) @ axes.T
    centres = np.asarray(centres, dtype=np.float64) @ axes.T
    radii = np.asarray(radii, dtype=np.float64)
    ids = [[fp_index(f) for f in eye] for eye in EYE_FPS]
    if not all(np.all(np.isfinite(fps[k[:4]])) for k in ids):
        return None
    distance = np.linalg.norm(face[:, None] - centres[None], axis=2)
    eye = np.argmin(distance, axis=1)
    rows = np.arange(len(face))
    near = distance[rows, eye] / radii[eye]
    # skin on the eyeball: not inside it (the socket the eyeball hides) nor far from it (brow, cheek)
    on_eyeball = 1.0 - _fall((near - 0.95) / 0.05)
    fade = _fall((near - REACH_RADII[0]) / (REACH_RADII[1] - REACH_RADII[0])) * on_eyeball
    in_front = face[:, 2] > centres[eye, 2]
    up = np.clip(np.asarray(upper_lid, dtype=np.float64), 0.0, 1.0)
    low = np.clip(np.asarray(lower_lid, dtype=np.float64), 0.0, 1.0)
    keep = np.flatnonzero((fade > 0.0) & in_front)
    eye, fade, up, low = eye[keep], fade[keep], up[keep], low[keep]
    up_weight, low_weight = np.zeros(len(keep)), np.zeros(len(keep))
    rest_angles = np.full((2, 3), np.nan)
    for e, (upper, lower, inner, outer, pupil) in enumerate(ids):
        on = eye == e
        x = face[keep[on], 0]
        inner_x, outer_x = fps[inner, 0], fps[outer, 0]
        rest_angles[e] = elevation(fps[[upper, lower, pupil]], centres[e])
        t = (x - inner_x) / (outer_x - inner_x)
        elev = elevation(face[keep[on]], centres[e])
        margins = trace_margins(t, elev, up[on], low[on])
        profile = (
            None if margins is None else opening_profile(margins, t, (fps[upper, 0] - inner_x) / (outer_x - inner_x))
        )
        if profile is not None:
            up_weight[on], low_weight[on] = up[on] * profile, low[on] * profile
        else:  # no opening traced on the mesh: a sine arch along the eye
            up_weight[on] = up[on] * lid_profile(x, inner_x, fps[upper, 0], outer_x)
            low_weight[on] = low[on] * lid_profile(x, inner_x, fps[lower, 0], outer_x)
    moved = (up_weight > 0.0) | (low_weight > 0.0)
    keep, eye, fade = keep[moved], eye[moved], fade[moved]
    up_weight, low_weight = up_weight[moved], low_weight[moved]
    return EyelidRig(
        vertices=keep,
        eye=eye,
        upper=up_weight * fade,
        lower=low_weight * fade,
        local=face[keep] - centres[eye],
        centres=centres,
        rest_angles=rest_angles,
        axes=axes,
    )


def lid_turns(rig: EyelidRig, fp_positions: np.ndarray) -> np.ndarray:
    """(2, 2) turn of the upper and lower mid-lid (radians, + up) of each eye, gaze-follow and stop included.

    `fp_positions` (84, 3) current FP positions in mesh coordinates (a missing pupil: no gaze follow).
    Both eyes at once: this runs on every played frame, and on arrays this small numpy's cost is per call.
    """
    fps = np.asarray(fp_positions, dtype=np.float64)[_TURN_ROWS] @ rig.axes.T  # (2, 3, 3): upper, lower, pupil
    now = elevation(fps, rig.centres[:, None, :])
    delta = np.where(np.isfinite(now), now - rig.rest_angles, 0.0)
    up = delta[:, 0] + UPPER_FOLLOWS_PITCH * delta[:, 2]
    low = delta[:, 1] + LOWER_FOLLOWS_PITCH * delta[:, 2]
    down, rise = meet_at_closure(-up, low, rig.rest_angles[:, 0] - rig.rest_angles[:, 1])
    return np.stack([-down, rise], axis=1)


@functools.lru_cache(maxsize=16)
def _mid_lid_rows(control_ids: tuple[str, ...]) -> list[int]:
    return [k for k, fp_id in enumerate(control_ids) if fp_id in MID_LID_FPS]


def hold_lids(control_ids, points: np.ndarray, control_rest: np.ndarray) -> np.ndarray:
    """The control points (M, 3) with the mid-lid FPs (3.1-3.4) at rest: their motion is the lids' turn."""
    lids = _mid_lid_rows(tuple(control_ids))  # played every frame with the same ids
    if not lids:
        return points
    held = np.array(points, copy=True)
    held[lids] = control_rest[lids]
    return held


def apply_eyelids(rig: EyelidRig, out: np.ndarray, fp_positions: np.ndarray) -> None:
    """Add the lids' turn about the eye centres to the deformed positions `out` (N, 3), in place."""
    turns = lid_turns(rig, fp_positions)
    if not turns.any():  # lids at rest and the gaze level: every vertex would turn by exactly 0
        return
    angle = rig.upper * turns[rig.eye, 0] + rig.lower * turns[rig.eye, 1]
    # the turn about the face x axis moves only y and z: add (turned - local) straight along the y and z axes,
    # without building the turned copy; c - 1 as -2 sin^2(angle / 2) keeps small turns exact
    c1, s = -2.0 * np.sin(0.5 * angle) ** 2, np.sin(angle)
    y, z = rig.local[:, 1], rig.local[:, 2]
    moved = np.empty((len(angle), 2))
    moved[:, 0] = c1 * y + s * z
    moved[:, 1] = c1 * z - s * y
    out[rig.vertices] += moved @ rig.axes[1:]
