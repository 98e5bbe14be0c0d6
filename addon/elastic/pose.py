"""Bone transforms for one frame: the first (rule) transformation, then the elastic layer (eq. 3-4).

Two drives, one result, (B, 4, 4) transforms relative to rest (T_i T̂_i⁻¹ of eq. 1) in mesh coordinates:
- `pose_from_faps(skeleton, values, fapu, params)`: FAP values through the rule table (`rules`);
- `pose_from_fps(skeleton, rest_fps, moved_fps, params)`: feature point motion (as the accuracy
  benchmark and the FP empties give it). A translating bone moves by the mean motion of the FPs it
  follows; the jaw turns about the line through its head along the face's x axis by the mean angle its
  FPs turn about it, then translates by what remains; an eye turns by the rotation that takes its pupil
  where it went. A child's own motion is what its FPs did beyond its parent's (unscaled) motion, so every
  gain enters linearly (training relies on this). The head bone stays at rest: in this add-on head turns
  go to the face object's rotation, so FP positions are head-relative.

The elastic layer moves each bone's head p̂ to p (eq. 4) by adding p − p̂ to its transform's translation.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..mpeg4.fapu import Fapu
from .elastic_layer import elastic_positions
from .parameters import Parameters
from .rules import RULES, Rule, fap_transforms
from .skeleton import EYE_BONES, Skeleton
from .transforms import about_point, aligning_axis_angle, apply, rotation_matrix, translation


def apply_elastic(skeleton: Skeleton, transforms: np.ndarray, pairs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(B, 4, 4) the first-pass transforms with each bone's head moved by the elastic layer.

    Eq. 3-4 run in the head (root) bone's frame, so that a head turn, which moves every bone rigidly,
    stretches nothing."""
    root = transforms[skeleton.parents.index(-1)]
    local = np.linalg.solve(root, transforms)  # root⁻¹ @ M_b
    moved = np.einsum("bij,bj->bi", local[:, :3, :3], skeleton.heads) + local[:, :3, 3]
    offset = elastic_positions(skeleton.heads, moved, pairs, weights) - moved
    out = transforms.copy()
    out[:, :3, 3] += offset @ root[:3, :3].T
    return out


def _jaw_angle(skeleton: Skeleton, b: int, rest: np.ndarray, moved: np.ndarray) -> float:
    axis = skeleton.axes[0]
    a = rest - skeleton.heads[b]
    m = moved - skeleton.heads[b]
    a -= np.outer(a @ axis, axis)
    m -= np.outer(m @ axis, axis)
    return float(np.mean(np.arctan2(np.cross(a, m) @ axis, np.einsum("kj,kj->k", a, m))))


def fp_transforms(
    skeleton: Skeleton,
    rest_fps: Mapping[str, np.ndarray],
    moved_fps: Mapping[str, np.ndarray],
    gains: np.ndarray | None = None,
) -> np.ndarray:
    """(B, 4, 4) first-pass transforms from FP motion; FPs absent from either mapping do not count."""
    n_bones = len(skeleton.bones)
    gains = np.ones(n_bones) if gains is None else np.asarray(gains, dtype=np.float64)
    plain = np.empty((n_bones, 4, 4))  # the motion at gain 1, which children measure themselves against
    out = np.empty((n_bones, 4, 4))
    for b, (bone, parent) in enumerate(zip(skeleton.bones, skeleton.parents, strict=True)):
        base_plain = np.eye(4) if parent < 0 else plain[parent]
        base = np.eye(4) if parent < 0 else out[parent]
        ids = [f for f in bone.follow if f in rest_fps and f in moved_fps]
        if bone.kind == "root" or not ids:
            plain[b], out[b] = base_plain, base
            continue
        rest = np.array([rest_fps[f] for f in ids], dtype=np.float64)
        moved = np.array([moved_fps[f] for f in ids], dtype=np.float64)
        carried = apply(base_plain, rest)
        if bone.name in EYE_BONES:
            pivot = apply(base_plain, skeleton.heads[b])
            axis, angle = aligning_axis_angle(carried[0] - pivot, moved[0] - pivot)
            own_plain = about_point(rotation_matrix(axis, angle), pivot)
            own = about_point(rotation_matrix(axis, gains[b] * angle), pivot)
        elif bone.kind == "rotate":
            pivot = apply(base_plain, skeleton.heads[b])
            angle = _jaw_angle(skeleton, b, carried, moved)
            turn = about_point(rotation_matrix(skeleton.axes[0], angle), pivot)
            rest_offset = np.mean(moved - apply(turn, carried), axis=0)
            own_plain = translation(rest_offset) @ turn
            own = translation(rest_offset) @ about_point(rotation_matrix(skeleton.axes[0], gains[b] * angle), pivot)
        else:
            offset = np.mean(moved - carried, axis=0)
            own_plain, own = translation(offset), translation(gains[b] * offset)
        plain[b] = own_plain @ base_plain
        out[b] = own @ base
    return out


def pose_from_fps(
    skeleton: Skeleton,
    rest_fps: Mapping[str, np.ndarray],
    moved_fps: Mapping[str, np.ndarray],
    params: Parameters,
) -> np.ndarray:
    """(B, 4, 4) bone transforms relative to rest, elastic layer included, from FP positions (FP id ->
    (3,) mesh coordinates) of the neutral and the posed face."""
    first = fp_transforms(skeleton, rest_fps, moved_fps, params.gain_array(skeleton))
    return apply_elastic(skeleton, first, *params.pair_arrays(skeleton))


def pose_from_faps(
    skeleton: Skeleton, values: np.ndarray, fapu: Fapu, params: Parameters, rules: tuple[Rule, ...] = RULES
) -> np.ndarray:
    """(B, 4, 4) bone transforms relative to rest, elastic layer included, from one frame of (68,) FAP
    values through the rule table."""
    first = fap_transforms(skeleton, values, fapu, params.gain_array(skeleton), rules)
    return apply_elastic(skeleton, first, *params.pair_arrays(skeleton))
