"""FACS's appearance changes as direction checks on the ARKit shape keys: a development check made from the action
units' descriptions, not from any sculpt.

The MakeHuman expression units (`evaluate_arkit --makehuman-units`) are local sculpts: each moves the skin of its
own region and keeps the rest still, so they cannot say whether a key should move skin beside that region (the
cheeks, the chin boss, the nostril's wing), which is where the check set's error lies. FACS describes each action
unit by the appearance changes it makes (Ekman, Friesen and Hager 2002, *Facial Action Coding System*; the same
descriptions in Ekman and Friesen 1978), including the skin around the moving feature. `RULES` writes down, for
the ARKit shapes that correspond to an action unit, the changes the description names at a place MPEG-4 has a
feature point for, as a direction at that point: up, down, forward, back, out (away from the mid-line), in. A key
passes a rule when the skin vertex nearest that point at rest moves over `MIN_MOVE` in that direction. The rules
give directions only: FACS gives no sizes (intensity A-E is scored by appearance), so they say which skin a key
should move, never how far.

Places with no feature point of their own are the mean of the points named (`PLACES`): the infraorbital triangle
(FACS: the skin below the lower lid, bounded by the nose's side and the nasolabial furrow: the lower lid 3.3, the
nostril's border 9.1 and the cheek bone 5.3) and the skin just beyond the lip corner (the corner 8.3 and the
cheek's centre 5.1). Rules are written for the face's left side; the Right shapes are checked by their mirror.
"""

from __future__ import annotations

import numpy as np

from addon.mpeg4.feature_points import feature_point

MIN_MOVE = 0.0005  # metres: half a millimetre in the named direction
# Blender's head frame: +x the face's left, -y forward, +z up
DIRECTIONS = {
    "up": (0.0, 0.0, 1.0),
    "down": (0.0, 0.0, -1.0),
    "forward": (0.0, -1.0, 0.0),
    "back": (0.0, 1.0, 0.0),
    "out": (1.0, 0.0, 0.0),  # the face's left; mirrored for the right side
    "in": (-1.0, 0.0, 0.0),
}
PLACES = {
    "infraorbital triangle": ("3.3", "9.1", "5.3"),
    "skin beyond the corner": ("8.3", "5.1"),
}
# (ARKit shape, place (an FP or a `PLACES` name), direction, the description's words (action unit))
RULES = (
    ("eyeBlinkLeft", "3.1", "down", "AU 45 blink: the upper lid lowers over the eye"),
    ("eyeWideLeft", "3.1", "up", "AU 5 upper lid raiser: the upper lid is raised"),
    ("eyeSquintLeft", "3.3", "up", "AU 7 lid tightener: the lower lid is raised and straightened"),
    ("eyeLookUpLeft", "3.1", "up", "AU 63 eyes up: the upper lid follows the eye up"),
    ("eyeLookDownLeft", "3.1", "down", "AU 64 eyes down: the upper lid follows the eye down"),
    ("browInnerUp", "4.1", "up", "AU 1 inner brow raiser: the inner corner of the brow is raised"),
    ("browOuterUpLeft", "4.5", "up", "AU 2 outer brow raiser: the outer part of the brow is raised"),
    ("browDownLeft", "4.1", "down", "AU 4 brow lowerer: the brow is lowered"),
    ("browDownLeft", "4.1", "in", "AU 4: the brows are pulled together"),
    ("cheekSquintLeft", "5.3", "up", "AU 6 cheek raiser: the cheek is lifted"),
    ("noseSneerLeft", "9.1", "up", "AU 9 nose wrinkler: the nostril's wings are raised"),
    ("noseSneerLeft", "infraorbital triangle", "up", "AU 9: the infraorbital triangle is pulled up"),
    ("noseSneerLeft", "8.5", "up", "AU 9: the upper lip is drawn up"),
    ("mouthUpperUpLeft", "8.5", "up", "AU 10 upper lip raiser: the upper lip is raised"),
    ("mouthUpperUpLeft", "9.1", "up", "AU 10: the nostril's wings are widened and raised"),
    ("mouthUpperUpLeft", "infraorbital triangle", "up", "AU 10: the infraorbital triangle is pushed up"),
    ("mouthSmileLeft", "8.3", "up", "AU 12 lip corner puller: the corner is pulled up"),
    ("mouthSmileLeft", "8.3", "out", "AU 12: and back obliquely, outward"),
    ("mouthSmileLeft", "infraorbital triangle", "up", "AU 12: the infraorbital triangle is raised"),
    ("mouthSmileLeft", "5.1", "up", "AU 12, strong: the cheek is raised"),
    ("mouthDimpleLeft", "8.3", "back", "AU 14 dimpler: the corner is tightened inward"),
    ("mouthDimpleLeft", "skin beyond the corner", "back", "AU 14: a dimple beyond the corner"),
    ("mouthFrownLeft", "8.3", "down", "AU 15 lip corner depressor: the corner is pulled down"),
    ("mouthLowerDownLeft", "8.7", "down", "AU 16 lower lip depressor: the lower lip is pulled down"),
    ("mouthShrugLower", "2.10", "up", "AU 17 chin raiser: the chin boss is pushed up"),
    ("mouthShrugLower", "8.2", "up", "AU 17: the lower lip is pushed up"),
    ("mouthPucker", "8.1", "forward", "AU 18 lip pucker: the lips are pushed forward"),
    ("mouthPucker", "8.3", "in", "AU 18: the corners are drawn in"),
    ("mouthStretchLeft", "8.3", "out", "AU 20 lip stretcher: the corner is pulled out"),
    ("mouthStretchLeft", "skin beyond the corner", "out", "AU 20: the skin beyond the corner is stretched out"),
    ("mouthFunnel", "8.1", "forward", "AU 22 lip funneler: the lips funnel outward"),
    ("mouthFunnel", "8.2", "forward", "AU 22: both lips"),
    ("mouthPressLeft", "8.7", "up", "AU 24 lip presser: the lips are pressed together, the lower lip up"),
    ("jawOpen", "2.1", "down", "AU 26 / 27 jaw drop: the mandible lowers"),
    ("jawOpen", "2.10", "down", "AU 26 / 27: the chin boss goes down with it"),
    ("mouthRollLower", "8.2", "back", "AU 28 lip suck: the lip is drawn in"),
    ("jawForward", "2.1", "forward", "AD 29 jaw thrust: the jaw is pushed forward"),
    ("jawLeft", "2.1", "out", "AD 30 jaw sideways: the jaw moves to the side"),
    ("cheekPuff", "5.1", "out", "AD 34 puff: the cheeks expand outward"),
)


def mirrored(shape: str) -> str | None:
    return shape.replace("Left", "Right") if shape.endswith("Left") else None


def _side(fp_id: str, right: bool) -> str:
    mirror = feature_point(fp_id).mirror
    return mirror if right and mirror else fp_id


def place_rest(place: str, fp_rest: dict[str, np.ndarray], right: bool) -> np.ndarray | None:
    """The rest position of a rule's place on one side: its FP, or the mean of the FPs `PLACES` names."""
    fps = [_side(fp_id, right) for fp_id in PLACES.get(place, (place,))]
    points = [fp_rest.get(fp_id) for fp_id in fps]
    if any(p is None or not np.all(np.isfinite(p)) for p in points):
        return None
    return np.mean(points, axis=0)


def check(keys: dict[str, np.ndarray], rest: np.ndarray, fp_rest: dict[str, np.ndarray]) -> list[dict]:
    """Every rule (and the mirror of every Left one) on (N, 3) key offsets over (N, 3) `rest` vertices: the motion
    of the vertex nearest the place at rest along the rule's direction, and whether it passes."""
    out = []
    for shape, place, direction, why in RULES:
        sides = [(shape, False)]
        if mirrored(shape):
            sides.append((mirrored(shape), True))
        for name, right in sides:
            if name not in keys:
                continue
            at = place_rest(place, fp_rest, right)
            if at is None:
                continue
            vertex = int(np.argmin(np.linalg.norm(rest - at, axis=1)))
            unit = np.array(DIRECTIONS[direction])
            if right:
                unit[0] = -unit[0]
            along = float(keys[name][vertex] @ unit)
            out.append({"shape": name, "place": place, "direction": direction, "why": why, "mm": 1e3 * along})
            out[-1]["passes"] = along > MIN_MOVE
    return out


def print_checks(rows: list[dict]) -> None:
    failed = [r for r in rows if not r["passes"]]
    print(
        f"\nFACS appearance checks: {len(rows) - len(failed)} of {len(rows)} pass (over {1e3 * MIN_MOVE} mm that way)"
    )
    for r in failed:
        print(f"  fails: {r['shape']} {r['place']} {r['direction']} ({r['mm']:+.2f} mm): {r['why']}")
