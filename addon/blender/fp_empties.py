"""The feature point empties: finding, adopting, placing, mirroring and releasing them.

Set-up adopts empties named 'FP <id>' (or tagged `mpeg4_fp`) in the face's FP collection: they become
children of the face with an identity parent inverse, so their location is their face-local position.
What adoption changed (the id tag, the parent and the transform) is recorded on the empty so Remove
can put it back.
"""

from __future__ import annotations

import re

import bpy
import numpy as np
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

from ..errors import Mpeg4Error
from ..geometry.nearby import triangles_near
from ..mpeg4.feature_points import FP_IDS, feature_point
from . import face_data

FP_NAME = re.compile(r"^FP (\d+\.\d+)(\.\d+)?$")
ADOPTED_PROP = "mpeg4_adopted"  # what adoption changed: parent, its inverse, the transform, the tag, the size
DISPLAY_SIZE_PER_HEIGHT = 0.012  # an FP sphere is about 3 mm on a 25 cm head: large enough to grab


def ensure_fp_collection(face) -> bpy.types.Collection:
    """The face's FP collection, created (and linked to the scene) if it does not exist yet."""
    coll = face_data.fp_collection(face)
    if coll is None:
        coll = bpy.data.collections.new(face_data.fp_collection_name(face))
        coll[face_data.CREATED_PROP] = True
    face.mpeg4_face.fp_collection = coll
    scene_root = bpy.context.scene.collection
    if coll not in scene_root.children_recursive:
        scene_root.children.link(coll)
    return coll


def fp_id_of(ob) -> str | None:
    """The FP id an empty stands for (its tag, else its name), or None."""
    if ob.type != "EMPTY":
        return None
    tagged = ob.get(face_data.FP_PROP)
    if isinstance(tagged, str):
        return tagged if tagged in FP_IDS else None
    match = FP_NAME.match(ob.name)
    return match.group(1) if match and match.group(1) in FP_IDS else None


def candidates(coll) -> dict[str, bpy.types.Object]:
    """FP id -> empty among the collection's objects (the first of each id, by name)."""
    found = {}
    for ob in sorted(coll.all_objects, key=lambda o: o.name):
        fp_id = fp_id_of(ob)
        if fp_id is not None and fp_id not in found:
            found[fp_id] = ob
    return found


def _needs_parenting(face, ob) -> bool:
    return ob.parent != face or ob.parent_type != "OBJECT" or ob.matrix_parent_inverse != face_data.IDENTITY


def check_adoptable(face, empties: dict) -> None:
    """Refuse, before anything changes, empties that set-up could only adopt by moving their animation."""
    for ob in empties.values():
        if _needs_parenting(face, ob) and ob.animation_data and ob.animation_data.action:
            raise Mpeg4Error(
                f"{ob.name} is animated but not parented to {face.name}: parent it to "
                "the face without inverse, then run Set Up again"
            )


def planned_locations(face, empties: dict, rest: np.ndarray) -> dict[str, np.ndarray]:
    """Face-local location of each empty after adoption and snapping, computed without moving anything.

    Skin points snap onto the face's rest surface (`rest`: (N, 3) positions; the mesh may be showing a
    pose) unless they are animated (their keys are the user's).
    """
    inv = face.matrix_world.inverted()
    planned = {}
    for fp_id, ob in empties.items():
        local = ob.location.copy() if not _needs_parenting(face, ob) else inv @ ob.matrix_world.translation
        planned[fp_id] = np.array(local, dtype=np.float64)
    snapped = [f for f, ob in empties.items() if feature_point(f).surface == "skin" and not ob.animation_data]
    if snapped:
        tree = _surface(face, rest, np.array([planned[f] for f in snapped]))
        for fp_id in snapped:
            on_surface, *_rest = tree.find_nearest(Vector(planned[fp_id]))
            if on_surface is not None:
                planned[fp_id] = np.array(on_surface, dtype=np.float64)
    return planned


def _surface(face, rest: np.ndarray, points: np.ndarray) -> BVHTree:
    """The part of the rest surface that can hold the points' nearest surface points, as triangles (the
    whole surface's BVH took 0.26 s at 68k vertices, most of it in handing it the vertices as lists)."""
    mesh = face.data
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", triangles)
    triangles = triangles.reshape(-1, 3)[triangles_near(rest, triangles, points)]
    used, corners = np.unique(triangles, return_inverse=True)
    return BVHTree.FromPolygons(np.asarray(rest)[used].tolist(), corners.reshape(-1, 3).tolist())


def neutral_locations(empties: dict, planned: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The neutral face: the planned location unless the empty is animated and already has a neutral.

    An animated empty keeps the neutral position measured at its first set-up, so setting up again in
    the middle of an animation does not take a posed frame for the neutral face.
    """
    neutral = {}
    for fp_id, ob in empties.items():
        stored = ob.get(face_data.EMPTY_REST_PROP)
        animated = ob.animation_data is not None and ob.animation_data.action is not None
        if animated and stored is not None and len(stored) == 3:
            neutral[fp_id] = np.array(stored, dtype=np.float64)
        else:
            neutral[fp_id] = planned[fp_id]
    return neutral


def display_size(face) -> float:
    """An FP empty's display size in face-local units, scaled to the face."""
    return DISPLAY_SIZE_PER_HEIGHT * max(max(face.dimensions) / max(max(face.scale), 1e-9), 1e-3)


def adopt(face, empties: dict, planned: dict[str, np.ndarray], neutral: dict[str, np.ndarray]) -> int:
    """Parent, tag and place the empties as planned; returns how many were reparented."""
    reparented = 0
    size = display_size(face)
    for fp_id, ob in empties.items():
        if ADOPTED_PROP not in ob and face_data.CREATED_PROP not in ob:
            # the object's own data, not matrix_world: that is only valid once Blender has evaluated it
            ob[ADOPTED_PROP] = {
                "parent": ob.parent.name if ob.parent else "",
                "parent_type": ob.parent_type,
                "parent_inverse": [v for row in ob.matrix_parent_inverse for v in row],
                "basis": [v for row in ob.matrix_basis for v in row],
                "tagged": face_data.FP_PROP in ob,
                "size": ob.empty_display_size,
            }
            # sized to the face once, when adopted: a later set-up (after a fit, Back to Generic) keeps the size,
            # so that going back to the generic face gives back the empties as they were
            ob.empty_display_size = max(ob.empty_display_size, size)
        ob[face_data.FP_PROP] = fp_id
        if _needs_parenting(face, ob):
            ob.parent = face
            ob.parent_type = "OBJECT"
            ob.matrix_parent_inverse.identity()
            reparented += 1
        if tuple(ob.location) != tuple(planned[fp_id]):
            ob.location = planned[fp_id]
        ob[face_data.EMPTY_REST_PROP] = [float(v) for v in neutral[fp_id]]
    return reparented


def release(face) -> int:
    """Undo adoption (Remove): delete the empties set-up created, give the others their old parent back."""
    coll = face.mpeg4_face.fp_collection
    if coll is None:
        return 0
    created = [ob for ob in coll.all_objects if face_data.CREATED_PROP in ob]
    for ob in created:
        bpy.data.objects.remove(ob)
    for ob in coll.all_objects:
        record = ob.get(ADOPTED_PROP)
        if record is not None:
            if "basis" in record and "parent_inverse" in record:
                ob.parent = bpy.data.objects.get(record.get("parent", ""))
                ob.parent_type = record.get("parent_type", "OBJECT")
                ob.matrix_parent_inverse = _matrix(record["parent_inverse"])
                ob.matrix_basis = _matrix(record["basis"])
            ob.empty_display_size = record.get("size", ob.empty_display_size)
            if not record.get("tagged", False) and face_data.FP_PROP in ob:
                del ob[face_data.FP_PROP]
            del ob[ADOPTED_PROP]
        if face_data.EMPTY_REST_PROP in ob:
            del ob[face_data.EMPTY_REST_PROP]
    if face_data.CREATED_PROP in coll and not coll.all_objects:
        bpy.data.collections.remove(coll)
    return len(created)


def _matrix(values) -> Matrix:
    return Matrix([list(values[i : i + 4]) for i in range(0, 16, 4)])


def place(face, fp_id: str, world_location, mirror: bool = False, snap: bool = True) -> list[bpy.types.Object]:
    """Create (or move) the empty of `fp_id` at a world location; skin points snap onto the face as shown (its
    evaluated shape) unless `snap` is False (a location already on the surface wanted).

    With `mirror`, the FP's partner across the face's local X = 0 plane (Blender's X-mirror) is placed too.
    """
    local = face.matrix_world.inverted() @ Vector(world_location)
    placed = [_place_local(face, fp_id, local, snap)]
    partner = feature_point(fp_id).mirror
    if mirror and partner:
        placed.append(_place_local(face, partner, Vector((-local.x, local.y, local.z)), snap))
    return placed


def _place_local(face, fp_id: str, local, snap: bool = True) -> bpy.types.Object:
    coll = ensure_fp_collection(face)
    empty = face_data.fp_empties(face).get(fp_id)
    if empty is None:
        empty = bpy.data.objects.new(f"FP {fp_id}", None)
        empty[face_data.FP_PROP] = fp_id
        empty[face_data.CREATED_PROP] = True
        empty.empty_display_type = "SPHERE"
        empty.empty_display_size = display_size(face)
        coll.objects.link(empty)
        empty.parent = face
    if snap and feature_point(fp_id).surface == "skin":
        ok, on_surface, _n, _i = face.closest_point_on_mesh(local)
        if ok:
            local = on_surface
    empty.location = local
    return empty


def mirror_move(face, moved) -> bpy.types.Object | None:
    """X-mirror editing: put the partner of the FP empty `moved` at its mirror image (face-local X = 0)."""
    fp_id = moved.get(face_data.FP_PROP)
    partner_id = feature_point(fp_id).mirror if fp_id in FP_IDS else None
    partner = face_data.fp_empties(face).get(partner_id) if partner_id else None
    if partner is None or partner.animation_data is not None:
        return None
    x, y, z = moved.location
    if tuple(partner.location) != (-x, y, z):
        partner.location = (-x, y, z)
    return partner
