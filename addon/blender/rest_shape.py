"""The face's rest shape and the fast reads and writes of its positions.

The rest shape is a float32 copy of the vertex positions at set-up (`mpeg4_rest` on the mesh data), so
turning the effect off restores the mesh bit for bit. A mesh with shape keys ignores writes to its
positions, so there the deformed positions go into a shape key of our own (relative to the reference
key, value 1) and the user's keys still add on top.
"""

from __future__ import annotations

import bpy
import numpy as np

from .face_data import REST_PROP

SHAPE_KEY_NAME = "MPEG-4 Planar Bones"


def read_positions(mesh: bpy.types.Mesh) -> np.ndarray:
    """(N, 3) float32 positions of the base mesh (the `position` attribute)."""
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3)


def read_key(block) -> np.ndarray:
    out = np.empty(len(block.data) * 3, dtype=np.float32)
    block.data.foreach_get("co", out)
    return out.reshape(-1, 3)


def reference_positions(mesh: bpy.types.Mesh) -> np.ndarray | None:
    """Where the deformer starts from: the reference shape key if there are keys, else the rest copy."""
    key = mesh.shape_keys
    if key is not None:
        return read_key(key.reference_key)
    return stored_rest(mesh)


def stored_rest(mesh: bpy.types.Mesh) -> np.ndarray | None:
    """The rest copy, or None when there is none or it does not fit the mesh (float32 triples only)."""
    rest = mesh.get(REST_PROP)
    if rest is None or not hasattr(rest, "to_list") or len(rest) != 3 * len(mesh.vertices):
        return None
    out = np.array(rest, dtype=np.float32)
    return out.reshape(-1, 3) if out.ndim == 1 else None


def current_rest(mesh: bpy.types.Mesh) -> np.ndarray:
    """The shape set-up binds: the reference key, else the base positions (call with the effect off)."""
    key = mesh.shape_keys
    return read_key(key.reference_key) if key is not None else read_positions(mesh)


def store_rest(mesh: bpy.types.Mesh, rest: np.ndarray) -> None:
    # delete first: assigning an ID-property array of another length in place can corrupt memory
    if REST_PROP in mesh:
        del mesh[REST_PROP]
    mesh[REST_PROP] = np.ascontiguousarray(rest, dtype=np.float32).ravel()


def clear_rest(mesh: bpy.types.Mesh) -> None:
    if REST_PROP in mesh:
        del mesh[REST_PROP]


def owner(mesh: bpy.types.Mesh) -> bpy.types.Object:
    for ob in bpy.data.objects:
        if ob.data == mesh:
            return ob
    raise LookupError(f"no object uses mesh {mesh.name!r}")


def deform_target(mesh: bpy.types.Mesh):
    """Our shape key on a mesh with shape keys (created on first use), else None (write positions)."""
    key = mesh.shape_keys
    if key is None:
        return None
    block = key.key_blocks.get(SHAPE_KEY_NAME)
    if block is None:
        # creating a key from the reference copies it, so the mesh looks the same until we write
        block = owner(mesh).shape_key_add(name=SHAPE_KEY_NAME, from_mix=False)
        block.relative_key = key.reference_key
        block.value = 1.0
    return block


def write_positions(mesh: bpy.types.Mesh, positions: np.ndarray) -> None:
    """Write (N, 3) positions the fast way: float32 into `position`, or into our shape key."""
    flat = np.ascontiguousarray(positions, dtype=np.float32).ravel()
    block = deform_target(mesh)
    if block is None:
        mesh.attributes["position"].data.foreach_set("vector", flat)
    else:
        block.data.foreach_set("co", flat)
    mesh.update()


def restore_rest(mesh: bpy.types.Mesh) -> None:
    """Put the mesh back exactly as it was at set-up (nothing happens when the rest copy no longer fits)."""
    key = mesh.shape_keys
    if key is not None:
        block = key.key_blocks.get(SHAPE_KEY_NAME)
        if block is not None:
            block.data.foreach_set("co", read_key(key.reference_key).ravel())
            mesh.update()
        return
    rest = stored_rest(mesh)
    if rest is not None:
        mesh.attributes["position"].data.foreach_set("vector", rest.ravel())
        mesh.update()


def remove_own_shape_key(face: bpy.types.Object) -> None:
    key = face.data.shape_keys
    if key is not None and SHAPE_KEY_NAME in key.key_blocks:
        face.shape_key_remove(key.key_blocks[SHAPE_KEY_NAME])
