"""Bake the live deformation so the animation plays without this extension.

Both targets first step through the frames once with the live effect on and collect the deformed
positions, then turn the effect off (which restores the rest mesh) and store them:
- shape keys: one key per frame, keyed to 1 on its frame and 0 on its neighbours;
- point cache: a .pc2 file read by a Mesh Cache modifier put first in the stack.
Alembic export (Blender's own exporter) of a baked face then needs nothing from us.
"""

from __future__ import annotations

import os

import bpy
import numpy as np

from ..errors import Mpeg4Error
from ..formats.pc2 import write_pc2
from . import animation, live, rest_shape
from .face_data import CREATED_PROP
from .reporting import progress

CACHE_MODIFIER = "MPEG-4 Bake"


BAKED_KEY_PREFIX = "MPEG-4 frame "
CREATED_BASIS_PROP = "mpeg4_bake_created_basis"  # on the mesh: the bake added the Basis key


def deformed_positions(mesh) -> np.ndarray:
    block = mesh.shape_keys.key_blocks.get(rest_shape.SHAPE_KEY_NAME) if mesh.shape_keys else None
    if block is None:
        return rest_shape.read_positions(mesh)
    return rest_shape.read_key(block)


def collect(context, face, frames) -> np.ndarray:
    """(F, N, 3) float32 deformed positions at each frame (the scene's frame is put back after)."""
    if not face.mpeg4_face.enabled:
        raise Mpeg4Error(f"turn on Deform for {face.name} before baking")
    scene = context.scene
    current = scene.frame_current
    out = np.empty((len(frames), len(face.data.vertices), 3), dtype=np.float32)
    try:
        with progress(context, len(frames)) as step:
            for i, frame in enumerate(frames):
                scene.frame_set(frame)
                if not live.apply_face(face):
                    raise Mpeg4Error(face.mpeg4_face.status)
                out[i] = deformed_positions(face.data)
                step(i)
    finally:
        scene.frame_set(current)
    return out


def bake_shape_keys(context, face, frames) -> list[str]:
    frames = list(frames)
    positions = collect(context, face, frames)
    face.mpeg4_face.enabled = False
    mesh = face.data
    if mesh.shape_keys is None:
        face.shape_key_add(name="Basis", from_mix=False)
        mesh[CREATED_BASIS_PROP] = True
    with progress(context, len(frames)) as step:
        for i, frame in enumerate(frames):
            block = face.shape_key_add(name=f"{BAKED_KEY_PREFIX}{frame}", from_mix=False)
            block.data.foreach_set("co", positions[i].ravel())
            fcurve = animation.ensure_fcurve(
                mesh.shape_keys, f'key_blocks["{block.name}"].value', 0, f"{face.name} MPEG-4 bake"
            )
            keys = np.array([frame - 1, frame, frame + 1], dtype=np.float64)
            animation.set_keys(fcurve, keys, np.array([0.0, 1.0, 0.0]))
            step(i)
    mesh.shape_keys.animation_data.action[CREATED_PROP] = True
    return [f"baked {len(frames)} frames to shape keys; live deformation turned off"]


def bake_point_cache(context, face, frames, path: str | None = None) -> list[str]:
    frames = list(frames)
    if not path:
        if not bpy.data.filepath:
            raise Mpeg4Error("save the .blend first (the cache goes next to it) or give a cache file path")
        path = f"//{bpy.path.clean_name(face.name)}_mpeg4.pc2"
    absolute = bpy.path.abspath(path)
    if not os.path.isdir(os.path.dirname(absolute) or "."):
        raise Mpeg4Error(f"folder does not exist: {os.path.dirname(absolute)}")
    positions = collect(context, face, frames)
    write_pc2(absolute, positions, start=float(frames[0]))
    face.mpeg4_face.enabled = False
    mod = face.modifiers.get(CACHE_MODIFIER) or face.modifiers.new(CACHE_MODIFIER, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = path
    mod.frame_start = float(frames[0])
    mod.frame_scale = 1.0
    with context.temp_override(object=face):
        bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    return [f"baked {len(frames)} frames to {absolute}; live deformation turned off"]


def remove_bakes(face) -> list[str]:
    """Remove what baking added: the Mesh Cache modifier, the baked shape keys, their action, a Basis it made."""
    notes = []
    mod = face.modifiers.get(CACHE_MODIFIER)
    if mod is not None:
        face.modifiers.remove(mod)
        notes.append("removed the point cache modifier (the .pc2 file stays on disk)")
    mesh = face.data
    key = mesh.shape_keys
    if key is None:
        return notes
    baked = [block for block in key.key_blocks if block.name.startswith(BAKED_KEY_PREFIX)]
    for block in baked:
        face.shape_key_remove(block)
    anim = key.animation_data
    if anim is not None and anim.action is not None and CREATED_PROP in anim.action:
        action = anim.action
        anim.action = None
        if action.users == 0:
            bpy.data.actions.remove(action)
    if mesh.get(CREATED_BASIS_PROP) and mesh.shape_keys is not None and len(mesh.shape_keys.key_blocks) == 1:
        face.shape_key_remove(mesh.shape_keys.key_blocks[0])
    if CREATED_BASIS_PROP in mesh:
        del mesh[CREATED_BASIS_PROP]
    if baked:
        notes.append(f"removed {len(baked)} baked shape keys")
    return notes
