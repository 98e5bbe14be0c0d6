"""The reduced MPEG-4 face skeleton as data, and its placement on the feature points of a set-up face.

Paper 004 (section 3.3) starts from the MPEG-4 skeleton and replaces sets of bones by one bone, "mainly
in the lips, ears, nose and jaw"; its figure 2 is not reproducible from the text, so the table below is
our reading: each lip bone merges the inner and outer contour points at one place along the mouth (its
head on the inner contour, its tail on the outer), each ear is one bone, the nose one bone from the bump
to the tip plus a bone per nostril wing, the jaw one rotating bone hinged on the line through the jaw
corners 2.13/2.14 (the jaw joint itself has no FP). Eyes and
jaw rotate; the head bone (7.1 -> 11.4) is the root and carries the head FAPs 48-50. The temples have no
FP: only the elastic layer moves them (the paper's "cheeks and temples").

`Bone` fields:
- `head`, `tail`: the FPs whose mean places the bone's head and tail; an empty tail is a short stub
  pointing out of the face (STUB_FRACTION of the skeleton's scale), for bones placed by one point.
- `follow`: the FPs whose motion moves the bone when the engine is driven by FP motion (`pose`).
- `neighbours`: the bones whose motion pulls or pushes this one through the elastic layer (eq. 3-4).
- `kind`: "root" (head), "rotate" (jaw, eyes) or "translate".
- `side`: the opening side the bone sits on; that side's mask (as Planar Bones uses it) limits its weights.
- `skinned`: False for the eyes, which move their eyeball objects, not the skin.
- `skin`: a polyline of FPs from which the bone's skin weights fall off, where its head-tail segment
  lies inside the head (the jaw: along the jaw line, 2.13-2.11-2.1-2.12-2.14).
- `reach`: the bone's skin falloff radius relative to the others' (the temples and ears cover more, the
  jaw most: from the jaw line up to the lower lip, so that the lower face turns with it as one piece).

`place_skeleton(fp_positions)` -> `Skeleton` (names, parents, (B, 3) heads and tails) is the API the
Blender side builds its armature from.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.decode import EYEBALL_RADIUS_PER_ES0
from ..mpeg4.feature_points import FP_IDS, feature_point
from .errors import MissingFeaturePointsError, RuleTableError

KINDS = ("root", "rotate", "translate")
SIDES = ("upper_lip", "lower_lip", "upper_eyelid", "lower_eyelid")
STUB_FRACTION = 0.1  # length of a one-point bone, per skeleton scale (~1 cm on an adult face)
SCALE_FPS = ("3.7", "3.12")  # the skeleton's scale: distance between the outer eye corners


@dataclass(frozen=True)
class Bone:
    name: str
    head: tuple[str, ...]
    tail: tuple[str, ...]
    parent: str | None
    follow: tuple[str, ...] = ()
    neighbours: tuple[str, ...] = ()
    kind: str = "translate"
    side: str | None = None
    skinned: bool = True
    mirror: str | None = None
    skin: tuple[str, ...] = ()  # a polyline of FPs the skin distance starts from, instead of head-tail
    reach: float = 1.0  # the skin falloff radius, in units of `skinning.RADIUS_PER_SCALE`


def _mirror_name(name: str) -> str:
    return name[:-2] + {"_l": "_r", "_r": "_l"}[name[-2:]]


def _mirror_fp(fp_id: str) -> str:
    return feature_point(fp_id).mirror or fp_id


def _pair(bone: Bone) -> tuple[Bone, Bone]:
    """A left bone and its mirror image (names `_l` -> `_r`, FPs -> their mirror partners)."""

    def name(n):
        return _mirror_name(n) if n and n[-2:] in ("_l", "_r") else n

    right = Bone(
        name(bone.name),
        tuple(map(_mirror_fp, bone.head)),
        tuple(map(_mirror_fp, bone.tail)),
        name(bone.parent),
        tuple(map(_mirror_fp, bone.follow)),
        tuple(map(name, bone.neighbours)),
        bone.kind,
        bone.side,
        bone.skinned,
        bone.name,
        tuple(map(_mirror_fp, bone.skin)),
        bone.reach,
    )
    left = Bone(**{**bone.__dict__, "mirror": right.name})
    return left, right


_LEFT_AND_MID = (
    Bone("head", ("7.1",), ("11.4",), None, kind="root"),
    Bone(
        "jaw",
        ("2.13", "2.14"),
        ("2.1",),
        "head",
        ("2.1", "2.10", "2.11", "2.12"),
        kind="rotate",
        skin=("2.13", "2.11", "2.1", "2.12", "2.14"),
        reach=2.5,  # the whole lower face, up to the lower lip, turns with the jaw
    ),  # fmt: skip
    Bone("chin", ("2.10",), (), "jaw", ("2.10",), ("lower_lip",)),
    Bone("upper_lip", ("2.2",), ("8.1",), "head", ("2.2", "8.1"), side="upper_lip"),
    Bone("upper_lip_l", ("2.6",), ("8.5",), "head", ("2.6", "8.5"), side="upper_lip"),
    Bone("lower_lip", ("2.3",), ("8.2",), "jaw", ("2.3", "8.2"), side="lower_lip"),
    Bone("lower_lip_l", ("2.8",), ("8.7",), "jaw", ("2.8", "8.7"), side="lower_lip"),
    Bone("lip_corner_l", ("2.4",), ("8.3",), "head", ("2.4", "8.3")),
    Bone("nose", ("9.12",), ("9.3",), "head", ("9.3",)),
    Bone("nostril_l", ("9.1",), (), "nose", ("9.1",), ("upper_lip_l", "cheek_l")),
    Bone("cheek_l", ("5.1",), (), "head", ("5.1",), ("lip_corner_l", "upper_lip_l", "lower_lip_l")),
    Bone("cheekbone_l", ("5.3",), (), "head", ("5.3",), ("cheek_l", "lip_corner_l", "lower_lid_l")),
    Bone("temple_l", ("4.5", "10.1"), (), "head", (), ("brow_outer_l", "cheekbone_l", "lip_corner_l"), reach=1.5),
    Bone("brow_inner_l", ("4.1",), (), "head", ("4.1",), ("brow_mid_l",)),
    Bone("brow_mid_l", ("4.3",), (), "head", ("4.3",), ("brow_inner_l", "brow_outer_l")),
    Bone("brow_outer_l", ("4.5",), (), "head", ("4.5",), ("brow_mid_l",)),
    Bone("upper_lid_l", ("3.1",), (), "head", ("3.1",), side="upper_eyelid"),
    Bone("lower_lid_l", ("3.3",), (), "head", ("3.3",), ("cheekbone_l",), side="lower_eyelid"),
    Bone("eye_l", ("3.5",), ("3.5",), "head", ("3.5",), kind="rotate", skinned=False),
    Bone("ear_l", ("10.1", "10.3"), ("10.9",), "head", ("10.1", "10.3"), reach=1.5),
)


def _expand(bones) -> tuple[Bone, ...]:
    out = []
    for bone in bones:
        out.extend(_pair(bone) if bone.name.endswith("_l") else (bone,))
    return tuple(out)


BONES: tuple[Bone, ...] = _expand(_LEFT_AND_MID)
EYE_BONES = ("eye_l", "eye_r")  # the head sits at the eyeball centre behind the pupil (head FP)
# the lip bones along each lip, corner to corner: their heads trace the inner lip contour (FPs 2.x), their
# tails the outer one (8.x); the mouth's lining behind the lower line follows the jaw (`skinning`)
LIP_LINES = (
    ("lip_corner_r", "upper_lip_r", "upper_lip", "upper_lip_l", "lip_corner_l"),
    ("lip_corner_r", "lower_lip_r", "lower_lip", "lower_lip_l", "lip_corner_l"),
)
JAW = "jaw"


def check_bone_table(bones: tuple[Bone, ...] = BONES) -> None:
    """Raise RuleTableError naming every row that names an unknown FP, bone, kind or side."""
    names = [b.name for b in bones]
    problems = [f"bone {n!r} is listed twice" for n in sorted({n for n in names if names.count(n) > 1})]
    known_fps = set(FP_IDS)
    for b in bones:
        for field in ("head", "tail", "follow", "skin"):
            problems += [
                f"bone {b.name!r} {field} names unknown FP {f!r}" for f in getattr(b, field) if f not in known_fps
            ]
        for other in (b.parent, *b.neighbours, b.mirror):
            if other is not None and other not in names:
                problems.append(f"bone {b.name!r} names unknown bone {other!r}")
        if b.parent in names and names.index(b.parent) > names.index(b.name):
            problems.append(f"bone {b.name!r} comes before its parent {b.parent!r}")
        if b.kind not in KINDS:
            problems.append(f"bone {b.name!r} has unknown kind {b.kind!r}")
        if b.side is not None and b.side not in SIDES:
            problems.append(f"bone {b.name!r} has unknown side {b.side!r}")
        if not b.head:
            problems.append(f"bone {b.name!r} has no head FP")
    if problems:
        raise RuleTableError("bad bone table: " + "; ".join(problems))


@dataclass(frozen=True)
class Skeleton:
    """A placed skeleton in mesh coordinates; row b of every array is `bones[b]`."""

    bones: tuple[Bone, ...]
    heads: np.ndarray  # (B, 3) rest head positions (the bone positions of eq. 3-4)
    tails: np.ndarray  # (B, 3)
    scale: float  # distance between the outer eye corners
    axes: np.ndarray  # (3, 3) face frame rows x (left), y (up), z (forward) in mesh coordinates
    skin_paths: tuple[np.ndarray, ...] = ()  # per bone, (S, 2, 3) segments its skin distance starts from

    def skin_segments(self, b: int) -> np.ndarray:
        """(S, 2, 3) the segments bone b's skin weights fall off from: its `skin` polyline or head-tail."""
        if self.skin_paths and len(self.skin_paths[b]):
            return self.skin_paths[b]
        return np.stack([self.heads[b], self.tails[b]])[None]

    @cached_property  # read every frame: built once per skeleton
    def names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.bones)

    @cached_property
    def rows(self) -> dict[str, int]:
        """Bone name -> row."""
        return {name: i for i, name in enumerate(self.names)}

    @cached_property
    def parents(self) -> tuple[int, ...]:
        """Row of each bone's parent, -1 for the root."""
        return tuple(self.rows[b.parent] if b.parent else -1 for b in self.bones)

    def index(self, name: str) -> int:
        try:
            return self.rows[name]
        except KeyError:
            raise RuleTableError(f"unknown bone {name!r}") from None


def place_skeleton(
    fp_positions: Mapping[str, np.ndarray], axes: np.ndarray = BLENDER_FACE_AXES, bones: tuple[Bone, ...] = BONES
) -> Skeleton:
    """Bone heads and tails from the FP positions of a set-up face (FP id -> (3,) mesh coordinates).

    Checks the table and every FP first; raises MissingFeaturePointsError naming each bone that lacks
    FPs (and which), so nothing is built from a partial skeleton.
    """
    check_bone_table(bones)
    axes = np.asarray(axes, dtype=np.float64)
    points = {}
    for fp_id, p in fp_positions.items():
        p = np.asarray(p, dtype=np.float64)
        if p.shape == (3,) and np.all(np.isfinite(p)):
            points[fp_id] = p
    problems = []
    for b in bones:
        needed = (*b.head, *b.tail, *b.skin) + (("3.5", "3.6") if b.name in EYE_BONES else ())
        missing = [f for f in dict.fromkeys(needed) if f not in points]
        if missing:
            problems.append(f"bone {b.name!r} needs FP {', '.join(missing)}")
    missing_scale = [f for f in SCALE_FPS if f not in points]
    if missing_scale:
        problems.append(f"the skeleton's scale needs FP {', '.join(missing_scale)}")
    if problems:
        raise MissingFeaturePointsError("cannot place the elastic-bones skeleton: " + "; ".join(problems))

    scale = float(np.linalg.norm(points[SCALE_FPS[0]] - points[SCALE_FPS[1]]))
    if not scale > 0.0:
        raise MissingFeaturePointsError(f"FP {SCALE_FPS[0]} and {SCALE_FPS[1]} coincide: the face has no size")
    forward = axes[2]
    es0 = abs(float(axes[0] @ (points["3.5"] - points["3.6"]))) if "3.5" in points and "3.6" in points else 0.0
    heads, tails = [], []
    for b in bones:
        head = np.mean([points[f] for f in b.head], axis=0)
        if b.name in EYE_BONES:
            # the eyeball centre, as `mpeg4.decode.eye_centres` places it by default; the tail is the pupil
            head = head - EYEBALL_RADIUS_PER_ES0 * es0 * forward
        tail = np.mean([points[f] for f in b.tail], axis=0) if b.tail else head + STUB_FRACTION * scale * forward
        if np.linalg.norm(tail - head) < 1e-9 * scale:
            tail = head + STUB_FRACTION * scale * forward
        heads.append(head)
        tails.append(tail)
    paths = []
    for b in bones:
        line = np.array([points[f] for f in b.skin]).reshape(-1, 3)
        paths.append(np.stack([line[:-1], line[1:]], axis=1))
    return Skeleton(bones, np.array(heads), np.array(tails), scale, axes, tuple(paths))
