"""What fitting keeps with the face: the generic face it started from, the DFFD binding of that generic face,
and what an FDP import changed for its texture; and putting all of it back (Back to Generic, Remove).

Everything lives on a hidden Text data-block of its own, '.MPEG-4 fitting <face>', that the face points to
with the custom property `mpeg4_fitting` (off the mesh, like the Planar Bones binding: the depsgraph copies
a mesh's ID properties whenever its positions are written). On it:
- "dffd": the arrays of `DffdBinding.to_arrays` with the digest of the generic rest shape and FPs they were
  computed from (Escher et al. §3.1.1: "performed only once for each generic head and saved"). Loading
  accepts only the dtypes and shapes a binding has before `DffdBinding.from_arrays` checks the values.
- "generic": the generic face (`FaceShape`): its rest positions and shape keys as float32 (restored bit for
  bit), the FP empties' neutral positions, and the rigid parts' transforms.
- "texture": the UV map, material, image and nodes an FDP import made or changed, to take them away again.
Objects, materials and images are recorded by name: an ID pointer in a property would keep a deleted
object alive in the file.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from dataclasses import dataclass

import bpy
import numpy as np

from ..errors import Mpeg4Error
from ..fitting.dffd import DffdBinding
from ..fitting.errors import BindingError
from ..mpeg4.feature_points import FP_IDS
from . import face_data, rest_shape
from .face_data import CREATED_PROP

HOLDER_PROP = "mpeg4_fitting"
DFFD_PROP, GENERIC_PROP, TEXTURE_PROP = "dffd", "generic", "texture"
UV_MAP_NAME = "MPEG-4 FDP"
IMAGE_NODE, UV_NODE = "MPEG-4 FDP image", "MPEG-4 FDP UV"
# the dtypes of `DffdBinding.to_arrays` (int64 is stored as int32, the widest integer an ID property holds)
STORED_DTYPES = {"<f8": np.float64, "<i4": np.int32, "<i8": np.int64}
MAX_NDIM = 2
FP_ID_LENGTH = 8  # DFFD binding ids are saved as U8

_cache: dict[str, DffdBinding] = {}  # digest -> binding; a digest names one generic face, so undo cannot stale it


# ----------------------------------------------------------------------------- the holder


def holder(face: bpy.types.Object) -> bpy.types.Text | None:
    held = face.get(HOLDER_PROP)
    return held if isinstance(held, bpy.types.Text) else None


def _own_holder(face: bpy.types.Object) -> bpy.types.Text:
    """The face's holder, created on first use; a copy when a duplicated face shares it."""
    held = holder(face)
    if held is None:
        held = bpy.data.texts.new(f".MPEG-4 fitting {face.name}")
        held.use_fake_user = False  # the face's property keeps it; texts are made with a fake user
        held[CREATED_PROP] = True
    elif held.users > 1:
        held = held.copy()
        held.use_fake_user = False
    face[HOLDER_PROP] = held
    return held


def remove_holder(face: bpy.types.Object) -> None:
    held = holder(face)
    if HOLDER_PROP in face:
        del face[HOLDER_PROP]
    if held is not None and held.users == int(held.use_fake_user) and CREATED_PROP in held:
        bpy.data.texts.remove(held)


# ----------------------------------------------------------------------------- the DFFD binding


def binding_key(rest: np.ndarray, fps: Mapping[str, np.ndarray]) -> str:
    """A digest of the generic face a DFFD binding is computed from (rest positions and FPs)."""
    h = hashlib.blake2b(digest_size=16)
    h.update(np.ascontiguousarray(rest, dtype=np.float64).tobytes())
    for fp_id in sorted(fps):
        h.update(fp_id.encode())
        h.update(np.asarray(fps[fp_id], dtype=np.float64).tobytes())
    return h.hexdigest()


def save_binding(face: bpy.types.Object, binding: DffdBinding, key: str) -> None:
    group: dict[str, object] = {"key": key}
    for name, array in binding.to_arrays().items():
        if array.dtype.kind == "U":
            group[name] = [str(text) for text in array.ravel()]
        else:
            stored = array.astype(np.int32) if array.dtype.kind == "i" else array
            group[name] = np.ascontiguousarray(stored).ravel()
            group[name + ".dtype"] = array.dtype.str
        group[name + ".shape"] = list(array.shape)
    _own_holder(face)[DFFD_PROP] = group
    _cache.clear()
    _cache[key] = binding


def stored_binding_key(face: bpy.types.Object) -> str | None:
    held = holder(face)
    group = held.get(DFFD_PROP) if held is not None else None
    key = group.get("key") if group is not None and hasattr(group, "keys") else None
    return key if isinstance(key, str) else None


def load_binding(face: bpy.types.Object, key: str) -> DffdBinding | None:
    """The DFFD binding of the generic face with digest `key`: cached, saved on the face, or None."""
    if key in _cache:
        return _cache[key]
    held = holder(face)
    group = held.get(DFFD_PROP) if held is not None else None
    if group is None or not hasattr(group, "keys") or group.get("key") != key:
        return None
    arrays = {}
    for name in group.keys():
        if name == "key" or name.endswith((".shape", ".dtype")):
            continue
        array = _stored_array(group, name)
        if array is None:
            return None
        arrays[name] = array
    try:
        binding = DffdBinding.from_arrays(arrays)
    except BindingError:
        return None
    _cache.clear()
    _cache[key] = binding
    return binding


def _stored_array(group, name: str) -> np.ndarray | None:
    """The array `name` of a stored group, or None when its dtype or shape is not one a DFFD binding has."""
    data, shape = group.get(name), group.get(name + ".shape")
    if not hasattr(shape, "__len__") or len(shape) > MAX_NDIM or any(not isinstance(n, int) or n < 0 for n in shape):
        return None
    shape = tuple(shape)
    size = int(np.prod(shape, dtype=np.int64))
    if name + ".dtype" not in group:  # text; an empty list is stored as an empty array
        data = _entries(data)
        if data is None or len(data) != size:
            return None
        if not all(isinstance(text, str) and len(text) <= FP_ID_LENGTH for text in data):
            return None
        return np.array(data, dtype=f"U{FP_ID_LENGTH}").reshape(shape)
    dtype = STORED_DTYPES.get(group.get(name + ".dtype"))
    if dtype is None or not hasattr(data, "to_list") or len(data) != size:
        return None
    return np.array(data, dtype=dtype).reshape(shape)


# ----------------------------------------------------------------------------- the face's shape


@dataclass(frozen=True)
class PartPose:
    """An object's own transform (not its deltas, which followers drive)."""

    location: tuple[float, ...]
    rotation_mode: str
    rotation_euler: tuple[float, ...]
    rotation_quaternion: tuple[float, ...]
    rotation_axis_angle: tuple[float, ...]
    scale: tuple[float, ...]

    @classmethod
    def of(cls, ob: bpy.types.Object) -> PartPose:
        return cls(
            tuple(ob.location),
            ob.rotation_mode,
            tuple(ob.rotation_euler),
            tuple(ob.rotation_quaternion),
            tuple(ob.rotation_axis_angle),
            tuple(ob.scale),
        )

    def apply(self, ob: bpy.types.Object) -> None:
        ob.rotation_mode = self.rotation_mode
        ob.location = self.location
        ob.rotation_euler = self.rotation_euler
        ob.rotation_quaternion = self.rotation_quaternion
        ob.rotation_axis_angle = self.rotation_axis_angle
        ob.scale = self.scale


@dataclass
class FaceShape:
    """A face as fitting writes it: mesh, FP empties and rigid parts."""

    rest: np.ndarray  # (N, 3) float32: the rest shape set-up binds (its rest copy; the reference key)
    positions: np.ndarray  # (N, 3) float32: the mesh's `position` attribute
    keys: dict[str, np.ndarray]  # shape key name -> (N, 3) float32
    fps: dict[str, np.ndarray]  # FP id -> face-local location of its empty
    parts: dict[str, PartPose]  # object name -> its transform


def rest_now(face: bpy.types.Object) -> np.ndarray:
    """The rest shape the face was set up with (float32), refused when the mesh changed since."""
    mesh = face.data
    rest = rest_shape.reference_positions(mesh)
    changed = rest is None or len(rest) != len(mesh.vertices)
    if not changed and mesh.shape_keys is None and not face.mpeg4_face.enabled:
        changed = not np.array_equal(rest, rest_shape.read_positions(mesh))
    if changed:
        raise Mpeg4Error(f"{face.name}'s mesh changed since set-up: run Set Up Face first")
    return rest


def capture(face: bpy.types.Object, fps: Mapping[str, np.ndarray], parts) -> FaceShape:
    """The face as it is now, with `fps` as its FP locations and the transforms of the objects `parts`."""
    mesh = face.data
    keys = {}
    if mesh.shape_keys is not None:
        keys = {block.name: rest_shape.read_key(block).copy() for block in mesh.shape_keys.key_blocks}
    return FaceShape(
        rest=rest_now(face).copy(),
        positions=rest_shape.read_positions(mesh).copy(),
        keys=keys,
        fps={fp_id: np.asarray(p, dtype=np.float64).copy() for fp_id, p in fps.items()},
        parts={ob.name: PartPose.of(ob) for ob in parts},
    )


def put(face: bpy.types.Object, shape: FaceShape) -> None:
    """Write `shape` into the face: positions, rest copy and keys bit for bit, FP empties, part transforms."""
    mesh = face.data
    if mesh.shape_keys is not None:
        for block in mesh.shape_keys.key_blocks:
            co = shape.keys.get(block.name)
            if co is not None:
                block.data.foreach_set("co", co.ravel())
    mesh.attributes["position"].data.foreach_set("vector", shape.positions.ravel())
    mesh.update()
    rest_shape.store_rest(mesh, shape.rest)
    empties = face_data.fp_empties(face)
    for fp_id, location in shape.fps.items():
        empty = empties.get(fp_id)
        if empty is not None and tuple(empty.location) != tuple(location):
            empty.location = location
    for name, pose in shape.parts.items():
        ob = bpy.data.objects.get(name)
        if ob is not None:
            pose.apply(ob)


def save_generic(face: bpy.types.Object, shape: FaceShape) -> None:
    _own_holder(face)[GENERIC_PROP] = {
        "rest": np.ascontiguousarray(shape.rest, dtype=np.float32).ravel(),
        "keys": [{"name": name, "co": np.ascontiguousarray(co, np.float32).ravel()} for name, co in shape.keys.items()],
        "fps": {fp_id: [float(v) for v in p] for fp_id, p in shape.fps.items()},
        "parts": [
            {
                "name": name,
                "location": list(pose.location),
                "rotation_mode": pose.rotation_mode,
                "rotation_euler": list(pose.rotation_euler),
                "rotation_quaternion": list(pose.rotation_quaternion),
                "rotation_axis_angle": list(pose.rotation_axis_angle),
                "scale": list(pose.scale),
            }
            for name, pose in shape.parts.items()
        ],
    }


def has_generic(face: bpy.types.Object) -> bool:
    held = holder(face)
    return held is not None and GENERIC_PROP in held


def load_generic(face: bpy.types.Object) -> FaceShape | None:
    """The recorded generic face, or None when there is none or it does not fit the mesh any more."""
    held = holder(face)
    group = held.get(GENERIC_PROP) if held is not None else None
    if group is None or not hasattr(group, "keys"):
        return None
    n = len(face.data.vertices)
    rest = _float32_positions(group.get("rest"), n)
    key_entries, part_entries, stored_fps = _entries(group.get("keys")), _entries(group.get("parts")), group.get("fps")
    if rest is None or key_entries is None or part_entries is None or not hasattr(stored_fps, "keys"):
        return None
    keys = {}
    for entry in key_entries:
        co = _float32_positions(entry.get("co"), n) if hasattr(entry, "keys") else None
        if co is None or not isinstance(entry.get("name"), str):
            return None
        keys[entry["name"]] = co
    fps = {}
    for fp_id in stored_fps.keys():
        p = stored_fps.get(fp_id) if fp_id in FP_IDS else None
        if not hasattr(p, "to_list") or len(p) != 3 or not np.all(np.isfinite(p)):
            return None
        fps[fp_id] = np.array(p, dtype=np.float64)
    parts = {}
    for entry in part_entries:
        pose = _part_pose(entry)
        if pose is None:
            return None
        parts[entry["name"]] = pose
    return FaceShape(rest, rest.copy(), keys, fps, parts)


def _entries(value) -> list | None:
    """A stored list (an empty one comes back as an empty array), or None."""
    if isinstance(value, list):
        return value
    return [] if hasattr(value, "to_list") and len(value) == 0 else None


def _float32_positions(data, n: int) -> np.ndarray | None:
    if not hasattr(data, "to_list") or len(data) != 3 * n or getattr(data, "typecode", "") != "f":
        return None
    return np.array(data, dtype=np.float32).reshape(n, 3)


_POSE_SIZES = {"location": 3, "rotation_euler": 3, "rotation_quaternion": 4, "rotation_axis_angle": 4, "scale": 3}
_ROTATION_MODES = {"QUATERNION", "AXIS_ANGLE", "XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"}


def _part_pose(entry) -> PartPose | None:
    if not hasattr(entry, "keys") or not isinstance(entry.get("name"), str):
        return None
    if entry.get("rotation_mode") not in _ROTATION_MODES:
        return None
    values = {}
    for name, size in _POSE_SIZES.items():
        value = entry.get(name)
        if not hasattr(value, "to_list") or len(value) != size or not np.all(np.isfinite(value)):
            return None
        values[name] = tuple(float(v) for v in value)
    return PartPose(rotation_mode=entry["rotation_mode"], **values)


# ----------------------------------------------------------------------------- texture (FDP import)


def apply_texture(face: bpy.types.Object, uvs: np.ndarray, image: bpy.types.Image | None, image_created: bool) -> None:
    """Per-vertex `uvs` into the UV map "MPEG-4 FDP" and `image` into the face's material, recorded so that
    `restore_texture` takes exactly that away. A previous import's changes are taken away first."""
    restore_texture(face)
    mesh = face.data
    record: dict[str, object] = {"uv": UV_MAP_NAME, "uv_created": UV_MAP_NAME not in mesh.uv_layers}
    layer = mesh.uv_layers.get(UV_MAP_NAME) or mesh.uv_layers.new(name=UV_MAP_NAME, do_init=False)
    record["uv"] = layer.name
    loop_vertex = face_data.mesh_corners(mesh)[1]
    layer.data.foreach_set("uv", np.ascontiguousarray(uvs[loop_vertex], dtype=np.float32).ravel())
    if image is not None:
        record.update(_image_into_material(face, image, layer.name))
        record["image"], record["image_created"] = image.name, image_created
    _own_holder(face)[TEXTURE_PROP] = record


def _image_into_material(face: bpy.types.Object, image: bpy.types.Image, uv_name: str) -> dict[str, object]:
    record: dict[str, object] = {"material_created": False, "slot": -1, "slot_appended": False}
    material = face.active_material
    if material is None:
        material = bpy.data.materials.new(f"{face.name} FDP")
        record["material_created"] = True
        if len(face.material_slots) == 0:
            face.data.materials.append(material)
            record["slot_appended"] = True
        else:
            record["slot"] = face.active_material_index
            face.material_slots[face.active_material_index].material = material
    record["material"] = material.name
    tree = material.node_tree
    if tree is None:  # Blender before 5.0 makes node-less materials
        material.use_nodes = True
        tree = material.node_tree
        record["used_nodes"] = True
    nodes = tree.nodes
    record["active_node"] = nodes.active.name if nodes.active is not None else ""
    texture = nodes.new("ShaderNodeTexImage")
    texture.name = texture.label = IMAGE_NODE
    texture.image = image
    uv = nodes.new("ShaderNodeUVMap")
    uv.name = uv.label = UV_NODE
    uv.uv_map = uv_name
    tree.links.new(uv.outputs["UV"], texture.inputs["Vector"])
    record["nodes"] = [texture.name, uv.name]
    shader = next((node for node in nodes if node.type == "BSDF_PRINCIPLED"), None)
    if shader is not None:
        socket = shader.inputs["Base Color"]
        before = socket.links[0] if socket.is_linked else None
        record["shader"] = shader.name
        record["link"] = [before.from_node.name, before.from_socket.identifier] if before is not None else []
        tree.links.new(texture.outputs["Color"], socket)
    texture.location = (shader.location.x - 300, shader.location.y) if shader is not None else (-300, 0)
    uv.location = (texture.location.x - 200, texture.location.y)
    nodes.active = texture  # Workbench's Texture colour shows the active image node
    return record


def restore_texture(face: bpy.types.Object) -> bool:
    """Take away what `apply_texture` made or changed; True when there was something."""
    held = holder(face)
    record = held.get(TEXTURE_PROP) if held is not None else None
    if record is None:
        return False
    mesh = face.data
    material = bpy.data.materials.get(record.get("material", "")) if "material" in record else None
    tree = material.node_tree if material is not None else None
    if tree is not None:
        for name in record.get("nodes", []):
            node = tree.nodes.get(name)
            if node is not None:
                tree.nodes.remove(node)
        shader = tree.nodes.get(record.get("shader", ""))
        link = list(record.get("link", []))
        if shader is not None and len(link) == 2 and link[0] in tree.nodes:
            output = next((s for s in tree.nodes[link[0]].outputs if s.identifier == link[1]), None)
            if output is not None:
                tree.links.new(output, shader.inputs["Base Color"])
        tree.nodes.active = tree.nodes.get(record.get("active_node", ""))
        if record.get("used_nodes"):
            material.use_nodes = False
    if material is not None and record.get("material_created"):
        if record.get("slot_appended"):
            index = next((i for i, m in enumerate(mesh.materials) if m == material), None)
            if index is not None:
                mesh.materials.pop(index=index)
                face.data = mesh  # the object's own slot list follows its data only when the data is set
        elif 0 <= record.get("slot", -1) < len(face.material_slots):
            face.material_slots[record["slot"]].material = None
        if material.users == 0:
            bpy.data.materials.remove(material)
    image = bpy.data.images.get(record.get("image", "")) if "image" in record else None
    if image is not None and record.get("image_created") and image.users == 0:
        bpy.data.images.remove(image)
    layer = mesh.uv_layers.get(record.get("uv", ""))
    if layer is not None and record.get("uv_created"):
        mesh.uv_layers.remove(layer)
    del held[TEXTURE_PROP]
    return True


# ----------------------------------------------------------------------------- Remove


def remove_fitting(face: bpy.types.Object) -> list[str]:
    """Remove Set-Up: the generic face back (mesh, FPs, rigid parts), texture changes taken away, holder gone."""
    notes = []
    if holder(face) is None:
        return notes
    generic = load_generic(face)
    if generic is not None:
        put(face, generic)
        notes.append(f"put {face.name} back to its generic shape")
    elif has_generic(face):
        notes.append(f"{face.name}'s generic shape no longer fits its mesh: the fitted shape is kept")
    if restore_texture(face):
        notes.append("removed the FDP texture coordinates and image")
    remove_holder(face)
    return notes
