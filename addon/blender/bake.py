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

from ..formats.pc2 import write_pc2
from . import animation, face_data, live
from .reporting import UserError, progress

CACHE_MODIFIER = "MPEG-4 Bake"


def deformed_positions(mesh) -> np.ndarray:
    block = mesh.shape_keys.key_blocks.get(face_data.SHAPE_KEY_NAME) if mesh.shape_keys else None
    if block is None:
        return face_data.read_positions(mesh)
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    block.data.foreach_get("co", out)
    return out.reshape(-1, 3)


def collect(context, face, frames) -> np.ndarray:
    """(F, N, 3) float32 deformed positions at each frame (the scene's frame is put back after)."""
    if not face.mpeg4_face.enabled:
        raise UserError(f"turn on Deform for {face.name} before baking")
    scene = context.scene
    current = scene.frame_current
    out = np.empty((len(frames), len(face.data.vertices), 3), dtype=np.float32)
    try:
        with progress(context, len(frames)) as step:
            for i, frame in enumerate(frames):
                scene.frame_set(frame)
                if not live.apply_face(face):
                    raise UserError(face.mpeg4_face.status)
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
    with progress(context, len(frames)) as step:
        for i, frame in enumerate(frames):
            block = face.shape_key_add(name=f"MPEG-4 frame {frame}", from_mix=False)
            block.data.foreach_set("co", positions[i].ravel())
            fcurve = animation.ensure_fcurve(
                mesh.shape_keys, f'key_blocks["{block.name}"].value', 0, f"{face.name} MPEG-4 bake"
            )
            keys = np.array([frame - 1, frame, frame + 1], dtype=np.float64)
            animation.set_keys(fcurve, keys, np.array([0.0, 1.0, 0.0]))
            step(i)
    return [f"baked {len(frames)} frames to shape keys; live deformation turned off"]


def bake_point_cache(context, face, frames, path: str | None = None) -> list[str]:
    frames = list(frames)
    if not path:
        if not bpy.data.filepath:
            raise UserError("save the .blend first (the cache goes next to it) or give a cache file path")
        path = f"//{bpy.path.clean_name(face.name)}_mpeg4.pc2"
    absolute = bpy.path.abspath(path)
    if not os.path.isdir(os.path.dirname(absolute) or "."):
        raise UserError(f"folder does not exist: {os.path.dirname(absolute)}")
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
