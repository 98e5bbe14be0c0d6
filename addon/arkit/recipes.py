"""ARKit's 52 face blendshapes and the recipe table that says each one in FAPs (data/recipes.json).

The loader checks the whole file before it returns: all 52 names exactly once each (as ARKit spells them),
a 'why' for each, known low-level FAPs with finite values within the standard's range, an optional
'cannot' (what FAPs cannot express), an optional dedicated deformation (deformations.py) by its name, and an
optional 'over': a shape earlier in ARKit's order (itself not made over another) whose weight-1 pose this one's key
is made on top of.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..mpeg4.fap_tables import TableReader
from ..mpeg4.faps import LEFT_RIGHT_PAIRS, N_FAPS
from . import ArkitError
from .deformations import FP_DEFORMATIONS, PART_DEFORMATIONS, SKIN_DEFORMATIONS

DATA = Path(__file__).resolve().with_name("data")
READ = TableReader(ArkitError)

# ARFaceAnchor.BlendShapeLocation, in the order Live Link Face writes them (its CSV columns, PascalCase there)
ARKIT_NAMES = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft", "eyeSquintLeft",
    "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "eyeLookUpRight",
    "eyeSquintRight", "eyeWideRight", "jawForward", "jawRight", "jawLeft", "jawOpen", "mouthClose",
    "mouthFunnel", "mouthPucker", "mouthRight", "mouthLeft", "mouthSmileLeft", "mouthSmileRight",
    "mouthFrownLeft", "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper",
    "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)  # fmt: skip
N_SHAPES = len(ARKIT_NAMES)
ARKIT_INDEX = MappingProxyType({name: k for k, name in enumerate(ARKIT_NAMES)})
# dedicated deformations a recipe may name, for what no FAP moves
DEDICATED_DEFORMATIONS = FP_DEFORMATIONS + SKIN_DEFORMATIONS + PART_DEFORMATIONS

# FAPs that a left/right mirror negates besides swapping the pairs: sideways motions of midline points,
# and the eyeballs' yaw (both eyes share one sign convention)
_MIRROR_NEGATED = (15, 23, 24, 64)


@dataclass(frozen=True, eq=False)
class RecipeTable:
    """`targets[i, k]` is FAP k+1 of ARKit shape i (ARKIT_NAMES order) at weight 1, in FAPU (AU for angles)."""

    targets: np.ndarray  # (52, 68) float64, read-only
    why: tuple[str, ...]
    cannot: MappingProxyType  # name -> what FAPs cannot express of it
    deformations: MappingProxyType  # name -> the dedicated deformation it names
    # name -> the shape its key is made over: the key is the change its FAPs make on that shape's pose at weight 1
    # (mouthClose over jawOpen: ARKit's lips closing "independent of jaw position", added to an open jaw)
    over: MappingProxyType

    @property
    def names(self) -> tuple[str, ...]:
        return ARKIT_NAMES

    def recipe(self, name: str) -> np.ndarray:
        return self.targets[ARKIT_INDEX[name]]


def mirror_faps(values: np.ndarray) -> np.ndarray:
    """FAP values (..., 68) of the left/right mirror image: the pairs swapped, sideways midline motions and eye
    yaw negated (the standard gives paired FAPs mirrored directions, so a pair swaps without a sign)."""
    out = np.array(values, dtype=np.float64)
    for left, right in LEFT_RIGHT_PAIRS:
        out[..., [left - 1, right - 1]] = out[..., [right - 1, left - 1]]
    out[..., [n - 1 for n in _MIRROR_NEGATED]] *= -1.0
    return out


def mirror_name(name: str) -> str:
    """The ARKit name of the mirrored shape (itself for the symmetric ones)."""
    for a, b in (("Left", "Right"), ("Right", "Left")):
        if name.endswith(a):
            return name[: -len(a)] + b
    return name


def _table(path) -> RecipeTable:
    source = str(path)
    doc = READ.object_with(READ.read_json(path, "ARKit recipe table"), {"about", "shapes"}, set(), source)
    entries = READ.list_of(doc["shapes"], f"{source}: shapes")
    targets = np.zeros((N_SHAPES, N_FAPS))
    why = [""] * N_SHAPES
    cannot, deformations, over = {}, {}, {}
    for k, entry in enumerate(entries):
        where = f"{source}: shapes entry {k + 1}"
        entry = READ.object_with(entry, {"name", "why", "faps"}, {"cannot", "deformation", "over"}, where)
        name = entry["name"]
        if name not in ARKIT_INDEX:
            raise ArkitError(f"{where}: {name!r} is not one of ARKit's 52 blendshape names")
        i = ARKIT_INDEX[name]
        if why[i]:
            raise ArkitError(f"{where}: {name} is listed twice")
        where = f"{source}: {name}"
        why[i] = READ.text(entry["why"], f"{where}: 'why'")
        if "cannot" in entry:
            cannot[name] = READ.text(entry["cannot"], f"{where}: 'cannot'")
        if "deformation" in entry:
            named = entry["deformation"]
            if named not in DEDICATED_DEFORMATIONS:
                raise ArkitError(f"{where}: deformation {named!r} is not one of {', '.join(DEDICATED_DEFORMATIONS)}")
            deformations[name] = named
        if "over" in entry:
            base = entry["over"]
            if ARKIT_INDEX.get(base, N_SHAPES) >= i:  # made before it, so its pose is there when this key is made
                raise ArkitError(f"{where}: 'over' {base!r} is not one of ARKit's names listed before {name}")
            over[name] = base
        for number, value in READ.fap_values(entry["faps"], where).items():
            targets[i, number - 1] = value
    missing = [name for name, text in zip(ARKIT_NAMES, why, strict=True) if not text]
    if missing:
        raise ArkitError(f"{source}: {len(missing)} ARKit shape(s) missing: {', '.join(missing)}")
    chained = sorted(name for name, base in over.items() if base in over)
    if chained:
        raise ArkitError(f"{source}: {', '.join(chained)}: 'over' names a shape that is itself made over another")
    targets.flags.writeable = False
    return RecipeTable(
        targets, tuple(why), MappingProxyType(cannot), MappingProxyType(deformations), MappingProxyType(over)
    )


def load_recipes(path: Path | str | None = None) -> RecipeTable:
    """The 52 recipes from `path`, or the bundled data/recipes.json (loaded once)."""
    return _default() if path is None else _table(path)


@functools.cache
def _default() -> RecipeTable:
    return _table(DATA / "recipes.json")
