"""Eyeballs, lower teeth and tongue follow their feature point empties through drivers.

Drivers are evaluated by Blender itself (viewport, playback, renders, a file opened without this
extension), and the expressions below are Blender "simple expressions", which need no Python and so
also run when a file's scripts are not trusted. Each driver writes a delta transform, so the object's
own transform stays the user's.

- eyeball: delta rotation = yaw/pitch of the pupil FP (3.5/3.6) about the eyeball's origin, relative
  to the rest gaze (MPEG-4 yaw +: toward the face's left = about +Z; pitch +: down = about +X);
- lower teeth: delta location = displacement of 9.11 (top of the lower teeth) from rest;
- tongue: delta location = displacement of 6.2 (tongue body) from rest.
Empties and followers are children of the face with identity parent inverse, so locations are in
face-local coordinates.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

DRIVER_TAG = "mpeg4_rig"  # custom property on followers: which FP drives them


def _variables(driver, empty):
    for name, axis in (("x", 0), ("y", 1), ("z", 2)):
        var = driver.variables.new()
        var.name = name
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "OBJECT"
        var.targets[0].id = empty
        var.targets[0].data_path = f"location[{axis}]"


def _driver(ob, path, index, empty, expression):
    fcurve = ob.driver_add(path, index)
    driver = fcurve.driver
    driver.type = "SCRIPTED"
    while driver.variables:
        driver.variables.remove(driver.variables[0])
    _variables(driver, empty)
    driver.expression = expression
    return driver


def remove_follow(ob) -> None:
    if ob is None or DRIVER_TAG not in ob:
        return
    for path in ("delta_location", "delta_rotation_euler"):
        for index in range(3):
            ob.driver_remove(path, index)
    ob.delta_location = (0.0, 0.0, 0.0)
    ob.delta_rotation_euler = (0.0, 0.0, 0.0)
    del ob[DRIVER_TAG]


def follow_location(ob, empty) -> None:
    """ob.delta_location = empty.location - its rest location."""
    remove_follow(ob)
    rest = tuple(empty.location)
    for axis, name in enumerate("xyz"):
        _driver(ob, "delta_location", axis, empty, f"{name} - ({rest[axis]!r})")
    ob[DRIVER_TAG] = empty.get("mpeg4_fp", empty.name)


def follow_gaze(eye, pupil, pivot: np.ndarray) -> None:
    """Turn `eye` about its origin (`pivot`, face-local) so it keeps looking through the `pupil` empty."""
    remove_follow(eye)
    cx, cy, cz = (float(v) for v in pivot)
    px, py, pz = (float(v) for v in pupil.location)
    yaw0 = math.atan2(px - cx, cy - py)
    pitch0 = math.atan2(cz - pz, math.hypot(px - cx, py - cy))
    horizontal = f"sqrt((x - ({cx!r})) * (x - ({cx!r})) + (y - ({cy!r})) * (y - ({cy!r})))"
    _driver(eye, "delta_rotation_euler", 0, pupil, f"atan2(({cz!r}) - z, {horizontal}) - ({pitch0!r})")
    _driver(eye, "delta_rotation_euler", 2, pupil, f"atan2(x - ({cx!r}), ({cy!r}) - y) - ({yaw0!r})")
    eye[DRIVER_TAG] = pupil.get("mpeg4_fp", pupil.name)


def _side(child) -> float:
    """+1 on the face's left (+X), -1 on its right: from the name ('Eye L', 'eye.R', 'left_eye'), else from
    where the child sits in the face's space (computed from its own transform, so it holds before Blender
    has evaluated a freshly made scene)."""
    words = set(child.name.lower().replace(".", " ").replace("_", " ").replace("-", " ").split())
    if words & {"l", "left"}:
        return 1.0
    if words & {"r", "right"}:
        return -1.0
    return (child.matrix_parent_inverse @ child.matrix_basis).translation.x


def find_followers(face) -> dict[str, bpy.types.Object | None]:
    """Guess the eyeballs, lower teeth and tongue among the face's children by name and side."""
    found = {"left_eye": None, "right_eye": None, "lower_teeth": None, "tongue": None}
    for child in face.children:
        name = child.name.lower()
        if child.type != "MESH":
            continue
        if "eye" in name and not any(word in name for word in ("lash", "brow", "lid")):
            side = "left_eye" if _side(child) > 0 else "right_eye"
            found[side] = found[side] or child
        elif "teeth" in name and ("lower" in name or "bottom" in name):
            found["lower_teeth"] = found["lower_teeth"] or child
        elif "tongue" in name:
            found["tongue"] = found["tongue"] or child
    return found
