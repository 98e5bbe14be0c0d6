"""FAP values per frame -> feature point positions per frame.

The data path: `hold_missing` turns a stream's masked values into a dense (F, 68) array, then
`fap_to_fp` moves the neutral FPs:

1. translations: every translational FAP moves its FP along its axis by value x FAPU (face frame);
   the jaw FAPs (3, 14, 15) also carry the points that ride on the mandible (`JAW_RIDERS`);
2. tongue_roll (47) turns the tongue borders 6.3/6.4 upward about the tongue's forward axis through 6.2;
3. eyeball yaw/pitch (23-26) turn the pupils 3.5/3.6 about the eyeball centres;
4. head pitch/yaw/roll (48-50) turn every point about 7.1, the top of the spine.

Between 1 and 2, opposed points that close an opening (upper/lower eyelids, inner and outer lips) meet
and stop there (`meet_at_closure`): values that together close more than the opening (a blink of 1024
on both lids, a pout pressed past contact) would otherwise make the lids or lips cross. The lips' FPs
also stay in order top to bottom in each column (outer upper, inner upper, inner lower, outer lower:
an outer lip contour lowered past its inner one, or raised into the other lip, stops), and a mouth
corner squeezed inward stops short of the lip FPs beside it. The skin can still pass between FPs in
order; `deform.lips.guard_lips` keeps it apart after the deformer.

Readings chosen where the standard leaves the decoder free (research/mpeg4-fba.md sections 8, 13):
- Masked-out FAPs hold their last transmitted value (0 = neutral before the first one), as Greta and
  VREng play them. Optionally a FAP missing in a frame first takes its left/right partner's value, then
  its inner/outer lip counterpart's, in that frame.
- open_jaw "does not affect mouth opening": the lower lip, chin and lower teeth move with the jaw and
  the lip FAPs add on top. The lip corners take half of the jaw motion (they sit at the hinge between
  the lips), and so do the cheeks' centres 5.1 / 5.2, which the standard puts at the corners' height: skin
  between the maxilla and the mandible at the level where the teeth meet, stretched between a bone that
  stays and one that drops (MakeHuman's sculpted mouth-open unit moves them 19 mm as its chin moves 39;
  before, the cheeks stayed and the skin between them and the chin stretched). Unidirectional FAPs are
  passed through when negative (real streams send such values).
- Rotations compose as R = R_yaw @ R_pitch @ R_roll for the head (roll innermost, yaw outermost like a
  neck) and R_yaw @ R_pitch for the eyeballs; both eyes use the same sign convention.
- dilate_pupil (29, 30) scales the pupil and moves no feature point, so it is ignored here.
"""

from __future__ import annotations

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .faps import FAPS, INNER_OUTER_LIP_PAIRS, LEFT_RIGHT_PAIRS, N_FAPS
from .fapu import Fapu
from .feature_points import N_FEATURE_POINTS, fp_index

JAW_FAPS = (3, 14, 15)
JAW_RIDERS: dict[str, float] = {
    **dict.fromkeys("2.3 2.8 2.9 2.10 2.11 2.12 8.2 8.7 8.8 9.9 9.11 6.1 6.2 6.3 6.4".split(), 1.0),
    **dict.fromkeys(("2.4", "2.5", "8.3", "8.4", "5.1", "5.2"), 0.5),
}
# (upper FP, lower FP) across the eye openings and the mouth: the upper one must stay above the lower one
CLOSING_PAIRS = (
    ("3.1", "3.3"), ("3.2", "3.4"),
    ("2.2", "2.3"), ("2.6", "2.8"), ("2.7", "2.9"),
    ("8.1", "8.2"), ("8.5", "8.7"), ("8.6", "8.8"),
)  # fmt: skip
# the lips' columns, left, middle and right: (outer upper, inner upper, inner lower, outer lower) FPs, top to bottom
LIP_COLUMNS = (("8.5", "2.6", "2.8", "8.7"), ("8.1", "2.2", "2.3", "8.2"), ("8.6", "2.7", "2.9", "8.8"))
# (corner, neighbour, side: +1 left, x > 0; -1 right) across the mouth: a corner stretched inward stops
# short of the lip FPs beside it
CORNER_PAIRS = (
    ("2.4", "2.6", 1.0), ("2.4", "2.8", 1.0), ("8.3", "8.5", 1.0), ("8.3", "8.7", 1.0),
    ("2.5", "2.7", -1.0), ("2.5", "2.9", -1.0), ("8.4", "8.6", -1.0), ("8.4", "8.8", -1.0),
)  # fmt: skip
CORNER_KEEP = 0.25  # share of the rest distance from a corner to its neighbour that a squeeze leaves
EYEBALL_RADIUS_PER_ES0 = 0.19  # default eye pivot: 12 mm behind a 63 mm-ES0 pupil, when no eyeball is given


def hold_missing(mask: np.ndarray, values: np.ndarray, fill_partners: bool = False) -> np.ndarray:
    """(F, 68) mask + values -> (F, 68) dense values: each masked-out FAP holds its last value."""
    mask = np.asarray(mask, dtype=bool)
    values = np.where(mask, np.asarray(values, dtype=np.float64), 0.0)
    if fill_partners:
        mask = mask.copy()
        for pairs in (LEFT_RIGHT_PAIRS, INNER_OUTER_LIP_PAIRS):
            for a, b in pairs:
                for dst, src in ((a - 1, b - 1), (b - 1, a - 1)):
                    take = ~mask[:, dst] & mask[:, src]
                    values[take, dst] = values[take, src]
                    mask[take, dst] = True
    frames = np.arange(len(mask))[:, None]
    last = np.maximum.accumulate(np.where(mask, frames, -1), axis=0)
    held = np.take_along_axis(values, np.maximum(last, 0), axis=0)
    return np.where(last >= 0, held, 0.0)


def meet_at_closure(
    upper_down: np.ndarray, lower_up: np.ndarray, gap: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closing motions of two opposed points -> the same motions stopped where the points meet.

    `upper_down` and `lower_up` (any shape) are how far each point moves toward the other (negative: away),
    `gap` >= 0 their distance at rest. Where together they would close more than the gap: if both close,
    each keeps its share of the gap (a blink of both lids meets where their values say); if one moves
    away, it keeps its motion and the other stops on it (a pout lifting both lips keeps the lift).
    Continuous in both motions.
    """
    a = np.asarray(upper_down, dtype=np.float64)
    b = np.asarray(lower_up, dtype=np.float64)
    gap = np.maximum(np.asarray(gap, dtype=np.float64), 0.0)  # a number, or one per point (broadcast)
    over = a + b > gap
    both = over & (a > 0.0) & (b > 0.0)
    share = gap / np.where(both, a + b, 1.0)
    a_out = np.where(both, a * share, np.where(over & (b <= 0.0), gap - b, a))
    b_out = np.where(both, b * share, np.where(over & (a <= 0.0), gap - a, b))
    return a_out, b_out


def _meet(face_neutral: np.ndarray, pts: np.ndarray, upper: str, lower: str) -> None:
    """`meet_at_closure` on the heights of two points (face frame: y up), in place; unknown points are skipped."""
    i, j = fp_index(upper), fp_index(lower)
    if not np.all(np.isfinite(face_neutral[[i, j], 1])):
        return
    rest_i, rest_j = face_neutral[i, 1], face_neutral[j, 1]
    down, up = meet_at_closure(rest_i - pts[:, i, 1], pts[:, j, 1] - rest_j, rest_i - rest_j)
    pts[:, i, 1] = rest_i - down
    pts[:, j, 1] = rest_j + up


def _stop_at_closure(face_neutral: np.ndarray, pts: np.ndarray) -> None:
    """Stop the opposed points of CLOSING_PAIRS where they meet, and keep each lip column in order, in place.

    A lip column (LIP_COLUMNS) stays ordered top to bottom, outer upper >= inner upper >= inner lower >=
    outer lower: a lip's outer contour stops on its own inner contour (a lip is never less than zero high),
    the inner contours stop on each other, then an outer point that the inner one's stop has passed is
    carried along with it. Each step is continuous (a clamp or `meet_at_closure`) and the same for the left
    and right columns, so the whole is continuous and mirror-symmetric. Our reading: the standard leaves
    the decoder free to keep the lips from crossing, and the skin between a lip's outer and inner FPs
    follows both, so lip skin cannot pass the other lip while the FPs keep this order.
    """
    for upper_o, upper_i, lower_i, lower_o in LIP_COLUMNS:
        _meet(face_neutral, pts, upper_o, upper_i)
        _meet(face_neutral, pts, lower_i, lower_o)
    for upper, lower in CLOSING_PAIRS:
        _meet(face_neutral, pts, upper, lower)
    for upper_o, upper_i, lower_i, lower_o in LIP_COLUMNS:
        uo, ui, li, lo = (fp_index(f) for f in (upper_o, upper_i, lower_i, lower_o))
        # a face whose points are out of this order at rest keeps its rest overlap
        above = np.fmin(face_neutral[uo, 1] - face_neutral[ui, 1], 0.0)
        below = np.fmin(face_neutral[li, 1] - face_neutral[lo, 1], 0.0)
        pts[:, uo, 1] = np.fmax(pts[:, uo, 1], pts[:, ui, 1] + above)
        pts[:, lo, 1] = np.fmin(pts[:, lo, 1], pts[:, li, 1] - below)
    _keep_corners_out(face_neutral, pts)


def _keep_corners_out(face_neutral: np.ndarray, pts: np.ndarray) -> None:
    """Stop a mouth corner stretched inward (stretch_l/r_cornerlip, -400 moves it 0.4 MW0, most of the way to
    the mid line) short of the lip FPs beside it, in place: the corner and each neighbour close along x
    like a CLOSING_PAIRS pair (`meet_at_closure`) over all but CORNER_KEEP of their rest distance, so the
    lip contours stay in order across the mouth (the lips' skin is not folded over itself); the right
    side mirrors the left (x negated)."""
    for corner, beside, sign in CORNER_PAIRS:
        i, j = fp_index(corner), fp_index(beside)
        if not np.all(np.isfinite(face_neutral[[i, j], 0])):
            continue
        rest_i, rest_j = sign * face_neutral[i, 0], sign * face_neutral[j, 0]
        inward, outward = meet_at_closure(
            rest_i - sign * pts[:, i, 0], sign * pts[:, j, 0] - rest_j, (1.0 - CORNER_KEEP) * (rest_i - rest_j)
        )
        pts[:, i, 0] = sign * (rest_i - inward)
        pts[:, j, 0] = sign * (rest_j + outward)


def fap_scale(fapu: Fapu) -> np.ndarray:
    """(68,) size of one unit of each FAP: model units for distances, radians for angles, 0 for FAP 1/2."""
    return np.array([fapu.unit(f.fapu) if f.fapu else 0.0 for f in FAPS])


def translation_basis(fapu: Fapu) -> np.ndarray:
    """(68, 84, 3) face-frame displacement of each FP per unit of each FAP."""
    basis = np.zeros((N_FAPS, N_FEATURE_POINTS, 3))
    scale = fap_scale(fapu)
    for f in FAPS:
        if f.axis is None:
            continue
        axis = scale[f.number - 1] * np.asarray(f.axis)
        basis[f.number - 1, fp_index(f.fp)] = axis
        if f.number in JAW_FAPS:
            for fp_id, weight in JAW_RIDERS.items():
                basis[f.number - 1, fp_index(fp_id)] = weight * axis
    return basis


def rotation(axis: int, angle: np.ndarray) -> np.ndarray:
    """(F, 3, 3) right-handed rotations by `angle` (F,) about face axis 0 (x), 1 (y) or 2 (z)."""
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros((len(angle), 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r[:, axis, axis] = 1.0
    r[:, i, i] = c
    r[:, j, j] = c
    r[:, i, j] = -s
    r[:, j, i] = s
    return r


def _rotate(points: np.ndarray, pivot: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Rotate (F, K, 3) points about (F or 1, 1, 3) pivots by (F, 3, 3) rotations (column convention)."""
    return pivot + np.einsum("fkj,fij->fki", points - pivot, rot)


def fap_to_fp(
    neutral: np.ndarray,
    values: np.ndarray,
    fapu: Fapu,
    *,
    axes: np.ndarray = BLENDER_FACE_AXES,
    eye_pivots: np.ndarray | None = None,
) -> np.ndarray:
    """Dense FAP values (F, 68) -> FP positions (F, 84, 3) in mesh coordinates.

    `neutral` is (84, 3) in mesh coordinates (rows in FP_IDS order; NaN rows stay NaN), `axes` the face
    frame (see frame.py), `eye_pivots` the (2, 3) left/right eyeball centres in mesh coordinates.
    """
    neutral = np.asarray(neutral, dtype=np.float64)
    values = np.atleast_2d(np.asarray(values, dtype=np.float64))
    if neutral.shape != (N_FEATURE_POINTS, 3):
        raise ValueError(f"neutral FP positions must be ({N_FEATURE_POINTS}, 3), got {neutral.shape}")
    if values.shape[1] != N_FAPS:
        raise ValueError(f"FAP values must have {N_FAPS} columns, got {values.shape[1]}")
    axes = np.asarray(axes, dtype=np.float64)
    n_frames = len(values)
    angle = values * fap_scale(fapu)

    face_neutral = neutral @ axes.T
    disp = (values @ translation_basis(fapu).reshape(N_FAPS, -1)).reshape(n_frames, N_FEATURE_POINTS, 3)
    pts = face_neutral[None] + disp
    _stop_at_closure(face_neutral, pts)

    tongue_body = pts[:, [fp_index("6.2")]]  # after its own translation (raise_tongue)
    for fp_id, sign in (("6.3", 1.0), ("6.4", -1.0)):
        k = fp_index(fp_id)
        pts[:, [k]] = _rotate(pts[:, [k]], tongue_body, rotation(2, sign * angle[:, 46]))

    face_pivots = eye_centres(face_neutral, fapu, eye_pivots, axes)
    for eye, (fp_id, yaw, pitch) in enumerate((("3.5", 22, 24), ("3.6", 23, 25))):
        k = fp_index(fp_id)
        pivot = face_pivots[eye] + disp[:, k]  # thrust_eyeball (27, 28) carries the whole eyeball
        rot = rotation(1, angle[:, yaw]) @ rotation(0, angle[:, pitch])
        pts[:, [k]] = _rotate(pts[:, [k]], pivot[:, None], rot)

    if np.any(angle[:, 47:50]):  # a head held still (callers that key the head apart) skips the identity turn
        pts = _rotate(pts, head_pivot(face_neutral)[None, None], head_rotation(angle[:, 47:50]))
    return pts @ axes


def eye_centres(face_neutral: np.ndarray, fapu: Fapu, eye_pivots: np.ndarray | None, axes: np.ndarray) -> np.ndarray:
    """(2, 3) left/right eyeball centres in the face frame: the given pivots (mesh coordinates), or by
    default an eyeball radius straight behind each pupil."""
    if eye_pivots is not None:
        return np.asarray(eye_pivots, dtype=np.float64) @ axes.T
    back = EYEBALL_RADIUS_PER_ES0 * fapu.ES0 * np.array([0.0, 0.0, 1.0])
    return face_neutral[[fp_index("3.5"), fp_index("3.6")]] - back


def head_rotation(angles: np.ndarray) -> np.ndarray:
    """(F, 3) head pitch, yaw, roll in radians -> (F, 3, 3) face-frame rotations R_yaw @ R_pitch @ R_roll."""
    angles = np.asarray(angles, dtype=np.float64).reshape(-1, 3)
    return rotation(1, angles[:, 1]) @ rotation(0, angles[:, 0]) @ rotation(2, angles[:, 2])


def head_angles(rotations: np.ndarray) -> np.ndarray:
    """Inverse of `head_rotation`: (F, 3, 3) -> (F, 3) pitch, yaw, roll in radians (|pitch| < pi/2)."""
    r = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    pitch = np.arctan2(-r[:, 1, 2], np.hypot(r[:, 1, 0], r[:, 1, 1]))
    roll = np.arctan2(r[:, 1, 0], r[:, 1, 1])
    yaw = np.arctan2(r[:, 0, 2], r[:, 2, 2])
    return np.stack([pitch, yaw, roll], axis=1)


def head_pivot(face_points: np.ndarray) -> np.ndarray:
    """The head's rotation centre: 7.1, or the centroid of the known points on a face without it."""
    spine = face_points[fp_index("7.1")]
    if np.all(np.isfinite(spine)):
        return spine
    known = face_points[np.all(np.isfinite(face_points), axis=1)]
    return known.mean(axis=0) if len(known) else np.zeros(3)
