"""Elastic Bones (paper 004) on a set-up face: the armature, its skin and its pose (the bpy side of `elastic`).

Switching a face to Elastic Bones builds, from the FP empties' neutral positions:
- "<face> Skeleton", an armature object parented to the face with an identity transform, so armature space
  is the face's mesh space (where `elastic.pose` gives its transforms); its bones are the core skeleton's,
  named BONE_PREFIX + the table's name (the table's `upper_lip` would otherwise meet the mask vertex group of
  that name);
- a vertex group per skinned bone with the core's skin weights (`elastic.skinning.skin_weights`, cut at the
  lip and eyelid masks), and an Armature modifier first in the face's stack: Blender's own SSD (eq. 1);
- the eyeballs bone-parented to the eye bones, the lower teeth and the tongue to the jaw bone, their
  follower drivers muted, so the whole head is plain skeletal animation.
Everything is computed (and every problem raised) before the file changes, and all of it is recorded on
the objects, so `remove` takes exactly it away again.

Each frame `apply_pose` reads the FP empties, drives the core (`pose_from_fps`, elastic layer included) and
writes the pose bones' channels (`armature_space.bone_basis`). `bake_keys` does the same for every frame of
an imported stream into keys on the skeleton, so the animation plays (and exports) without this extension.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import bpy
import numpy as np
from mathutils import Matrix

from ..elastic.armature_space import bone_basis, quaternions
from ..elastic.parameters import TRAINED
from ..elastic.pose import pose_from_fps
from ..elastic.skeleton import Skeleton, place_skeleton
from ..elastic.skinning import skin_weights
from ..errors import Mpeg4Error
from . import animation, binding_store, face_data, followers, rest_shape

ELASTIC, PLANAR = "ELASTIC_BONES", "PLANAR_BONES"
BONE_PREFIX = "fa_"  # "face animation": keeps the bones' vertex groups apart from the face's own groups
MODIFIER = "MPEG-4 Elastic Bones"
SKELETON_PROP = "mpeg4_elastic_skeleton"  # on the face: its skeleton object
GROUPS_PROP = "mpeg4_elastic_groups"  # on the face: the vertex group names made, the active group index before
PARENT_PROP = "mpeg4_elastic_parent"  # on a part: its parenting before (parent, type, bone, parent inverse)
MUTED_PROP = "mpeg4_elastic_muted"  # on a part: the drivers switching muted, "path index" each
# part field -> the bone it rides on; the upper teeth stay with the skull, lashes and brows on the skin
PART_BONES = {"left_eye": "eye_l", "right_eye": "eye_r", "lower_teeth": "jaw", "tongue": "jaw"}
PARAMETERS = TRAINED
# what the followers' drivers write (followers.py); the user's own drivers on a part are left alone
FOLLOWER_PATHS = ("delta_location", "delta_rotation_euler", f'["{followers.PITCH_PROP}"]', f'["{followers.YAW_PROP}"]')


def skeleton_object(face) -> bpy.types.Object | None:
    ob = face.get(SKELETON_PROP)
    return ob if isinstance(ob, bpy.types.Object) and ob.type == "ARMATURE" else None


def neutral_fps(face) -> dict[str, np.ndarray]:
    """FP id -> face-local neutral position of every FP empty (the location set-up recorded)."""
    return {
        fp_id: np.array(ob.get(face_data.EMPTY_REST_PROP, ob.location), dtype=np.float64)
        for fp_id, ob in face_data.fp_empties(face).items()
    }


EYES = {"eye_l": "left_eye", "eye_r": "right_eye"}


def _with_eye_centres(skeleton: Skeleton, centres: dict[str, np.ndarray]) -> Skeleton:
    """The skeleton with its eye bones turning about the given centres (the core guesses them from the FPs)."""
    heads = skeleton.heads.copy()
    for bone, centre in centres.items():
        heads[skeleton.index(bone)] = centre
    return replace(skeleton, heads=heads)


@dataclass
class Plan:
    """Everything switching to Elastic Bones writes, worked out before the file changes."""

    skeleton: Skeleton
    weights: np.ndarray  # (N, B)
    parts: dict[str, tuple[bpy.types.Object, str]]  # part field -> (object, bone name)


def plan(face) -> Plan:
    """Check and compute the rig; raises Mpeg4Error naming the problem, changes nothing."""
    if not binding_store.is_bound(face):
        raise Mpeg4Error(f"{face.name} is not set up: run Set Up Face first")
    if face.mode != "OBJECT":
        raise Mpeg4Error(f"{face.name} is in {face.mode.title()} Mode: go back to Object Mode")
    if skeleton_object(face) is not None or face.modifiers.get(MODIFIER) is not None:
        raise Mpeg4Error(f"{face.name} already has an Elastic Bones skeleton")
    settings = face.mpeg4_face
    eyes = {bone: getattr(settings, field) for bone, field in EYES.items()}
    # an eyeball turns about its own centre, as the Planar Bones followers turn it
    centres = {bone: followers.eye_centre(face, eye) for bone, eye in eyes.items() if eye is not None}
    skeleton = _with_eye_centres(place_skeleton(neutral_fps(face)), centres)
    taken = [BONE_PREFIX + name for name in skeleton.names if BONE_PREFIX + name in face.vertex_groups]
    if taken:
        raise Mpeg4Error(f"{face.name} already has vertex groups named like the skeleton's bones: {', '.join(taken)}")
    rest = rest_shape.reference_positions(face.data)
    if rest is None:
        raise Mpeg4Error(f"{face.name} has no rest shape: run Set Up Face again")
    masks = binding_store.vertex_masks(face) if face.mpeg4_face.use_masks else {}
    weights = skin_weights(rest, face_data.mesh_edges(face.data), skeleton, masks)
    parts = {}
    for field, bone in PART_BONES.items():
        ob = getattr(settings, field)
        if ob is not None and ob != face and ob.type == "MESH":
            parts[field] = (ob, BONE_PREFIX + bone)
    return Plan(skeleton, weights, parts)


def build(face, p: Plan) -> list[str]:
    """Write the planned rig: skeleton, vertex groups, Armature modifier, parts on their bones."""
    name = f"{face.name} Skeleton"
    arm = bpy.data.objects.new(name, bpy.data.armatures.new(name))
    arm[face_data.CREATED_PROP] = True
    for coll in face.users_collection:
        coll.objects.link(arm)
    arm.parent = face  # identity parent inverse and transform: armature space = the face's mesh space
    arm.show_in_front = True
    _add_bones(arm, p.skeleton)
    face[SKELETON_PROP] = arm
    groups = _write_groups(face, p.skeleton, p.weights)
    modifier = face.modifiers.new(MODIFIER, "ARMATURE")
    modifier.object = arm
    face.modifiers.move(len(face.modifiers) - 1, 0)  # before anything that reads the deformed skin
    for ob, bone in p.parts.values():
        _ride_on_bone(face, ob, arm, bone)
    notes = [f"built {name} ({len(p.skeleton.bones)} bones, {groups} skinned) with an Armature modifier on {face.name}"]
    if p.parts:
        notes.append(f"{', '.join(ob.name for ob, _ in p.parts.values())} follow the skeleton's bones")
    return notes


def _add_bones(arm, skeleton: Skeleton) -> None:
    view_layer = bpy.context.view_layer
    active = view_layer.objects.active
    view_layer.objects.active = arm  # Edit Mode is entered on the view layer's active object
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        edit = arm.data.edit_bones
        for bone, head, tail in zip(skeleton.bones, skeleton.heads, skeleton.tails, strict=True):
            eb = edit.new(BONE_PREFIX + bone.name)
            eb.head, eb.tail = head.tolist(), tail.tolist()
            eb.use_deform = bone.skinned
            if bone.parent is not None:
                eb.parent = edit[BONE_PREFIX + bone.parent]
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
        view_layer.objects.active = active


def _write_groups(face, skeleton: Skeleton, weights: np.ndarray) -> int:
    """A vertex group per bone that has skin; returns how many. The names and the active group are recorded."""
    before = face.vertex_groups.active_index
    made = []
    for b, bone in enumerate(skeleton.bones):
        column = weights[:, b]
        touched = np.flatnonzero(column > 0.0)
        if not bone.skinned or len(touched) == 0:
            continue
        group = face.vertex_groups.new(name=BONE_PREFIX + bone.name)
        for v in touched.tolist():
            group.add((v,), float(column[v]), "REPLACE")
        made.append(group.name)
    face[GROUPS_PROP] = {"names": ",".join(made), "active": before}
    face.vertex_groups.active_index = before
    return len(made)


def _bone_tail_matrix(arm, bone: str) -> Matrix:
    """A bone child's parent matrix at rest, in armature space: the bone's rest matrix moved to its tail."""
    data = arm.data.bones[bone]
    return data.matrix_local @ Matrix.Translation((0.0, data.length, 0.0))


def _ride_on_bone(face, ob, arm, bone: str) -> None:
    """Parent `ob` to `bone` where it is at rest, with its follower drivers muted and their deltas cleared."""
    old_world = ob.parent.matrix_world.copy() if ob.parent is not None else Matrix.Identity(4)
    saved = {
        "type": ob.parent_type,
        "bone": ob.parent_bone,
        "inverse": [v for row in ob.matrix_parent_inverse for v in row],
    }
    if ob.parent is not None:
        saved["parent"] = ob.parent
    ob[PARENT_PROP] = saved
    muted = []
    if ob.animation_data is not None:
        for fcurve in ob.animation_data.drivers:
            if not fcurve.mute and fcurve.data_path in FOLLOWER_PATHS:
                fcurve.mute = True
                muted.append(f"{fcurve.data_path} {fcurve.array_index}")
    ob[MUTED_PROP] = muted
    ob.delta_location = (0.0, 0.0, 0.0)
    ob.delta_rotation_euler = (0.0, 0.0, 0.0)
    inverse = ob.matrix_parent_inverse.copy()
    ob.parent = arm
    ob.parent_type = "BONE"
    ob.parent_bone = bone
    # the armature's world matrix is the face's (identity child): keep the part's rest place
    ob.matrix_parent_inverse = (face.matrix_world @ _bone_tail_matrix(arm, bone)).inverted() @ old_world @ inverse


def _restore_part(ob) -> None:
    saved = ob.get(PARENT_PROP)
    if saved is None:
        return
    parent = saved.get("parent")
    ob.parent = parent if isinstance(parent, bpy.types.Object) else None
    ob.parent_type = saved["type"]
    ob.parent_bone = saved["bone"]
    values = list(saved["inverse"])
    ob.matrix_parent_inverse = Matrix([values[i : i + 4] for i in range(0, 16, 4)])
    muted = set(ob.get(MUTED_PROP, ()))
    if ob.animation_data is not None:
        for fcurve in ob.animation_data.drivers:
            if f"{fcurve.data_path} {fcurve.array_index}" in muted:
                fcurve.mute = False
    del ob[PARENT_PROP]
    if MUTED_PROP in ob:
        del ob[MUTED_PROP]


def remove(face) -> bool:
    """Take the rig away (parts back on their old parents, drivers on); False when there was none."""
    forget(face)
    arm = skeleton_object(face)
    found = arm is not None or GROUPS_PROP in face or face.modifiers.get(MODIFIER) is not None
    for ob in bpy.data.objects:
        if PARENT_PROP in ob and (ob.parent == arm or ob.parent is None):
            _restore_part(ob)
    modifier = face.modifiers.get(MODIFIER)
    if modifier is not None:
        face.modifiers.remove(modifier)
    recorded = face.get(GROUPS_PROP)
    if recorded is not None:
        names, active = recorded["names"], recorded["active"]
        for name in filter(None, names.split(",")):
            group = face.vertex_groups.get(name)
            if group is not None:
                face.vertex_groups.remove(group)
        face.vertex_groups.active_index = active
        del face[GROUPS_PROP]
    if arm is not None:
        _drop_skeleton(arm)
    if SKELETON_PROP in face:
        del face[SKELETON_PROP]
    return found


def _drop_skeleton(arm) -> None:
    data = arm.data
    anim = arm.animation_data
    action = anim.action if anim is not None else None
    slot = anim.action_slot if anim is not None and animation.SLOTTED else None
    bpy.data.objects.remove(arm)
    if data.users == 0:
        bpy.data.armatures.remove(data)
    if action is not None and animation.is_stream_action(action):
        if slot is not None and action.users > 0:
            action.slots.remove(slot)  # the FP empties still play the stream; the skeleton's channels go
        elif action.users == 0:
            bpy.data.actions.remove(action)


# ----------------------------------------------------------------------------- the pose


@dataclass
class _State:
    arm_name: str
    skeleton: Skeleton
    rest_fps: dict[str, np.ndarray]
    rest: np.ndarray  # (B, 4, 4) bone rest matrices (armature space), in skeleton order
    reader: face_data.FpReader  # the FPs the bones follow
    order: np.ndarray  # pose bone row of each skeleton bone
    last: np.ndarray | None = None


_states: dict[int, _State] = {}


def forget(face=None) -> None:
    if face is None:
        _states.clear()
    else:
        _states.pop(face.session_uid, None)


def _state(face, arm) -> _State:
    state = _states.get(face.session_uid)
    if state is not None and state.arm_name == arm.name and len(arm.pose.bones) == len(state.order):
        return state
    rest_fps = neutral_fps(face)
    bones = arm.data.bones
    skeleton = place_skeleton(rest_fps)
    names = [b.name for b in arm.pose.bones]
    missing = [n for n in skeleton.names if BONE_PREFIX + n not in names]
    if missing:
        raise Mpeg4Error(f"{arm.name} lacks the bones {', '.join(missing)}: switch the engine to Planar Bones and back")
    order = np.array([names.index(BONE_PREFIX + n) for n in skeleton.names], dtype=np.intp)
    skeleton = _with_eye_centres(skeleton, {eye: np.array(bones[BONE_PREFIX + eye].head_local) for eye in EYES})
    rest = np.array([bones[BONE_PREFIX + n].matrix_local for n in skeleton.names], dtype=np.float64)
    follow = sorted({f for bone in skeleton.bones for f in bone.follow if f in rest_fps})
    state = _State(arm.name, skeleton, rest_fps, rest, face_data.FpReader(follow), order)
    _states[face.session_uid] = state
    return state


def _channels(state: _State, moved: np.ndarray, previous: np.ndarray | None = None):
    """(B, 3) locations and (B, 4) quaternions of the skeleton's bones for FP positions `moved` (reader order),
    and their (B, 4, 4) transforms relative to rest (what the Armature modifier applies)."""
    moved_fps = dict(zip(state.reader.fp_ids, moved, strict=True))
    transforms = pose_from_fps(state.skeleton, state.rest_fps, moved_fps, PARAMETERS)
    basis = bone_basis(state.rest, state.skeleton.parents, transforms)
    return basis[:, :3, 3], quaternions(basis[:, :3, :3], previous), transforms


def require_skeleton(face) -> bpy.types.Object:
    arm = skeleton_object(face)
    if arm is None or not arm.users_collection:
        raise Mpeg4Error(f"{face.name}'s Elastic Bones skeleton was deleted: switch to Planar Bones and back")
    return arm


class Posed(NamedTuple):
    """What `apply_pose` wrote: each bone's (4, 4) transform relative to rest, in skeleton order, and the vertex
    group each bone skins, in the same order."""

    transforms: np.ndarray  # (B, 4, 4)
    groups: list[str]


def apply_pose(face, force: bool = False) -> Posed | None:
    """Pose the skeleton from the FP empties as they are now; what it wrote, or None when nothing was written
    (they did not move)."""
    arm = require_skeleton(face)
    state = _state(face, arm)
    moved = state.reader.read(face)
    if not force and state.last is not None and np.array_equal(moved, state.last):
        return None
    location, rotation, transforms = _channels(state, moved)
    _write_pose(arm, state, location, rotation)
    state.last = moved
    return Posed(transforms, [BONE_PREFIX + name for name in state.skeleton.names])


def _write_pose(arm, state: _State, location: np.ndarray, rotation: np.ndarray) -> None:
    n = len(arm.pose.bones)
    loc = np.zeros((n, 3), dtype=np.float32)
    quat = np.tile(np.array([1.0, 0.0, 0.0, 0.0], dtype=np.float32), (n, 1))
    loc[state.order], quat[state.order] = location, rotation
    bones = arm.pose.bones
    bones.foreach_set("location", loc.ravel())
    bones.foreach_set("rotation_quaternion", quat.ravel())
    arm.update_tag(refresh={"DATA"})


def rest_pose(face) -> None:
    """Show the skeleton at rest (Deform off)."""
    arm = skeleton_object(face)
    if arm is None:
        return
    forget(face)
    n = len(arm.pose.bones)
    arm.pose.bones.foreach_set("location", np.zeros(n * 3, dtype=np.float32))
    arm.pose.bones.foreach_set("rotation_quaternion", np.tile(np.float32([1, 0, 0, 0]), n))
    arm.update_tag(refresh={"DATA"})


def bake_keys(face, frames: np.ndarray, streams: animation.StreamActions) -> str:
    """Key every bone's location and rotation at `frames` from the FP empties' motion, into the stream's action."""
    arm = require_skeleton(face)
    return _bake(face, arm, frames, animation.replace_motion(arm, streams))


def rebake_keys(face, frames: np.ndarray) -> str:
    """`bake_keys` again into the skeleton's current stream action (the FP empties' keys changed)."""
    arm = require_skeleton(face)
    anim = arm.animation_data
    if anim is None or not animation.is_stream_action(anim.action):
        raise Mpeg4Error(f"{arm.name} has no imported stream to bake again: import the stream again")
    return _bake(face, arm, frames, lambda path, index: animation.ensure_fcurve(arm, path, index, anim.action.name))


def _bake(face, arm, frames: np.ndarray, fcurve) -> str:
    state = _state(face, arm)
    empties = face_data.fp_empties(face)
    moved = np.stack(
        [
            np.stack([animation.sample(empties[f], "location", a, frames, empties[f].location[a]) for a in range(3)], 1)
            for f in state.reader.fp_ids
        ],
        axis=1,
    )  # (F, M, 3)
    locations = np.empty((len(frames), len(state.skeleton.bones), 3))
    rotations = np.empty((len(frames), len(state.skeleton.bones), 4))
    previous = None
    for k in range(len(frames)):
        locations[k], rotations[k], _transforms = _channels(state, moved[k], previous)
        previous = rotations[k]
    for b, name in enumerate(state.skeleton.names):
        path = f'pose.bones["{BONE_PREFIX}{name}"]'
        for axis in range(3):
            animation.set_keys(fcurve(f"{path}.location", axis), frames, locations[:, b, axis])
        for axis in range(4):
            animation.set_keys(fcurve(f"{path}.rotation_quaternion", axis), frames, rotations[:, b, axis])
    return f"baked {len(state.skeleton.bones)} bones over {len(frames)} frames into keys on {arm.name}"
