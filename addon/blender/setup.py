"""Setting a face up for MPEG-4 animation, and taking it down again (services the operators call).

Set-up: adopt or create the FP collection, snap skin FP empties onto the face, build the control mesh
(the project's FP triangulation when all its points are present, else a cylindrical-projection
Delaunay over the present ones), compute FAPU, store the rest positions, bind, hook up the eyes, lower
teeth and tongue, and turn the effect on. Everything it creates is tagged so `remove` can take exactly
that away again and leave the user's mesh bit for bit as it was.
"""

from __future__ import annotations

import re

import bpy
import numpy as np

from ..deform.face_binding import FADE_BELOW, bind_face
from ..deform.masks import image_masks, vertex_uvs
from ..mpeg4 import control_mesh
from ..mpeg4.control_mesh import MASK_NAMES, triangulate_present
from ..mpeg4.fapu import FapuError, compute_fapu
from ..mpeg4.feature_points import FP_IDS, feature_point
from . import face_data, live, rig
from .reporting import UserError

FP_NAME = re.compile(r"^FP (\d+\.\d+)(\.\d+)?$")
FOLLOWERS = ("left_eye", "right_eye", "lower_teeth", "tongue")


class SetupError(UserError):
    """Set-up cannot proceed; the message says why and what to do."""


def ensure_fp_collection(face) -> bpy.types.Collection:
    """The face's FP collection, created (and linked to the scene) if it does not exist yet."""
    settings = face.mpeg4_face
    coll = face_data.fp_collection(face)
    if coll is None:
        coll = bpy.data.collections.new(face_data.fp_collection_name(face))
        coll[face_data.CREATED_PROP] = True
    settings.fp_collection = coll
    scene_root = bpy.context.scene.collection
    if coll not in scene_root.children_recursive:
        scene_root.children.link(coll)
    return coll


def _candidate_empties(coll) -> list:
    return [ob for ob in coll.all_objects if ob.type == "EMPTY" and (face_data.FP_PROP in ob or FP_NAME.match(ob.name))]


def _needs_parenting(face, ob) -> bool:
    return ob.parent != face or not _is_identity(ob.matrix_parent_inverse)


def check_adoptable(face, coll) -> None:
    """Refuse, before anything changes, empties that set-up could only adopt by moving their animation."""
    for ob in _candidate_empties(coll):
        if _needs_parenting(face, ob) and ob.animation_data and ob.animation_data.action:
            raise SetupError(
                f"{ob.name} is animated but not parented to {face.name}: parent it to "
                "the face without inverse, then run Set Up again"
            )


def adopt_empties(face, coll) -> list[str]:
    """Tag empties named 'FP <id>' with their id and parent them to the face (keeping them in place)."""
    notes = []
    inv = face.matrix_world.inverted()
    for ob in _candidate_empties(coll):
        match = FP_NAME.match(ob.name)
        if face_data.FP_PROP not in ob and match:
            ob[face_data.FP_PROP] = match.group(1)
        if _needs_parenting(face, ob):
            world = ob.matrix_world.copy()
            ob.parent = face
            ob.matrix_parent_inverse.identity()
            ob.matrix_basis = inv @ world
            notes.append(ob.name)
    return notes


def _is_identity(matrix) -> bool:
    return np.allclose(np.array(matrix), np.eye(4), atol=0.0)


def snap_to_surface(face, empties: dict) -> int:
    """Move skin FP empties onto the face's surface; returns how many moved."""
    moved = 0
    for fp_id, ob in empties.items():
        if feature_point(fp_id).surface != "skin" or ob.animation_data:
            continue
        ok, location, _normal, _index = face.closest_point_on_mesh(ob.location)
        if ok and (location - ob.location).length > 1e-6:
            ob.location = location
            moved += 1
    return moved


def record_neutral(empties: dict) -> dict[str, np.ndarray]:
    """The neutral face: each empty's face-local location, measured now unless it is animated.

    An animated empty keeps the neutral position measured at its first set-up, so setting up again
    in the middle of an animation does not take a posed frame for the neutral face.
    """
    positions = {}
    for fp_id, ob in empties.items():
        animated = ob.animation_data is not None and ob.animation_data.action is not None
        if not animated or face_data.EMPTY_REST_PROP not in ob:
            ob[face_data.EMPTY_REST_PROP] = list(ob.location)
        positions[fp_id] = np.array(ob[face_data.EMPTY_REST_PROP], dtype=np.float64)
    return positions


def head_centre(face, positions: dict[str, np.ndarray]) -> np.ndarray:
    """A point on the head's vertical axis: 7.1 (top of the spine), else the middle of the bounding box."""
    centre = positions.get("7.1")
    if centre is None:
        corners = np.array(face.bound_box)
        centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    return np.asarray(centre, dtype=np.float64)


def build_control(face, positions: dict[str, np.ndarray]) -> tuple[list[str], np.ndarray, list[str | None]]:
    """Control FP ids, triangles and triangle masks for the FPs present."""
    template_ids = {fp_id for tri in control_mesh.CONTROL_TRIANGLES for fp_id in tri}
    if template_ids <= positions.keys():
        ids = sorted(template_ids, key=lambda s: tuple(int(p) for p in s.split(".")))
        index = {fp_id: i for i, fp_id in enumerate(ids)}
        tris = np.array([[index[fp_id] for fp_id in tri] for tri in control_mesh.CONTROL_TRIANGLES])
        return ids, tris, list(control_mesh.TRIANGLE_MASKS)
    skin = {k: v for k, v in positions.items() if feature_point(k).surface == "skin"}
    if len(skin) < 3:
        raise SetupError(f"only {len(skin)} skin feature points are placed; at least 3 are needed")
    ids, tris, masks = triangulate_present(skin, head_centre(face, positions))
    if len(tris) == 0:
        raise SetupError("the placed feature points give no usable control triangle")
    return ids, tris, masks


def write_control_object(face, coll, ids, points, tris) -> bpy.types.Object:
    settings = face.mpeg4_face
    control = settings.control_object
    name = f"{face.name} Control"
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(points.tolist(), [], tris.tolist())
    mesh[face_data.FP_IDS_PROP] = list(ids)
    mesh[face_data.REST_PROP] = points.astype(np.float32).ravel()
    if control is None or face_data.CREATED_PROP not in control:
        control = bpy.data.objects.new(name, mesh)
        control[face_data.CREATED_PROP] = True
        coll.objects.link(control)
        control.parent = face
        control.display_type = "WIRE"
        control.hide_render = True
        control.show_in_front = True
        settings.control_object = control
    else:
        old = control.data
        control.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
    return control


def missing_masks(face) -> list[str]:
    """The mask names neither the face's mask image nor a vertex group provides."""
    if face.mpeg4_face.mask_image is not None:
        return []
    return [name for name in MASK_NAMES if face.vertex_groups.get(name) is None]


def vertex_masks(face) -> dict[str, np.ndarray]:
    """Per-vertex mask weights by mask name.

    From the face's mask image when it has one (one channel per mask, sampled at the UVs, paper 000
    Figure 9), else from the vertex groups named like the masks.
    """
    image = face.mpeg4_face.mask_image
    if image is not None:
        return _image_masks(face, image)
    return face_data.group_weights(face, MASK_NAMES)


def _image_masks(face, image) -> dict[str, np.ndarray]:
    mesh = face.data
    if mesh.uv_layers.active is None:
        raise SetupError(f"{face.name} has no UV map to sample the mask image {image.name!r} with")
    width, height = image.size
    if width == 0 or height == 0:
        raise SetupError(f"the mask image {image.name!r} has no pixels (is its file missing?)")
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    loop_vertex = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    loop_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", loop_uv)
    uv = vertex_uvs(loop_vertex, loop_uv, len(mesh.vertices))
    return image_masks(pixels.reshape(height, width, image.channels), uv, MASK_NAMES)


def rebind(face) -> None:
    """Bind the face's rest mesh to its control mesh with the current parameters (and store it)."""
    settings = face.mpeg4_face
    mesh = face.data
    control = settings.control_object
    if control is None:
        raise SetupError("no control mesh: run Set Up Face")
    rest = face_data.reference_positions(mesh)
    if rest is None or len(rest) != len(mesh.vertices):
        raise SetupError("the stored rest positions do not match the mesh: run Set Up Face")
    points = np.asarray(control.data[face_data.REST_PROP], dtype=np.float64).reshape(-1, 3)
    tris = np.array([list(p.vertices) for p in control.data.polygons], dtype=np.int64).reshape(-1, 3)
    tri_masks = list(control.data.get("mpeg4_triangle_masks", [""] * len(tris)))
    masks = vertex_masks(face) if settings.use_masks else {}
    tri_masks = [m if m in masks else None for m in tri_masks]
    params = {
        "radius_fraction": settings.radius_fraction,
        "falloff_exponent": settings.falloff_exponent,
        "es0": settings.fapu[1],
    }
    key = face_data.binding_key(rest, points, tris, {**params, "fade_below": FADE_BELOW}, masks)
    if mesh.get(face_data.BINDING_KEY_PROP) == key:
        return
    binding = bind_face(
        rest.astype(np.float64),
        points,
        tris,
        vertex_masks=masks or None,
        triangle_masks=tri_masks if masks else None,
        **params,
    )
    face_data.store_binding(mesh, binding, key)
    live.forget(face)


def set_up(face) -> list[str]:
    """Set `face` up; returns report lines. Raises SetupError with a clear message."""
    if face is None or face.type != "MESH":
        raise SetupError("select the face mesh first")
    if len(face.data.vertices) == 0:
        raise SetupError(f"{face.name} has no vertices")
    settings = face.mpeg4_face
    coll = face_data.fp_collection(face)
    if coll is None or not _candidate_empties(coll):
        name = coll.name if coll else face_data.fp_collection_name(face)
        where = f"collection {name!r}"
        raise SetupError(
            f"no feature point empties in {where}: place them with Place Feature Points "
            "(or name empties 'FP 2.1', 'FP 9.3', ...)"
        )
    check_adoptable(face, coll)
    # fail on an unusable FP set before anything changes (the real build below uses snapped positions)
    placed = {
        ob.get(face_data.FP_PROP) or FP_NAME.match(ob.name).group(1): np.array(ob.location)
        for ob in _candidate_empties(coll)
    }
    build_control(face, {fp_id: p for fp_id, p in placed.items() if fp_id in FP_IDS})
    notes = []
    if settings.enabled:
        settings.enabled = False  # back to rest before anything is measured
    coll = ensure_fp_collection(face)
    reparented = adopt_empties(face, coll)
    if reparented:
        notes.append(f"parented {len(reparented)} feature point empties to {face.name}")
    empties = face_data.fp_empties(face)
    moved = snap_to_surface(face, empties)
    if moved:
        notes.append(f"snapped {moved} feature points onto the surface")
    positions = record_neutral(empties)

    ids, tris, tri_masks = build_control(face, positions)
    points = np.array([positions[fp_id] for fp_id in ids])
    control = write_control_object(face, coll, ids, points, tris)
    control.data["mpeg4_triangle_masks"] = [m or "" for m in tri_masks]
    if len(ids) < len(positions):
        notes.append(f"control mesh over {len(ids)} of {len(positions)} FPs ({len(tris)} triangles)")

    try:
        settings.fapu = tuple(compute_fapu(positions).as_dict().values())
    except FapuError as exc:
        settings.fapu = (0.0,) * 5
        notes.append(f"FAP import needs FAPU: {exc}")

    mesh = face.data
    face_data.store_rest(mesh)  # the effect is off: this is the rest shape, with any edits the user made
    if settings.use_masks:
        missing = missing_masks(face)  # names only: the weights are read once, by rebind
        if missing:
            notes.append(f"no vertex groups {', '.join(missing)}: those openings are not masked")
    if face_data.BINDING_KEY_PROP in mesh:
        del mesh[face_data.BINDING_KEY_PROP]
    rebind(face)
    notes.extend(hook_followers(face, empties))
    settings.status = ""
    settings.enabled = True
    scene = bpy.context.scene
    if not scene.render.use_lock_interface:
        scene.render.use_lock_interface = True
        notes.append("turned on Render > Lock Interface (Blender's advice for handlers that edit meshes)")
    return notes


def hook_followers(face, empties) -> list[str]:
    settings = face.mpeg4_face
    guessed = rig.find_followers(face)
    notes = []
    inv = np.array(face.matrix_world.inverted())
    for name, fp_id in zip(FOLLOWERS, ("3.5", "3.6", "9.11", "6.2"), strict=True):
        ob = getattr(settings, name) or guessed[name]
        empty = empties.get(fp_id)
        if ob is None or empty is None:
            continue
        setattr(settings, name, ob)
        if name.endswith("eye"):
            pivot = inv[:3, :3] @ np.array(ob.matrix_world.translation) + inv[:3, 3]
            rig.follow_gaze(ob, empty, pivot)
        else:
            rig.follow_location(ob, empty)
        notes.append(f"{ob.name} follows FP {fp_id}")
    return notes


def remove(face) -> list[str]:
    """Undo set-up: the mesh back to its rest positions bit for bit, and everything set-up created gone."""
    settings = face.mpeg4_face
    notes = []
    live.forget(face)
    mesh = face.data
    face_data.restore_rest(mesh)
    key = mesh.shape_keys
    if key is not None and face_data.SHAPE_KEY_NAME in key.key_blocks:
        face.shape_key_remove(key.key_blocks[face_data.SHAPE_KEY_NAME])
    face_data.clear_binding(mesh)
    for name in FOLLOWERS:
        rig.remove_follow(getattr(settings, name))
    coll = settings.fp_collection
    control = settings.control_object
    if control is not None and face_data.CREATED_PROP in control:
        old = control.data
        bpy.data.objects.remove(control)
        if old.users == 0:
            bpy.data.meshes.remove(old)
    if coll is not None:
        created = [ob for ob in coll.all_objects if face_data.CREATED_PROP in ob]
        for ob in created:
            bpy.data.objects.remove(ob)
        for ob in coll.all_objects:
            if face_data.EMPTY_REST_PROP in ob:
                del ob[face_data.EMPTY_REST_PROP]
        if face_data.CREATED_PROP in coll and not coll.all_objects:
            bpy.data.collections.remove(coll)
        if created:
            notes.append(f"removed {len(created)} feature point empties set-up had made")
    face.property_unset("mpeg4_face")
    return notes
