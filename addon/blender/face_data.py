"""Where a face's MPEG-4 data lives in Blender, and fast reads and writes of it.

- FP empties: objects with the custom property `mpeg4_fp` = FP id, in the face's FP collection.
- Control mesh: a mesh object whose vertices are the control FPs (ids in its data's `mpeg4_fp_ids`).
- Rest positions: float32 copy of the face's vertex positions at set-up (`mpeg4_rest` on the mesh data),
  so turning the effect off restores the mesh bit for bit.
- Binding: the deformer's arrays as ID property arrays under `mpeg4_binding` on the mesh data, saved
  with the .blend (reading them back is a buffer copy, no Python objects per value).

A mesh with shape keys ignores writes to its positions, so there the deformed positions go into a
shape key of our own (relative to the reference key, value 1) and the user's keys still add on top.
Data is always looked up by name or pointer on each call: undo invalidates Python references.
"""

from __future__ import annotations

import dataclasses
import hashlib

import bpy
import numpy as np

from ..deform.planar_bones import Binding
from ..mpeg4.feature_points import FP_IDS, fp_index

FP_PROP = "mpeg4_fp"
CREATED_PROP = "mpeg4_created"  # on objects set-up created (and remove may delete)
FP_IDS_PROP = "mpeg4_fp_ids"
# "the shape at set-up": on the face's and the control mesh's data the float32 vertex positions, on each
# FP empty its face-local location (the neutral face)
REST_PROP = "mpeg4_rest"
EMPTY_REST_PROP = REST_PROP
BINDING_PROP = "mpeg4_binding"
BINDING_KEY_PROP = "mpeg4_binding_key"
SHAPE_KEY_NAME = "MPEG-4 Planar Bones"


def fp_collection_name(face: bpy.types.Object) -> str:
    return f"{face.name} FPs"


def fp_collection(face: bpy.types.Object) -> bpy.types.Collection | None:
    """The face's FP collection: the one set-up recorded, else the one named '<face> FPs'."""
    return face.mpeg4_face.fp_collection or bpy.data.collections.get(fp_collection_name(face))


def fp_empties(face: bpy.types.Object) -> dict[str, bpy.types.Object]:
    """FP id -> empty in the face's FP collection, by the empties' `mpeg4_fp` property."""
    coll = fp_collection(face)
    if coll is None:
        return {}
    found = {}
    for ob in coll.all_objects:
        fp_id = ob.get(FP_PROP)
        if ob.type == "EMPTY" and fp_id in FP_IDS and fp_id not in found:
            found[fp_id] = ob
    return found


def local_positions(face: bpy.types.Object, objects: dict[str, bpy.types.Object]) -> dict[str, np.ndarray]:
    """World positions of `objects` expressed in the face's local (mesh) coordinates, float64."""
    if not objects:
        return {}
    world = np.array([ob.matrix_world.translation for ob in objects.values()], dtype=np.float64)
    inv = np.array(face.matrix_world.inverted(), dtype=np.float64)
    local = world @ inv[:3, :3].T + inv[:3, 3]
    return dict(zip(objects, local, strict=True))


def neutral_array(positions: dict[str, np.ndarray]) -> np.ndarray:
    """(84, 3) in FP_IDS order, NaN for missing FPs."""
    out = np.full((len(FP_IDS), 3), np.nan)
    for fp_id, p in positions.items():
        out[fp_index(fp_id)] = p
    return out


def group_weights(ob: bpy.types.Object, names) -> dict[str, np.ndarray]:
    """(N,) weights of the vertex groups called `names` that `ob` has (0 where a vertex is not in one)."""
    index = {g.index: g.name for g in ob.vertex_groups if g.name in names}
    weights = {name: np.zeros(len(ob.data.vertices)) for name in index.values()}
    if index:
        for v in ob.data.vertices:
            for g in v.groups:
                name = index.get(g.group)
                if name is not None:
                    weights[name][v.index] = g.weight
    return weights


# ----------------------------------------------------------------------------- mesh positions


def read_positions(mesh: bpy.types.Mesh) -> np.ndarray:
    """(N, 3) float32 positions of the base mesh (the `position` attribute)."""
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3)


def reference_positions(mesh: bpy.types.Mesh) -> np.ndarray:
    """Where the deformer starts from: the reference shape key if there are keys, else the rest copy."""
    key = mesh.shape_keys
    if key is not None:
        out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        key.reference_key.data.foreach_get("co", out)
        return out.reshape(-1, 3)
    return stored_rest(mesh)


def stored_rest(mesh: bpy.types.Mesh) -> np.ndarray | None:
    rest = mesh.get(REST_PROP)
    if rest is None:
        return None
    return np.array(rest, dtype=np.float32).reshape(-1, 3)


def store_rest(mesh: bpy.types.Mesh) -> np.ndarray:
    rest = read_positions(mesh) if mesh.shape_keys is None else reference_positions(mesh)
    mesh[REST_PROP] = rest.ravel()
    return rest


def deform_target(mesh: bpy.types.Mesh):
    """Our shape key on a mesh with shape keys (created on first use), else None (write positions)."""
    key = mesh.shape_keys
    if key is None:
        return None
    block = key.key_blocks.get(SHAPE_KEY_NAME)
    if block is None:
        # creating a key from the reference copies it, so the mesh looks the same until we write
        block = bpy.data.objects[_owner_name(mesh)].shape_key_add(name=SHAPE_KEY_NAME, from_mix=False)
        block.relative_key = key.reference_key
        block.value = 1.0
    return block


def _owner_name(mesh: bpy.types.Mesh) -> str:
    for ob in bpy.data.objects:
        if ob.data == mesh:
            return ob.name
    raise LookupError(f"no object uses mesh {mesh.name!r}")


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
    """Put the mesh back exactly as it was at set-up."""
    key = mesh.shape_keys
    if key is not None:
        block = key.key_blocks.get(SHAPE_KEY_NAME)
        if block is not None:
            ref = reference_positions(mesh)
            block.data.foreach_set("co", ref.ravel())
            mesh.update()
        return
    rest = stored_rest(mesh)
    if rest is not None and len(rest) == len(mesh.vertices):
        mesh.attributes["position"].data.foreach_set("vector", rest.ravel())
        mesh.update()


# ----------------------------------------------------------------------------- binding storage


def binding_key(
    rest: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray, params: dict, masks: dict[str, np.ndarray]
) -> str:
    """A digest of everything a binding depends on, to tell whether a stored binding is still valid."""
    h = hashlib.blake2b(digest_size=16)
    for arr in (rest, control_rest, triangles, *(masks[k] for k in sorted(masks))):
        h.update(np.ascontiguousarray(arr).tobytes())
    h.update(repr(sorted(params.items())).encode())
    h.update(repr(sorted(masks)).encode())
    return h.hexdigest()


def store_binding(mesh: bpy.types.Mesh, binding: Binding, key: str) -> None:
    group = {}
    for field in dataclasses.fields(binding):
        if not field.init:
            continue
        value = getattr(binding, field.name)
        if isinstance(value, np.ndarray):
            # ID property arrays hold int32, float32 and float64
            stored = value.astype(np.int32) if value.dtype.kind in "iub" else value
            group[field.name] = np.ascontiguousarray(stored).ravel()
            group[field.name + ".shape"] = list(value.shape) or [0]
            group[field.name + ".dtype"] = value.dtype.str
        else:
            group[field.name] = value
    mesh[BINDING_PROP] = group
    mesh[BINDING_KEY_PROP] = key


def load_binding(mesh: bpy.types.Mesh) -> tuple[Binding, str] | None:
    group = mesh.get(BINDING_PROP)
    key = mesh.get(BINDING_KEY_PROP)
    if group is None or key is None:
        return None
    values = {}
    for field in dataclasses.fields(Binding):
        if not field.init:
            continue
        if field.name not in group:
            return None
        if field.name + ".shape" in group:
            shape = tuple(group[field.name + ".shape"])
            arr = np.array(group[field.name], dtype=np.dtype(group[field.name + ".dtype"]))
            values[field.name] = arr.reshape(shape if shape != (0,) or arr.size else (0,))
        else:
            values[field.name] = group[field.name]
    return Binding(**values), str(key)


def clear_binding(mesh: bpy.types.Mesh) -> None:
    for prop in (BINDING_PROP, BINDING_KEY_PROP, REST_PROP):
        if prop in mesh:
            del mesh[prop]
