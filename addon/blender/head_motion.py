"""Head rotation (FAPs 48-50) as the face object's delta transform, both ways, in one place.

The head turns about a pivot p (face-local, FP 7.1) by R_h, given in the MPEG-4 face frame. Blender
composes an object's rotation as R_delta @ R_user (delta on the left), so with matrix_basis =
T(loc + dloc) R_d R_u S (uniform scale s), turning local points about p by R_h needs
R_d = R_u R_h R_u^-1 and dloc = R_u s (p - R_h p). Which delta property Blender reads depends on the
object's rotation mode: delta_rotation_quaternion in quaternion mode, delta_rotation_euler (in the
object's own Euler order) otherwise; axis-angle has no delta and is refused.
"""

from __future__ import annotations

import numpy as np
from mathutils import Euler, Matrix, Quaternion

from ..deform.neck import head_turn_weights
from ..errors import Mpeg4Error
from ..mpeg4.decode import head_angles, head_rotation
from . import animation, face_data

DELTA_REST_PROP = "mpeg4_delta_rest"  # on the face: its delta transform before the first import


def check_rotation_mode(face) -> None:
    if face.rotation_mode == "AXIS_ANGLE":
        raise Mpeg4Error(
            f"{face.name} uses Axis Angle rotation, which has no delta rotation for head motion: "
            "set its rotation mode to an Euler order or Quaternion"
        )


def rotation_path(face) -> tuple[str, int]:
    """The delta rotation property Blender reads for the face's rotation mode, and its size."""
    return ("delta_rotation_quaternion", 4) if face.rotation_mode == "QUATERNION" else ("delta_rotation_euler", 3)


def user_rotation(face) -> np.ndarray:
    """The face's own rotation (without the delta) as a 3x3 matrix, whatever its rotation mode."""
    if face.rotation_mode == "QUATERNION":
        return np.array(face.rotation_quaternion.normalized().to_matrix())
    return np.array(face.rotation_euler.to_matrix())  # the Euler carries the object's order


def to_delta(face, angles: np.ndarray, pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, 3) head pitch/yaw/roll in radians -> per-frame delta rotation values and (F, 3) delta location."""
    check_rotation_mode(face)
    axes = face_data.face_axes(face)
    r_mesh = axes.T @ head_rotation(angles) @ axes
    r_user = user_rotation(face)
    scale = float(np.mean(face.scale))
    r_delta = r_user @ r_mesh @ r_user.T
    dloc = scale * np.einsum("ij,fj->fi", r_user, pivot - np.einsum("fij,j->fi", r_mesh, pivot))
    if face.rotation_mode == "QUATERNION":
        rotation = np.array([Matrix(r.tolist()).to_quaternion() for r in r_delta])
        rotation *= np.where(rotation[:, :1] < 0, -1.0, 1.0)  # one hemisphere, so keys interpolate the short way
    else:
        rotation = np.array([Matrix(r.tolist()).to_euler(face.rotation_mode) for r in r_delta])
    return rotation, dloc


def from_delta(face, rotation: np.ndarray) -> np.ndarray:
    """Per-frame delta rotation values (as `to_delta` gives them) -> (F, 3) head pitch/yaw/roll."""
    check_rotation_mode(face)
    if face.rotation_mode == "QUATERNION":
        r_delta = np.array([np.array(Quaternion(q.tolist()).normalized().to_matrix()) for q in rotation])
    else:
        r_delta = np.array([np.array(Euler(e.tolist(), face.rotation_mode).to_matrix()) for e in rotation])
    r_user = user_rotation(face)
    r_mesh = r_user.T @ r_delta @ r_user
    axes = face_data.face_axes(face)
    return head_angles(axes @ r_mesh @ axes.T)


def compose_with_existing(face, frames, rotation: np.ndarray, dloc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Head motion on top of the face's existing delta motion, sampled at `frames`: rotations compose (the
    stream's turn after the existing one), locations add."""
    path, size = rotation_path(face)
    rest = getattr(face, path)
    base = np.stack([animation.sample(face, path, axis, frames, rest[axis]) for axis in range(size)], axis=1)
    base_loc = np.stack(
        [animation.sample(face, "delta_location", a, frames, face.delta_location[a]) for a in range(3)], axis=1
    )
    if size == 4:
        combined = [Quaternion(q.tolist()) @ Quaternion(b.tolist()) for q, b in zip(rotation, base, strict=True)]
        composed = np.array([tuple(q) for q in combined])
    else:
        order = face.rotation_mode
        composed = np.array(
            [
                (Euler(r.tolist(), order).to_matrix() @ Euler(b.tolist(), order).to_matrix()).to_euler(order)
                for r, b in zip(rotation, base, strict=True)
            ]
        )
    return composed, dloc + base_loc


def remember_rest(face) -> None:
    """Record the face's delta transform before head motion is first imported (Remove restores it)."""
    if DELTA_REST_PROP not in face:
        face[DELTA_REST_PROP] = {
            "location": list(face.delta_location),
            "rotation_euler": list(face.delta_rotation_euler),
            "rotation_quaternion": list(face.delta_rotation_quaternion),
        }


def restore_rest(face) -> None:
    record = face.get(DELTA_REST_PROP)
    if record is None:
        return
    face.delta_location = record["location"]
    face.delta_rotation_euler = record["rotation_euler"]
    face.delta_rotation_quaternion = record["rotation_quaternion"]
    del face[DELTA_REST_PROP]


# ----------------------------------------------------------------------------- a head on a body

HEAD_TURN_GROUP = "head_turn"  # 1: turns with the head, 0: stays with the body (deform/neck.py)
MADE_NECK_PROP = "mpeg4_made_head_turn"  # on the face: set-up made the group


def plan_head_turn(face, rest: np.ndarray, neutral: dict, axes: np.ndarray, notes: list) -> np.ndarray | None:
    """The head-turn weights to write for a head on a body that has no such group with a weight (else None)."""
    held = face_data.group_weights(face, [HEAD_TURN_GROUP]).get(HEAD_TURN_GROUP)
    if held is not None and held.any():
        return None
    nan = np.full(3, np.nan)
    weights = head_turn_weights(rest, axes, neutral.get("7.1", nan), neutral.get("2.1", nan))
    if weights is not None:
        notes.append(
            f"{face.name} has a body: head turns turn the head about FP 7.1 and the neck in part, the shoulders "
            f"stay (vertex group {HEAD_TURN_GROUP}: edit it to move the falloff)"
        )
    return weights


def write_head_turn(face, weights: np.ndarray | None) -> None:
    if weights is None:
        return
    group = face.vertex_groups.get(HEAD_TURN_GROUP) or face.vertex_groups.new(name=HEAD_TURN_GROUP)
    for value in np.unique(weights[weights > 0.0]):
        group.add(np.flatnonzero(weights == value).tolist(), float(value), "REPLACE")
    face[MADE_NECK_PROP] = True


def remove_head_turn(face) -> bool:
    if MADE_NECK_PROP not in face:
        return False
    group = face.vertex_groups.get(HEAD_TURN_GROUP)
    if group is not None:
        face.vertex_groups.remove(group)
    del face[MADE_NECK_PROP]
    return True


def body_share(face) -> tuple[np.ndarray, np.ndarray] | None:
    """The vertices that must not take the whole head turn and the share of it each gives back (1 - weight),
    or None for a head without a head-turn group."""
    if face.vertex_groups.get(HEAD_TURN_GROUP) is None:
        return None
    weights = face_data.group_weights(face, [HEAD_TURN_GROUP])[HEAD_TURN_GROUP]
    vertices = np.flatnonzero(weights < 1.0)
    return (vertices, 1.0 - weights[vertices]) if len(vertices) and weights.any() else None


def _delta_matrix(face, values) -> np.ndarray:
    if face.rotation_mode == "QUATERNION":
        return np.array(Quaternion(values).normalized().to_matrix())
    return np.array(Euler(values, face.rotation_mode).to_matrix())


def mesh_turn(face) -> np.ndarray:
    """(3, 3) the head's turn now, in mesh coordinates: the face's delta rotation against the one it had before
    head motion was imported (the identity when none was)."""
    record = face.get(DELTA_REST_PROP)
    if record is None or face.rotation_mode == "AXIS_ANGLE":
        return np.eye(3)
    path, _size = rotation_path(face)
    rest = record["rotation_quaternion" if path == "delta_rotation_quaternion" else "rotation_euler"]
    r_delta = _delta_matrix(face, tuple(getattr(face, path))) @ _delta_matrix(face, tuple(rest)).T
    r_user = user_rotation(face)
    return r_user.T @ r_delta @ r_user
