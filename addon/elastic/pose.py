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
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..mpeg4.fapu import Fapu
from .armature_space import rigid_inverse
from .elastic_layer import elastic_positions
from .parameters import Parameters
from .rules import RULES, Rule, fap_transforms
from .skeleton import EYE_BONES, Bone, Skeleton
from .transforms import rotation_matrices


def apply_elastic(skeleton: Skeleton, transforms: np.ndarray, pairs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(B, 4, 4) the first-pass transforms with each bone's head moved by the elastic layer.

    Eq. 3-4 run in the head (root) bone's frame, so that a head turn, which moves every bone rigidly,
    stretches nothing."""
    root = transforms[skeleton.parents.index(-1)]
    local = rigid_inverse(root) @ transforms  # root⁻¹ @ M_b
    moved = np.einsum("bij,bj->bi", local[:, :3, :3], skeleton.heads) + local[:, :3, 3]
    offset = elastic_positions(skeleton.heads, moved, pairs, weights) - moved
    out = transforms.copy()
    out[:, :3, 3] += offset @ root[:3, :3].T
    return out


@dataclass(frozen=True)
class _Level:
    """The bones at one depth of the tree and the (bone, followed FP) rows that move them."""

    bones: np.ndarray  # (S,) bone rows
    row_bone: np.ndarray  # (R,) index into `bones` of each row
    row_fp: np.ndarray  # (R,) index into the plan's FP ids of each row
    first_row: np.ndarray  # (S,) each bone's first row (an eye turns to its first FP, the pupil)
    count: np.ndarray  # (S,) rows per bone, 0 for a bone that stays with its parent
    eye: np.ndarray  # (S,) bool
    hinge: np.ndarray  # (S,) bool, a rotating bone that is not an eye (the jaw)


@lru_cache(maxsize=16)
def _plan(bones: tuple[Bone, ...], fp_ids: tuple[str, ...]) -> tuple[_Level, ...]:
    """Per depth of the tree, parents first, the bones and the rows of the FPs in `fp_ids` they follow."""
    index = {b.name: i for i, b in enumerate(bones)}
    depth = []
    for bone in bones:
        depth.append(0 if bone.parent is None else depth[index[bone.parent]] + 1)
    column = {f: k for k, f in enumerate(fp_ids)}
    levels = []
    for d in range(max(depth) + 1):
        members = [b for b in range(len(bones)) if depth[b] == d]
        rows = [
            (s, column[f])
            for s, b in enumerate(members)
            if bones[b].kind != "root"
            for f in bones[b].follow
            if f in column
        ]
        row_bone = np.array([r[0] for r in rows], dtype=np.intp)
        count = np.bincount(row_bone, minlength=len(members))
        levels.append(
            _Level(
                np.array(members, dtype=np.intp),
                row_bone,
                np.array([r[1] for r in rows], dtype=np.intp),
                np.cumsum(count) - count,
                count,
                np.array([bones[b].name in EYE_BONES for b in members]),
                np.array([bones[b].kind == "rotate" and bones[b].name not in EYE_BONES for b in members]),
            )
        )
    return tuple(levels)


@lru_cache(maxsize=16)
def _followed(bones: tuple[Bone, ...]) -> tuple[str, ...]:
    return tuple(sorted({f for b in bones for f in b.follow}))


def _rigid(rotations: np.ndarray, pivots: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(S, 4, 4) translation(offset) @ the rotation about pivot, per row."""
    out = np.zeros((len(rotations), 4, 4))
    out[:, :3, :3] = rotations
    out[:, :3, 3] = offsets + pivots - np.einsum("sij,sj->si", rotations, pivots)
    out[:, 3, 3] = 1.0
    return out


def fp_transforms(
    skeleton: Skeleton,
    rest_fps: Mapping[str, np.ndarray],
    moved_fps: Mapping[str, np.ndarray],
    gains: np.ndarray | None = None,
) -> np.ndarray:
    """(B, 4, 4) first-pass transforms from FP motion; FPs absent from either mapping do not count.

    One depth of the tree at a time, every bone of it at once: a bone's FPs are first carried by its
    parent's motion at gain 1 (`plain`, what a child measures its own motion against), then
    - a translating bone moves by the mean of what remains;
    - the jaw turns about the x axis through its (carried) head by the mean angle its FPs turned about
      it, then translates by the mean of what the turn leaves;
    - an eye turns about its (carried) head by the smallest rotation that takes its pupil where it went.
    The gain scales the translation of a translating bone and the angle of a rotating one."""
    n_bones = len(skeleton.bones)
    gains = np.ones(n_bones) if gains is None else np.asarray(gains, dtype=np.float64)
    fp_ids = tuple(f for f in _followed(skeleton.bones) if f in rest_fps and f in moved_fps)
    rest = np.array([rest_fps[f] for f in fp_ids], dtype=np.float64).reshape(-1, 3)
    moved = np.array([moved_fps[f] for f in fp_ids], dtype=np.float64).reshape(-1, 3)
    parents = np.array(skeleton.parents, dtype=np.intp)
    x_axis = skeleton.axes[0]
    plain = np.empty((n_bones, 4, 4))  # the motion at gain 1, which children measure themselves against
    out = np.empty((n_bones, 4, 4))
    for level in _plan(skeleton.bones, fp_ids):
        b, rows = level.bones, level.row_bone
        base_plain = np.where((parents[b] < 0)[:, None, None], np.eye(4), plain[parents[b]])
        base = np.where((parents[b] < 0)[:, None, None], np.eye(4), out[parents[b]])
        if not len(rows):  # the root, or bones none of whose FPs are given: they stay with their parents
            plain[b], out[b] = base_plain, base
            continue
        carried = np.einsum("rij,rj->ri", base_plain[rows, :3, :3], rest[level.row_fp]) + base_plain[rows, :3, 3]
        target = moved[level.row_fp]
        pivot = np.einsum("sij,sj->si", base_plain[:, :3, :3], skeleton.heads[b]) + base_plain[:, :3, 3]
        count = np.maximum(level.count, 1)

        # the jaw: each FP's turn about the x axis through the pivot, averaged
        a = carried - pivot[rows]
        m = target - pivot[rows]
        a -= np.outer(a @ x_axis, x_axis)
        m -= np.outer(m @ x_axis, x_axis)
        turn = np.arctan2(np.cross(a, m) @ x_axis, np.einsum("rj,rj->r", a, m))
        hinge_angle = np.bincount(rows, turn, len(b)) / count
        # an eye: the pupil (first FP) turned from where its parent carried it to where it went
        eyes = np.flatnonzero(level.eye & (level.count > 0))
        first = level.first_row[eyes]
        u = carried[first] - pivot[eyes]
        v = target[first] - pivot[eyes]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        normal = np.cross(u, v)
        sin = np.linalg.norm(normal, axis=1)
        turns = sin >= 1e-12  # parallel: no turn (an antiparallel pupil is not a pose an eye takes)
        axis = np.tile(x_axis, (len(b), 1))
        angle = np.zeros(len(b))
        axis[eyes[turns]] = normal[turns] / sin[turns, None]
        angle[eyes[turns]] = np.arctan2(sin[turns], np.einsum("sj,sj->s", u, v)[turns])
        angle = np.where(level.hinge, hinge_angle, angle)

        rotation = rotation_matrices(axis, angle)
        turned = np.einsum("rij,rj->ri", rotation[rows], carried - pivot[rows]) + pivot[rows]
        rest_offset = np.stack([np.bincount(rows, (target - turned)[:, k], len(b)) for k in range(3)], 1)
        rest_offset /= count[:, None]
        rest_offset[level.eye] = 0.0
        translates = ~level.eye & ~level.hinge
        gain = gains[b]
        own_plain = _rigid(rotation, pivot, rest_offset)
        own_offset = np.where(translates[:, None], gain[:, None], 1.0) * rest_offset  # a rotation's gain is its angle's
        own = _rigid(rotation_matrices(axis, gain * angle), pivot, own_offset)
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
