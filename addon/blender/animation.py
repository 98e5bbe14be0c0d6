"""F-curves in bulk, across Blender versions.

Blender 4.4 introduced slotted actions and 5.0 removed `Action.fcurves`; 4.2-4.3 only have the
latter. Keys are written with one `foreach_set` per curve, never one keyframe_insert per key.
"""

from __future__ import annotations

import bpy
import numpy as np

LINEAR = 1  # BEZT_IPO_LIN, the raw value of 'LINEAR' in KeyframePoint.interpolation


def _channelbag(ob, create: bool):
    anim = ob.animation_data
    if anim is None or anim.action is None:
        return None
    action = anim.action
    if not hasattr(action, "slots"):  # Blender 4.2-4.3
        return action
    from bpy_extras import anim_utils

    if create:
        return anim_utils.action_ensure_channelbag_for_slot(action, anim.action_slot)
    return anim_utils.action_get_channelbag_for_slot(action, anim.action_slot)


def find_fcurve(ob, path: str, index: int):
    bag = _channelbag(ob, create=False)
    return None if bag is None else bag.fcurves.find(path, index=index)


def ensure_fcurve(ob, path: str, index: int, action_name: str):
    """The F-curve for ob.path[index], creating animation data, action and slot as needed."""
    anim = ob.animation_data or ob.animation_data_create()
    if anim.action is None:
        anim.action = bpy.data.actions.new(action_name)
    if hasattr(anim.action, "fcurve_ensure_for_datablock"):
        return anim.action.fcurve_ensure_for_datablock(ob, path, index=index)
    bag = _channelbag(ob, create=True)
    return bag.fcurves.find(path, index=index) or bag.fcurves.new(path, index=index)


def set_keys(fcurve, frames: np.ndarray, values: np.ndarray) -> None:
    """Replace all keys of `fcurve` with linear keys at `frames`."""
    points = fcurve.keyframe_points
    points.clear()
    points.add(len(frames))
    co = np.empty((len(frames), 2), dtype=np.float32)
    co[:, 0], co[:, 1] = frames, values
    points.foreach_set("co", co.ravel())
    points.foreach_set("interpolation", np.full(len(frames), LINEAR, dtype=np.int32))
    fcurve.update()


def sample(ob, path: str, index: int, frames: np.ndarray, default: float) -> np.ndarray:
    """Values of ob.path[index] at `frames` from its F-curve, or `default` when it is not animated."""
    fcurve = find_fcurve(ob, path, index)
    if fcurve is None:
        return np.full(len(frames), default)
    return np.array([fcurve.evaluate(float(f)) for f in frames])
