"""Keys in bulk, and FAP streams as actions: one action per imported stream, named after its file.

Blender 4.4 introduced slotted actions (one action animating many objects, a slot each) and 5.0 removed
`Action.fcurves`; 4.2-4.3 have only the latter, so there a stream gets one action per object, named
'<file> <object>'. Keys are written with one `foreach_set` per curve, never one keyframe_insert per key.

A stream's action becomes the active action of each object it moves; a user's own action is kept with a
fake user and given back by `remove_streams`. Everything is tagged so Remove can take exactly it away.
"""

from __future__ import annotations

import bpy
import numpy as np

from .face_data import CREATED_PROP

LINEAR = 1  # BEZT_IPO_LIN, the raw value of 'LINEAR' in KeyframePoint.interpolation
STREAM_PROP = "mpeg4_stream"  # on a stream's action: the file it came from
STASHED_PROP = "mpeg4_stashed_action"  # on an object: the user's action a stream replaced
CREATED_ANIM_PROP = "mpeg4_created_animation_data"
SLOTTED = hasattr(bpy.types, "ActionSlot")


class StreamActions:
    """The action(s) of one imported stream: one slotted action, or one action per object before 4.4."""

    def __init__(self, name: str, source: str):
        self.name = name
        self.source = source
        self._actions: dict[str, bpy.types.Action] = {}

    def action_for(self, ob) -> bpy.types.Action:
        key = "" if SLOTTED else ob.name
        action = self._actions.get(key)
        if action is None:
            action = bpy.data.actions.new(self.name if SLOTTED else f"{self.name} {ob.name}")
            action[CREATED_PROP] = True
            action[STREAM_PROP] = self.source
            self._actions[key] = action
        return action


def _anim(ob):
    if ob.animation_data is None:
        ob.animation_data_create()
        ob[CREATED_ANIM_PROP] = True
    return ob.animation_data


def _slot(action, ob):
    if not SLOTTED:
        return None
    for slot in action.slots:
        if slot.target_id_type == "OBJECT" and slot.name_display == ob.name:
            return slot
    return action.slots.new(id_type="OBJECT", name=ob.name)


def _fcurves(action, slot):
    if slot is None:
        return action.fcurves
    from bpy_extras import anim_utils

    return anim_utils.action_ensure_channelbag_for_slot(action, slot).fcurves


def is_stream_action(action) -> bool:
    return action is not None and STREAM_PROP in action


def replace_motion(ob, streams: StreamActions):
    """Make the stream the object's active action; returns a function giving F-curves of it."""
    anim = _anim(ob)
    current = anim.action
    if current is not None and not is_stream_action(current) and STASHED_PROP not in ob:
        current.use_fake_user = True  # the user's animation stays in the file; Remove gives it back
        ob[STASHED_PROP] = current.name
    action = streams.action_for(ob)
    slot = _slot(action, ob)
    anim.action = action
    if slot is not None:
        anim.action_slot = slot
    _drop_unused(current)
    return lambda path, index: (
        _fcurves(action, slot).find(path, index=index) or _fcurves(action, slot).new(path, index=index)
    )


def clear_stream_motion(ob) -> None:
    """Take the imported streams off an object: NLA tracks and the active action, the user's back."""
    anim = ob.animation_data
    if anim is None:
        return
    for track in list(anim.nla_tracks):
        if any(is_stream_action(strip.action) for strip in track.strips):
            anim.nla_tracks.remove(track)
    current = anim.action
    if is_stream_action(current):
        anim.action = None
        _drop_unused(current)
    stashed = ob.get(STASHED_PROP)
    if stashed is not None:
        action = bpy.data.actions.get(stashed)
        if action is not None and anim.action is None:
            anim.action = action
        del ob[STASHED_PROP]
    if CREATED_ANIM_PROP in ob:
        if anim.action is None and not anim.nla_tracks and not anim.drivers:
            ob.animation_data_clear()
        del ob[CREATED_ANIM_PROP]


def _drop_unused(action) -> None:
    if is_stream_action(action) and action.users == 0:
        bpy.data.actions.remove(action)


def remove_streams(objects) -> int:
    """Remove every imported stream from `objects` and the file; returns how many actions went."""
    before = sum(1 for a in bpy.data.actions if is_stream_action(a))
    for ob in objects:
        clear_stream_motion(ob)
    for action in [a for a in bpy.data.actions if is_stream_action(a) and a.users == 0]:
        bpy.data.actions.remove(action)
    return before - sum(1 for a in bpy.data.actions if is_stream_action(a))


# ----------------------------------------------------------------------------- keys


def _channelbag(ob):
    anim = ob.animation_data
    if anim is None or anim.action is None:
        return None
    action = anim.action
    if not SLOTTED:
        return action
    from bpy_extras import anim_utils

    return anim_utils.action_get_channelbag_for_slot(action, anim.action_slot)


def find_fcurve(ob, path: str, index: int):
    bag = _channelbag(ob)
    return None if bag is None else bag.fcurves.find(path, index=index)


def ensure_fcurve(ob, path: str, index: int, action_name: str):
    """The F-curve for ob.path[index] in its active action, creating animation data, action and slot."""
    anim = ob.animation_data or ob.animation_data_create()
    if anim.action is None:
        anim.action = bpy.data.actions.new(action_name)
    if hasattr(anim.action, "fcurve_ensure_for_datablock"):
        return anim.action.fcurve_ensure_for_datablock(ob, path, index=index)
    from bpy_extras import anim_utils

    bag = anim_utils.action_ensure_channelbag_for_slot(anim.action, anim.action_slot) if SLOTTED else anim.action
    return bag.fcurves.find(path, index=index) or bag.fcurves.new(path, index=index)


def linear_keys(frames: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The linear keys, (K, 2) float32 (frame, value), that give `values` at `frames` (increasing): a key inside
    a run of equal values is left out. Between a run's two ends a linear key evaluates to v + t * (v - v) = v
    exactly, so the curve gives the same value at every frame and between frames, with a fraction of the keys
    (most of a stream's curves are flat most of the time: most FPs move on few FAPs)."""
    co = np.empty((len(frames), 2), dtype=np.float32)
    co[:, 0], co[:, 1] = frames, values
    v = co[:, 1]  # compared as stored: float32
    keep = np.ones(len(v), dtype=bool)
    keep[1:-1] = (v[1:-1] != v[:-2]) | (v[1:-1] != v[2:])
    return co[keep]


def set_keys(fcurve, frames: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Replace all keys of `fcurve` with the linear keys giving `values` at `frames` (`linear_keys`); returns
    them as the curve now holds them (what `foreach_get("co")` reads back)."""
    co = linear_keys(frames, values)
    points = fcurve.keyframe_points
    points.clear()
    points.add(len(co))
    points.foreach_set("co", co.ravel())
    points.foreach_set("interpolation", np.full(len(co), LINEAR, dtype=np.int32))
    fcurve.update()  # the handles (drawn in the Graph Editor); keys in order stay where they are
    return co


def sample(ob, path: str, index: int, frames: np.ndarray, default: float) -> np.ndarray:
    """Values of ob.path[index] at `frames` from its F-curve, or `default` when it is not animated."""
    fcurve = find_fcurve(ob, path, index)
    if fcurve is None:
        return np.full(len(frames), default)
    return np.array([fcurve.evaluate(float(f)) for f in frames])
