"""Where a face's MPEG-4 data lives in Blender, and how to find it.

- FP empties: objects with the custom property `mpeg4_fp` = FP id, in the face's FP collection,
  children of the face with an identity parent inverse (so their location is face-local).
- Control mesh: a mesh object whose vertices are the control FPs (ids in its data's `mpeg4_fp_ids`).
- Rest shape (`rest_shape.py`) and binding (`binding_store.py`) live on the face's mesh data.
Data is always looked up by name or pointer on each call: undo invalidates Python references.
"""

from __future__ import annotations

import logging

import bpy
import numpy as np
from mathutils import Matrix

from ..deform.folds import fan_triangles
from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.feature_points import FP_IDS, fp_index

log = logging.getLogger(__name__)

FP_PROP = "mpeg4_fp"
CREATED_PROP = "mpeg4_created"  # on data set-up, import or bake created (and Remove deletes)
FP_IDS_PROP = "mpeg4_fp_ids"
TRIANGLE_MASKS_PROP = "mpeg4_triangle_masks"
FILLED_MASKS_PROP = "mpeg4_filled_masks"  # on the face: its mask groups that had no weight, which set-up filled
FACE_AXES_PROP = "mpeg4_face_axes"  # on the control mesh's data: the face frame's rows in mesh coordinates
# "the shape at set-up": on the face's and the control mesh's data the float32 vertex positions, on each
# FP empty its face-local location (the neutral face)
REST_PROP = "mpeg4_rest"
EMPTY_REST_PROP = REST_PROP


def active_face(context):
    """The face the user means: the active mesh, or the face of an active FP empty or control mesh."""
    ob = context.active_object
    if ob is None:
        return None
    if ob.type == "MESH" and (ob.mpeg4_face.control_object is not None or ob.mpeg4_face.fp_collection):
        return ob
    parent = ob.parent
    if parent is not None and parent.type == "MESH" and parent.mpeg4_face.control_object is not None:
        return parent
    return ob if ob.type == "MESH" else None


def face_axes(face: bpy.types.Object) -> np.ndarray:
    """(3, 3) the face frame set-up read from the FPs (x left, y up, z forward as rows, in mesh coordinates);
    a Blender character's frame for a face set up before set-up stored one."""
    control = face.mpeg4_face.control_object
    stored = control.data.get(FACE_AXES_PROP) if control is not None and control.type == "MESH" else None
    if stored is None or len(stored) != 9:
        return BLENDER_FACE_AXES
    return np.array(stored, dtype=np.float64).reshape(3, 3)


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


IDENTITY = Matrix.Identity(4)


def is_plain_child(face: bpy.types.Object, ob: bpy.types.Object) -> bool:
    """A child of the face whose location is its face-local position (no parent inverse or constraint)."""
    return (
        ob.parent == face and ob.parent_type == "OBJECT" and not ob.constraints and ob.matrix_parent_inverse == IDENTITY
    )


def local_positions(face: bpy.types.Object, objects: dict[str, bpy.types.Object]) -> dict[str, np.ndarray]:
    """Positions of `objects` in the face's local (mesh) coordinates, float64.

    A plain child's location is read directly: going through the float32 world matrices would lose
    about 1e-7 of the distance to the origin (0.1 mm at 1 km), and a face far from the origin would drift.
    """
    if not objects:
        return {}
    rows = [ob.location[:] if is_plain_child(face, ob) else None for ob in objects.values()]
    if any(row is None for row in rows):
        inv = np.array(face.matrix_world.inverted(), dtype=np.float64)
        for k, ob in enumerate(objects.values()):
            if rows[k] is None:
                rows[k] = inv[:3, :3] @ np.array(ob.matrix_world.translation, dtype=np.float64) + inv[:3, 3]
    return dict(zip(objects, np.array(rows, dtype=np.float64), strict=True))


class FpReader:
    """Face-local positions of chosen FP empties, read each frame in three `foreach_get` calls.

    The FP collection's objects are read together (session ids, locations, world matrices); the row of each
    wanted FP is cached and found again when the collection's objects change. The locations are taken as the
    face-local positions when every world matrix agrees with `face.matrix_world @ location` (plain children,
    the usual case; one product for all of them); otherwise the empties that disagree (a constraint, another
    parent, a delta transform, a world matrix not yet evaluated) go through `local_positions`, one by one.
    """

    def __init__(self, fp_ids: list[str]):
        self.fp_ids = fp_ids
        self._uids: bytes | None = None
        self._rows: np.ndarray | None = None
        # uids, locations, world matrices, [location 1] rows in float64: reused while the object count holds
        self._buffers: tuple[np.ndarray, ...] = ()

    def _find_rows(self, face: bpy.types.Object, objects, uids: np.ndarray) -> None:
        empties = fp_empties(face)
        missing = [fp_id for fp_id in self.fp_ids if fp_id not in empties]
        if missing:
            raise LookupError(f"feature point empties missing: {', '.join(missing)}")
        row_of = {ob.session_uid: row for row, ob in enumerate(objects)}
        self._rows = np.array([row_of[empties[fp_id].session_uid] for fp_id in self.fp_ids], dtype=np.intp)
        self._uids = uids.tobytes()

    def read(self, face: bpy.types.Object) -> np.ndarray:
        """(M, 3) float64 positions in `fp_ids` order; LookupError when an FP empty is missing."""
        coll = fp_collection(face)
        if coll is None:
            raise LookupError("the face's FP collection is missing")
        objects = coll.all_objects
        n = len(objects)
        if not self._buffers or len(self._buffers[0]) != n:
            homogeneous = np.ones((n, 4))
            self._buffers = (np.empty(n, np.int64), np.empty((n, 3), np.float32), np.empty((n, 4, 4), np.float32))
            self._buffers += (homogeneous,)
        uids, location, world, homogeneous = self._buffers
        objects.foreach_get("session_uid", uids)
        if self._uids is None or uids.tobytes() != self._uids:
            self._find_rows(face, objects, uids)
        objects.foreach_get("location", location.reshape(-1))
        objects.foreach_get("matrix_world", world.reshape(-1))
        homogeneous[:, :3] = location
        face_world = np.array(face.matrix_world, dtype=np.float64)
        error = homogeneous @ face_world[:3].T  # where each empty would be as a plain child of the face
        error -= world[:, 3, :3]  # column-major: the translation is row 3
        # float32 matrices: agreement to ~16 ulps of the largest term (one bound for all: the largest location)
        scale = 1.0 + float(np.abs(face_world[:3, 3]).sum()) + float(np.abs(location).max(initial=0.0)) * 3.0
        local = homogeneous[self._rows, :3]
        if np.abs(error).max(initial=0.0) <= 1e-6 * scale:
            return local
        other = np.flatnonzero(np.abs(error[self._rows]).max(axis=1) > 1e-6 * scale)  # (an object not read may differ)
        if len(other):
            obs = {k: objects[int(self._rows[k])] for k in other}
            local[other] = np.array(list(local_positions(face, obs).values()))
        return local


def neutral_array(positions: dict[str, np.ndarray]) -> np.ndarray:
    """(84, 3) in FP_IDS order, NaN for missing FPs."""
    out = np.full((len(FP_IDS), 3), np.nan)
    for fp_id, p in positions.items():
        out[fp_index(fp_id)] = p
    return out


def neutral_positions(empties: dict[str, bpy.types.Object]) -> np.ndarray:
    """(84, 3) face-local rest positions of the FP empties (`mpeg4_rest`, else where they are; NaN where missing)."""
    return neutral_array(
        {fp_id: np.array(ob.get(EMPTY_REST_PROP, ob.location), dtype=np.float64) for fp_id, ob in empties.items()}
    )


def mesh_edges(mesh: bpy.types.Mesh) -> np.ndarray:
    """(E, 2) the mesh's edges as vertex indices."""
    edges = np.empty(len(mesh.edges) * 2, dtype=np.int64)
    mesh.edges.foreach_get("vertices", edges)
    return edges.reshape(-1, 2)


def mesh_fans(mesh: bpy.types.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's polygons as triangle fans: (K, 3) vertex indices and each triangle's polygon (`folds`)."""
    return fan_triangles(*mesh_corners(mesh))


CORNER_VERT = ".corner_vert"  # the corners' vertices as Blender (4.0 on) keeps them, a corner-domain int attribute


def mesh_corners(mesh: bpy.types.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """(F,) each polygon's corner count and (L,) each corner's vertex, polygon after polygon (int64).

    The corners are read from the `.corner_vert` attribute (0.1 ms at 68k vertices) where it is there as Blender
    4.x keeps it, else through `mesh.loops` (10 ms)."""
    sizes = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", sizes)
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    attribute = mesh.attributes.get(CORNER_VERT)
    if attribute is not None and attribute.domain == "CORNER" and attribute.data_type == "INT":
        attribute.data.foreach_get("value", corners)
    else:
        mesh.loops.foreach_get("vertex_index", corners)
    return sizes, corners.astype(np.int64)


def group_weights(ob: bpy.types.Object, names) -> dict[str, np.ndarray]:
    """(N,) weights of the vertex groups called `names` that `ob` has (0 where a vertex is not in one).

    Read through a throw-away Geometry Nodes evaluation (about 20 ms at 68k vertices), which sees vertex
    groups as attributes; a Python loop over the vertices (about 1 s at 68k) remains where that fails.
    """
    index = {g.index: g.name for g in ob.vertex_groups if g.name in names}
    if not index:
        return {}
    try:
        return _group_weights_by_nodes(ob.data, list(index.values()))
    except (RuntimeError, KeyError, AttributeError, TypeError) as exc:
        log.info("reading vertex groups of %s one vertex at a time: %s", ob.name, exc)
    weights = {name: np.zeros(len(ob.data.vertices)) for name in index.values()}
    for v in ob.data.vertices:
        for g in v.groups:
            name = index.get(g.group)
            if name is not None:
                weights[name][v.index] = g.weight
    return weights


def _group_weights_by_nodes(mesh: bpy.types.Mesh, names: list[str]) -> dict[str, np.ndarray]:
    """Each group stored as a point attribute by a temporary node tree on a temporary object sharing `mesh`
    (the face's own modifiers stay out of it); both are removed before returning."""
    tree = bpy.data.node_groups.new(".MPEG-4 read vertex groups", "GeometryNodeTree")
    holder = None
    try:
        tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        geometry = tree.nodes.new("NodeGroupInput").outputs[0]
        for k, name in enumerate(names):
            read = tree.nodes.new("GeometryNodeInputNamedAttribute")
            read.data_type = "FLOAT"
            read.inputs["Name"].default_value = name
            store = tree.nodes.new("GeometryNodeStoreNamedAttribute")
            store.data_type, store.domain = "FLOAT", "POINT"
            store.inputs["Name"].default_value = f".mpeg4_group_{k}"
            tree.links.new(geometry, store.inputs["Geometry"])
            tree.links.new(read.outputs["Attribute"], store.inputs["Value"])
            geometry = store.outputs["Geometry"]
        tree.links.new(geometry, tree.nodes.new("NodeGroupOutput").inputs[0])
        holder = bpy.data.objects.new(".MPEG-4 read vertex groups", mesh)
        bpy.context.scene.collection.objects.link(holder)
        holder.modifiers.new("read", "NODES").node_group = tree
        evaluated = holder.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        if len(evaluated.vertices) != len(mesh.vertices):
            raise RuntimeError("the evaluated mesh has another vertex count")
        weights = {}
        for k, name in enumerate(names):
            values = np.empty(len(mesh.vertices), dtype=np.float32)
            evaluated.attributes[f".mpeg4_group_{k}"].data.foreach_get("value", values)
            weights[name] = values.astype(np.float64)
        return weights
    finally:
        if holder is not None:
            bpy.data.objects.remove(holder)
        bpy.data.node_groups.remove(tree)
