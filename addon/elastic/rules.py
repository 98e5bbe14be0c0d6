"""FAP -> bone rules (paper 004, section 3.3, "a rule-system method is used to convert the FAPs into
transformations of the corresponding bones"), as a data table.

`Rule(fap, bone, motion, amount, axis)`:
- "translate": the bone moves by amount x value x FAPU along the FAP's own direction (`mpeg4.faps`).
  The amount is the bone's share of the FAP's feature point: 1 / (number of FPs the bone follows), so
  that driving the engine by FAPs and by the FPs those FAPs move (`pose.fp_transforms`) agree.
- "rotate": the bone turns about its head, about the face axis `axis` ("x" left, "y" up, "z" forward).
  Angular FAPs (AU) turn by amount x value x AU. open_jaw is a distance (MNS) in the standard; here it
  turns the jaw by the arc that moves the chin by that distance: angle = amount x value x MNS / jaw length.
  A bone's rotations compose as R_y @ R_x @ R_z (yaw outermost, roll innermost), as `mpeg4.decode` turns
  the head and the eyeballs.

open_jaw carries the jaw's children (chin, lower lip bones); the lip corners are children of the head, so
they do not take the half jaw motion `mpeg4.decode.JAW_RIDERS` gives their FPs.

FAPs without a rule: 1-2 (high level; expanded to low-level FAPs before this), 29-30 (pupil size moves
no bone), 43-47 (tongue: the tongue object rides the jaw bone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mpeg4.faps import N_FAPS, fap
from ..mpeg4.fapu import Fapu
from .errors import RuleTableError
from .skeleton import Skeleton
from .transforms import about_point, rotation_matrix, translation

MOTIONS = ("translate", "rotate")
FACE_AXES = {"x": 0, "y": 1, "z": 2}
ROTATION_ORDER = ("y", "x", "z")  # R = R_y @ R_x @ R_z


@dataclass(frozen=True)
class Rule:
    fap: int
    bone: str
    motion: str
    amount: float = 1.0
    axis: str | None = None  # face axis of a rotation


def _t(fap_number, bone, amount=1.0):
    return Rule(fap_number, bone, "translate", amount)


def _r(fap_number, bone, axis):
    return Rule(fap_number, bone, "rotate", 1.0, axis)


def _both(fap_left, bone_left, amount=1.0):
    """The rule for a left FAP and the one for its right partner (the next FAP number)."""
    return _t(fap_left, bone_left, amount), _t(fap_left + 1, bone_left[:-2] + "_r", amount)


RULES: tuple[Rule, ...] = (
    _r(3, "jaw", "x"),  # open_jaw: the arc of the chin (see the module docstring)
    _t(14, "jaw"),  # thrust_jaw
    _t(15, "jaw"),  # shift_jaw
    _t(4, "upper_lip", 0.5),
    _t(51, "upper_lip", 0.5),
    _t(5, "lower_lip", 0.5),
    _t(52, "lower_lip", 0.5),
    _t(17, "upper_lip", 0.5),  # push_t_lip
    _t(16, "lower_lip", 0.5),  # push_b_lip
    *_both(6, "lip_corner_l", 0.5),  # stretch cornerlip, inner
    *_both(53, "lip_corner_l", 0.5),  # and outer contour
    *_both(12, "lip_corner_l", 0.5),  # raise cornerlip
    *_both(59, "lip_corner_l", 0.5),
    *_both(8, "upper_lip_l", 0.5),
    *_both(55, "upper_lip_l", 0.5),
    *_both(10, "lower_lip_l", 0.5),
    *_both(57, "lower_lip_l", 0.5),
    _t(18, "chin"),  # depress_chin
    *_both(19, "upper_lid_l"),
    *_both(21, "lower_lid_l"),
    _r(23, "eye_l", "y"),
    _r(24, "eye_r", "y"),
    _r(25, "eye_l", "x"),
    _r(26, "eye_r", "x"),
    *_both(27, "eye_l"),  # thrust eyeball
    *_both(31, "brow_inner_l"),
    *_both(33, "brow_mid_l"),
    *_both(35, "brow_outer_l"),
    *_both(37, "brow_inner_l"),  # squeeze eyebrow
    *_both(39, "cheek_l"),  # puff cheek
    *_both(41, "cheekbone_l"),  # lift cheek
    _r(48, "head", "x"),
    _r(49, "head", "y"),
    _r(50, "head", "z"),
    *_both(61, "nostril_l"),
    _t(63, "nose"),
    _t(64, "nose"),
    *_both(65, "ear_l", 0.5),  # raise ear (10.1)
    *_both(67, "ear_l", 0.5),  # pull ear (10.3)
)


def check_rules(rules: tuple[Rule, ...], bone_names: tuple[str, ...]) -> None:
    """Raise RuleTableError naming every rule with an unknown FAP, bone, motion or axis."""
    problems = []
    for k, rule in enumerate(rules):
        where = f"rule {k} (FAP {rule.fap} -> {rule.bone!r})"
        try:
            spec = fap(rule.fap)
        except (KeyError, TypeError):
            problems.append(f"{where}: unknown FAP {rule.fap!r} (FAPs are 1..{N_FAPS})")
            continue
        if spec.fapu is None:
            problems.append(f"{where}: FAP {spec.number} ({spec.name}) is high level and moves no bone")
        if rule.bone not in bone_names:
            problems.append(f"{where}: unknown bone {rule.bone!r}")
        if rule.motion not in MOTIONS:
            problems.append(f"{where}: unknown motion {rule.motion!r}")
        elif rule.motion == "rotate" and rule.axis not in FACE_AXES:
            problems.append(f"{where}: a rotation needs an axis x, y or z, got {rule.axis!r}")
        elif rule.motion == "translate" and spec.axis is None:
            problems.append(f"{where}: FAP {spec.number} ({spec.name}) has no direction to translate along")
        if not np.isfinite(rule.amount):
            problems.append(f"{where}: amount {rule.amount!r} is not finite")
    if problems:
        raise RuleTableError("bad FAP -> bone rule table: " + "; ".join(problems))


def fap_transforms(
    skeleton: Skeleton,
    values: np.ndarray,
    fapu: Fapu,
    gains: np.ndarray | None = None,
    rules: tuple[Rule, ...] = RULES,
) -> np.ndarray:
    """(B, 4, 4) first-pass bone transforms relative to rest (before the elastic layer) for one frame of
    (68,) FAP values (0 = neutral). `gains` (B,) scale each bone's translation or rotation angles.

    A child follows its parent (the lower lip and chin ride the jaw, everything rides the head):
    M_b = M_parent @ L_b, with L_b the bone's own motion in rest coordinates, rotation about its head
    first and then its translation.
    """
    check_rules(rules, skeleton.names)
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    if values.shape != (N_FAPS,):
        raise RuleTableError(f"FAP values must be one frame of {N_FAPS}, got {values.shape}")
    n_bones = len(skeleton.bones)
    gains = np.ones(n_bones) if gains is None else np.asarray(gains, dtype=np.float64)
    offsets = np.zeros((n_bones, 3))
    angles = np.zeros((n_bones, 3))
    for rule in rules:
        value = values[rule.fap - 1]
        if value == 0.0:
            continue
        spec = fap(rule.fap)
        b = skeleton.index(rule.bone)
        if rule.motion == "translate":
            offsets[b] += rule.amount * value * fapu.unit(spec.fapu) * (np.asarray(spec.axis) @ skeleton.axes)
        elif spec.is_rotation:
            angles[b, FACE_AXES[rule.axis]] += rule.amount * value * fapu.unit("AU")
        else:
            length = np.linalg.norm(skeleton.tails[b] - skeleton.heads[b])
            angles[b, FACE_AXES[rule.axis]] += rule.amount * value * fapu.unit(spec.fapu) / length
    out = np.empty((n_bones, 4, 4))
    for b, parent in enumerate(skeleton.parents):
        rot = np.eye(3)
        for name in ROTATION_ORDER:
            k = FACE_AXES[name]
            rot = rot @ rotation_matrix(skeleton.axes[k], gains[b] * angles[b, k])
        own = translation(gains[b] * offsets[b]) @ about_point(rot, skeleton.heads[b])
        out[b] = own if parent < 0 else out[parent] @ own
    return out
