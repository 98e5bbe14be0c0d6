"""The face parts (eyeballs, teeth, tongue, lashes, brows) and how each follows the face.

Set-up fills the face's part fields by name where they are empty (`find_followers`); from then on the
fields say which object is which. Eyeballs, lower teeth and tongue follow their feature point empties
through drivers. Drivers are evaluated by Blender itself (viewport, playback, renders, a file opened
without this extension), and the expressions below are Blender "simple expressions", which need no
Python and so also run when a file's scripts are not trusted. Each driver writes a delta transform, so
the object's own transform stays the user's.

- eyeball: delta rotation = yaw/pitch of the pupil FP (3.5/3.6) about the eyeball's centre (a sphere
  fitted to its mesh, not its origin), relative to the rest gaze (MPEG-4 yaw +: toward the face's
  left = about +Z; pitch +: down = about +X); when the origin is off that centre, a delta location
  keeps the centre in place (the turn is about the origin otherwise);
- lower teeth: delta location = displacement of 9.11 (top of the lower teeth) from rest;
- tongue: delta location = displacement of 6.2 (tongue body) from rest;
- upper teeth: fixed to the skull, they move only with the head (the face object);
- lashes and brows: a Surface Deform modifier bound to the face at rest, so they ride on the lids and
  the brow skin.
Empties and followers are children of the face with identity parent inverse, so locations are in
face-local coordinates.
"""

from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..geometry.sphere_fit import SphereFitError, fit_sphere

DRIVER_TAG = "mpeg4_rig"  # custom property on followers: which FP drives them
SURFACE_MODIFIER = "MPEG-4 Follow Face"
PITCH_PROP, YAW_PROP = "mpeg4_pitch", "mpeg4_yaw"  # an off-centre eyeball's turn, read by its delta drivers
OFF_CENTRE = 1e-3  # x eyeball radius: an origin farther than this from the fitted centre gets a delta location
# part field -> what drives it: an FP id, "skull" (nothing) or "surface" (a Surface Deform on the face)
PARTS = {
    "left_eye": "3.5",
    "right_eye": "3.6",
    "upper_teeth": "skull",
    "lower_teeth": "9.11",
    "tongue": "6.2",
    "lashes": "surface",
    "brows": "surface",
}


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
    for prop in (PITCH_PROP, YAW_PROP):
        if prop in ob:
            ob.driver_remove(f'["{prop}"]')
            del ob[prop]
    modifier = ob.modifiers.get(SURFACE_MODIFIER) if ob.type == "MESH" else None
    if modifier is not None:
        ob.modifiers.remove(modifier)
    del ob[DRIVER_TAG]


def follow_location(ob, empty) -> None:
    """ob.delta_location = empty.location - its rest location."""
    remove_follow(ob)
    rest = tuple(empty.location)
    for axis, name in enumerate("xyz"):
        _driver(ob, "delta_location", axis, empty, f"{name} - ({rest[axis]!r})")
    ob[DRIVER_TAG] = empty.get("mpeg4_fp", empty.name)


def eye_centre(face, eye) -> np.ndarray:
    """The eyeball's centre in face-local coordinates: a least-squares sphere through its vertices, or its
    origin when the mesh fixes no sphere (too few or flat vertices)."""
    to_face = np.array(face.matrix_world.inverted() @ eye.matrix_world)
    if eye.type == "MESH" and len(eye.data.vertices):
        co = np.empty(len(eye.data.vertices) * 3)
        eye.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3) @ to_face[:3, :3].T + to_face[:3, 3]
        try:
            return fit_sphere(co)[0]
        except SphereFitError:
            pass
    return to_face[:3, 3].copy()


def _along(row: np.ndarray, centre) -> tuple[int, float, str] | None:
    """For a face axis `row` along a mesh axis: (that axis, its sign, the expression of the pupil's coordinate on
    the face axis, from the centre); None for an axis between the mesh's axes."""
    k = int(np.argmax(np.abs(row)))
    if abs(abs(row[k]) - 1.0) > 1e-9:
        return None
    name, c = "xyz"[k], float(centre[k])
    return k, float(np.sign(row[k])), (f"({name} - ({c!r}))" if row[k] > 0 else f"(({c!r}) - {name})")


def follow_gaze(face, eye, pupil, pivot: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> str | None:
    """Turn `eye` about `pivot` (face-local) so it keeps looking through the `pupil` empty: pitch about the face's
    left axis, then yaw about its up (`axes`, the face frame's rows in face-local coordinates, along the mesh's
    axes). Returns why it cannot, when the frame's axes lie between the mesh's or come in an order an Euler
    rotation cannot follow (then the eye does not turn)."""
    remove_follow(eye)
    axes = np.asarray(axes, dtype=np.float64)
    left, up, forward = (_along(row, pivot) for row in axes)
    if left is None or up is None or forward is None or left[0] > up[0]:
        return f"{eye.name} cannot follow its pupil on a face whose frame lies between the mesh's axes"
    fx, fy, fz = left[2], up[2], forward[2]
    f = axes @ (np.array(pupil.location, dtype=np.float64) - pivot)
    yaw0 = math.atan2(f[0], f[2])
    pitch0 = math.atan2(-f[1], math.hypot(f[0], f[2]))
    pitch = f"atan2(-{fy}, sqrt({fx} * {fx} + {fz} * {fz})) - ({pitch0!r})"
    yaw = f"atan2({fx}, {fz}) - ({yaw0!r})"
    pitch, yaw = (expr if sign > 0 else f"-({expr})" for expr, sign in ((pitch, left[1]), (yaw, up[1])))
    q = _offset_from_origin(face, eye, pivot)
    canonical = np.array_equal(axes, BLENDER_FACE_AXES)
    if not canonical or np.linalg.norm(q) <= OFF_CENTRE * np.linalg.norm(f):
        _driver(eye, "delta_rotation_euler", left[0], pupil, pitch)
        _driver(eye, "delta_rotation_euler", up[0], pupil, yaw)
    else:
        # Blender turns an object about its origin, by the delta rotation D = Rz(yaw) Rx(pitch) after its own
        # rotation; with q the centre's offset from the origin, a delta location q - D q keeps the centre still.
        # The angles go through two custom properties so each expression stays within a driver's 256 characters.
        for prop, expression in ((PITCH_PROP, pitch), (YAW_PROP, yaw)):
            eye[prop] = 0.0
            _driver(eye, f'["{prop}"]', -1, pupil, expression)
        qx, qy, qz = (f"({float(v)!r})" for v in q)  # a Python float's repr: NumPy 2 writes np.float64(...)
        turned_y = f"(cos(p) * {qy} - sin(p) * {qz})"  # Rx(pitch) q = (qx, turned_y, turned_z)
        for path, index, expression in (
            ("delta_rotation_euler", 0, "p"),
            ("delta_rotation_euler", 2, "w"),
            ("delta_location", 0, f"{qx} - (cos(w) * {qx} - sin(w) * {turned_y})"),
            ("delta_location", 1, f"{qy} - (sin(w) * {qx} + cos(w) * {turned_y})"),
            ("delta_location", 2, f"{qz} - (sin(p) * {qy} + cos(p) * {qz})"),
        ):
            _angle_driver(eye, path, index, expression)
    eye[DRIVER_TAG] = pupil.get("mpeg4_fp", pupil.name)
    if not canonical and np.linalg.norm(q) > OFF_CENTRE * np.linalg.norm(f):
        return f"{eye.name} turns about its origin, {np.linalg.norm(q):.3g} from its fitted centre"
    return None


def _angle_driver(eye, path: str, index: int, expression: str) -> None:
    """A driver on `eye` reading its own pitch (p) and yaw (w) properties."""
    driver = eye.driver_add(path, index).driver
    driver.type = "SCRIPTED"
    while driver.variables:
        driver.variables.remove(driver.variables[0])
    for name, prop in (("p", PITCH_PROP), ("w", YAW_PROP)):
        var = driver.variables.new()
        var.name = name
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "OBJECT"
        var.targets[0].id = eye
        var.targets[0].data_path = f'["{prop}"]'
    driver.expression = expression


def _offset_from_origin(face, eye, pivot) -> np.ndarray:
    """The face-local `pivot` minus the eye's origin, in the space its location and deltas live in."""
    frame = eye.matrix_world @ eye.matrix_basis.inverted()  # parent's world matrix times parent inverse
    return np.array(frame.inverted() @ face.matrix_world @ Vector(pivot)) - np.array(eye.location)


def follow_surface(ob, face) -> None:
    """Bind `ob` to the face (at rest now) with a Surface Deform modifier, so it rides on the skin."""
    remove_follow(ob)
    modifier = ob.modifiers.new(SURFACE_MODIFIER, "SURFACE_DEFORM")
    modifier.target = face
    with bpy.context.temp_override(object=ob, active_object=ob):
        bpy.ops.object.surfacedeform_bind(modifier=modifier.name)
    bpy.context.evaluated_depsgraph_get().update()  # the bind happens at the next evaluation: now, at rest
    ob[DRIVER_TAG] = "surface"


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
    """Guess the face parts among the face's child meshes by name (and side, for the eyes)."""
    found = dict.fromkeys(PARTS)
    for child in face.children:
        name = child.name.lower()
        if child.type != "MESH":
            continue
        if "lash" in name:
            role = "lashes"
        elif "brow" in name:
            role = "brows"
        elif "eye" in name and "lid" not in name:
            role = "left_eye" if _side(child) > 0 else "right_eye"
        elif "teeth" in name or "tooth" in name:
            role = "upper_teeth" if any(w in name for w in ("upper", "top")) else None
            role = role or ("lower_teeth" if any(w in name for w in ("lower", "bottom")) else None)
        elif "tongue" in name:
            role = "tongue"
        else:
            role = None
        if role is not None and found[role] is None:
            found[role] = child
    return found
