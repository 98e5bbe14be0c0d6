"""Feature point positions -> FAP values: the inverse of decode.fap_to_fp, for authoring FAP streams.

Translations are one linear map (decode.translation_basis), solved by least squares over the points that
only translate; on positions made by `fap_to_fp` it returns the values exactly, and for hand-posed
points it returns the FAPs that best explain the motion (motion no FAP can express, such as moving
2.11 on its own, is dropped). Rotations are solved in closed form: the eyeballs from their pupils about
the eye pivots, tongue_roll from 6.3/6.4 about 6.2. Head rotation is not read from the points: callers
take it from the head's own transform (`decode.head_angles`). thrust_eyeball (27, 28) and
dilate_pupil (29, 30) are not recovered.
"""

from __future__ import annotations

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .decode import eye_centres, fap_scale, translation_basis
from .faps import FAPS, N_FAPS
from .fapu import Fapu
from .feature_points import FP_IDS, N_FEATURE_POINTS, fp_index

ROTATING_POINTS = ("3.5", "3.6", "6.3", "6.4")
NOT_RECOVERED = (1, 2, 27, 28, 29, 30, 48, 49, 50)


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + np.pi) % (2 * np.pi) - np.pi


def _eye_angles(v0: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Yaw and pitch with v = R_yaw @ R_pitch @ v0 (face frame; v0 (3,), v (F, 3))."""
    a, b = v0[1], v0[2]
    radius, phase = np.hypot(a, b), np.arctan2(b, a)
    # (R_pitch v0)_y = a cos p - b sin p = radius cos(p + phase) must equal v_y (R_yaw keeps y)
    base = np.arccos(np.clip(v[:, 1] / max(radius, 1e-300), -1.0, 1.0))
    candidates = np.stack([_wrap(base - phase), _wrap(-base - phase)], axis=1)
    pitch = candidates[np.arange(len(v)), np.argmin(np.abs(candidates), axis=1)]
    w_x = np.full_like(pitch, v0[0])
    w_z = a * np.sin(pitch) + b * np.cos(pitch)
    yaw = _wrap(np.arctan2(v[:, 0], v[:, 2]) - np.arctan2(w_x, w_z))
    return yaw, pitch


def fp_to_fap(
    neutral: np.ndarray,
    positions: np.ndarray,
    fapu: Fapu,
    *,
    axes: np.ndarray = BLENDER_FACE_AXES,
    eye_pivots: np.ndarray | None = None,
) -> np.ndarray:
    """(F, 84, 3) FP positions in mesh coordinates (head rotation removed) -> (F, 68) FAP values.

    FAPs whose points are missing (NaN in `neutral` or `positions`) come out as 0.
    """
    axes = np.asarray(axes, dtype=np.float64)
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    pts = np.asarray(positions, dtype=np.float64).reshape(-1, N_FEATURE_POINTS, 3) @ axes.T
    n_frames = len(pts)
    known = np.all(np.isfinite(face_neutral), axis=1) & np.all(np.isfinite(pts), axis=(0, 2))
    disp = np.where(known[None, :, None], pts - face_neutral[None], 0.0)

    basis = translation_basis(fapu)
    rows = [k for k, fp_id in enumerate(FP_IDS) if known[k] and fp_id not in ROTATING_POINTS]
    columns = [
        f.number - 1 for f in FAPS if f.axis is not None and f.number not in NOT_RECOVERED and known[fp_index(f.fp)]
    ]
    sub = basis[np.ix_(columns, rows)].reshape(len(columns), -1)
    values = np.zeros((n_frames, N_FAPS))
    if columns:
        solution, *_ = np.linalg.lstsq(sub.T, disp[:, rows].reshape(n_frames, -1).T, rcond=None)
        values[:, columns] = solution.T
    scale = fap_scale(fapu)

    translated = face_neutral[None] + (values @ basis.reshape(N_FAPS, -1)).reshape(n_frames, -1, 3)
    body = fp_index("6.2")
    angles = []
    for fp_id, sign in (("6.3", 1.0), ("6.4", -1.0)):
        k = fp_index(fp_id)
        if known[k] and known[body]:
            rest = translated[:, k] - pts[:, body]
            now = pts[:, k] - pts[:, body]
            angles.append(
                sign
                * np.arctan2(
                    rest[:, 0] * now[:, 1] - rest[:, 1] * now[:, 0], rest[:, 0] * now[:, 0] + rest[:, 1] * now[:, 1]
                )
            )
    if angles:
        values[:, 46] = np.mean(angles, axis=0) / scale[46]

    face_pivots = eye_centres(face_neutral, fapu, eye_pivots, axes)
    for eye, (fp_id, yaw, pitch) in enumerate((("3.5", 22, 24), ("3.6", 23, 25))):
        k = fp_index(fp_id)
        if known[k] and np.all(np.isfinite(face_pivots[eye])):
            y, p = _eye_angles(face_neutral[k] - face_pivots[eye], pts[:, k] - face_pivots[eye])
            values[:, yaw], values[:, pitch] = y / scale[yaw], p / scale[pitch]
    return values


def recoverable_faps(present: set[str]) -> list[int]:
    """FAP numbers that `fp_to_fap` can recover when the FPs in `present` exist."""
    out = []
    for f in FAPS:
        if f.number in NOT_RECOVERED:
            continue
        needed = {"6.2", "6.3", "6.4"} if f.number == 47 else {f.fp}
        if needed <= present:
            out.append(f.number)
    return out
