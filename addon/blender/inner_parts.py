"""Face parts inside the face object (deform/loose_parts.py): found at set-up, kept as vertex groups the user can
correct, moved rigidly in playback.

The assignment is a vertex group per rigid part, `part_left_eye`, `part_lower_teeth`, ...: set-up makes them
from the loose parts it finds when the face has none with a weight (and Remove deletes the ones it made); a
face that has them (made by an earlier set-up and corrected, or painted by the user) keeps them as they are.
"""

from __future__ import annotations

import numpy as np

from ..deform.loose_parts import RIGID_ROLES, SKIN_ROLES, RigidParts, bind_parts, find_parts
from . import face_data

GROUPS = {role: f"part_{role}" for role in RIGID_ROLES}
MADE_PROP = "mpeg4_made_parts"  # on the face: the part groups set-up made
LABELS = {
    "left_eye": "left eyeball",
    "right_eye": "right eyeball",
    "upper_teeth": "upper teeth",
    "lower_teeth": "lower teeth",
    "tongue": "tongue",
    "lashes": "lashes",
    "brows": "brows",
}
FOLLOWS = {
    "left_eye": "turns about its centre with FP 3.5",
    "right_eye": "turns about its centre with FP 3.6",
    "upper_teeth": "stays with the skull",
    "lower_teeth": "moves with FP 9.11 (the jaw)",
    "tongue": "moves with FP 6.2",
}


def group_members(face) -> dict[str, np.ndarray]:
    """Role -> vertex indices of the face's part groups that hold a weight above 1/2."""
    weights = face_data.group_weights(face, list(GROUPS.values()))
    found = {}
    for role, name in GROUPS.items():
        if name in weights and (weights[name] > 0.5).any():
            found[role] = np.flatnonzero(weights[name] > 0.5)
    return found


def plan_parts(face, rest: np.ndarray, edges: np.ndarray, neutral: dict, axes: np.ndarray, notes: list) -> dict:
    """The part groups to make (group name -> vertex indices): the loose parts found, unless the face has part
    groups already. Notes what each part was taken for."""
    if group_members(face):
        return {}
    found = find_parts(rest, edges, face_data.neutral_array(neutral), axes)
    made = {GROUPS[role]: found[role] for role in RIGID_ROLES if role in found}
    if made:
        taken = ", ".join(f"{LABELS[role]} ({len(found[role])} vertices)" for role in RIGID_ROLES if role in found)
        notes.append(
            f"found loose parts inside {face.name}: {taken}; they move rigidly (vertex groups part_*: "
            "reassign vertices to correct them, then run Set Up Face)"
        )
    riding = [LABELS[role] for role in SKIN_ROLES if role in found]
    if riding:
        notes.append(f"found {' and '.join(riding)} inside {face.name}: they ride on the skin")
    return made


def write_parts(face, made: dict) -> None:
    for name, members in made.items():
        face.vertex_groups.new(name=name).add(members.tolist(), 1.0, "REPLACE")
    if made:
        face[MADE_PROP] = sorted({*face.get(MADE_PROP, ()), *made})


def remove_parts(face) -> int:
    names = list(face.get(MADE_PROP, ()))
    for name in names:
        group = face.vertex_groups.get(name)
        if group is not None:
            face.vertex_groups.remove(group)
    if MADE_PROP in face:
        del face[MADE_PROP]
    return len(names)


def rigid_parts(face, rest: np.ndarray) -> RigidParts | None:
    """The face's rigid parts for playback, from its part groups (None without any)."""
    members = group_members(face)
    if not members:
        return None
    neutral = face_data.neutral_positions(face_data.fp_empties(face))
    return bind_parts(rest, members, neutral, face_data.face_axes(face))


def listed(face) -> list[tuple[str, str, str]]:
    """(group, what it was taken for, how it moves) for each part group of the face, for the panel (by name only:
    reading the weights takes a scene evaluation)."""
    return [(name, LABELS[role], FOLLOWS[role]) for role, name in GROUPS.items() if face.vertex_groups.get(name)]


def eye_centres(face, rest: np.ndarray) -> dict[str, np.ndarray]:
    """Eye role -> the fitted centre of the face's own eyeball part (the eyeballs inside the face object)."""
    parts = rigid_parts(face, rest)
    return {} if parts is None else parts.centres
