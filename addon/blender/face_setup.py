"""Setting a face up for MPEG-4 animation, and taking it down again (the services the operators call).

Set-up is all-or-nothing: it works out everything first (the FP empties it adopts and where they
snap, the control mesh, FAPU, the rest shape, masks and the binding) without touching the scene, and
only then writes it all. Set-up always starts afresh from the mesh as it is now. Everything it creates
or changes is recorded, so Remove can take exactly that away and leave the file as it was before.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ..deform import face_checks
from ..deform.auto_masks import make_masks
from ..deform.planar_bones import Binding
from ..errors import Mpeg4Error
from ..mpeg4 import control_mesh
from ..mpeg4.face_frame import face_frame
from ..mpeg4.fapu import FapuError, compute_fapu
from ..mpeg4.feature_points import feature_point
from . import (
    animation,
    arkit_keys,
    bake,
    binding_store,
    elastic_rig,
    eyelid_rig,
    face_data,
    followers,
    fp_empties,
    head_motion,
    inner_parts,
    live,
    rest_shape,
)
from .fitting_store import remove_fitting
from .reporting import Warn
from .speech_ops import remove_speech

LOCK_INTERFACE_PROP = "mpeg4_locked_interface"  # on the scene: set-up turned Lock Interface on


@dataclass
class Plan:
    """Everything set-up will write, computed before the scene changes."""

    empties: dict
    planned: dict[str, np.ndarray]
    neutral: dict[str, np.ndarray]
    control_ids: list[str]
    control_points: np.ndarray
    triangles: np.ndarray
    triangle_masks: list[str | None]
    fapu: tuple[float, ...]
    rest: np.ndarray
    binding: Binding
    key: str
    notes: list[str]
    made_masks: dict[str, np.ndarray]  # mask vertex groups to make (the face has none of these, or only empty ones)
    axes: np.ndarray  # (3, 3) the face frame read from the FPs, rows in mesh coordinates
    made_parts: dict[str, np.ndarray]  # part vertex groups to make (the loose parts found inside the face)
    head_turn: np.ndarray | None  # the head-turn weights to write (a head on a body without them)


def head_centre(face, positions: dict[str, np.ndarray]) -> np.ndarray:
    """A point on the head's vertical axis: 7.1 (top of the spine), else the middle of the bounding box."""
    centre = positions.get("7.1")
    if centre is None:
        corners = np.array(face.bound_box)
        centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    return np.asarray(centre, dtype=np.float64)


def build_control(
    face, positions: dict[str, np.ndarray], axes: np.ndarray
) -> tuple[list[str], np.ndarray, list[str | None]]:
    """Control FP ids, triangles and triangle masks for the FPs present (`axes`: the face frame)."""
    template_ids = {fp_id for tri in control_mesh.CONTROL_TRIANGLES for fp_id in tri}
    if template_ids <= positions.keys():
        ids = sorted(template_ids, key=lambda s: tuple(int(p) for p in s.split(".")))
        index = {fp_id: i for i, fp_id in enumerate(ids)}
        tris = np.array([[index[fp_id] for fp_id in tri] for tri in control_mesh.CONTROL_TRIANGLES])
        return ids, tris, list(control_mesh.TRIANGLE_MASKS)
    skin = {k: v for k, v in positions.items() if feature_point(k).surface == "skin"}
    if len(skin) < 3:
        raise Mpeg4Error(f"only {len(skin)} skin feature points are placed; at least 3 are needed")
    ids, tris, masks = control_mesh.triangulate_present(skin, head_centre(face, positions), axes)
    if len(tris) == 0:
        raise Mpeg4Error("the placed feature points give no usable control triangle")
    return ids, tris, masks


def _check_triangles(ids: list[str], points: np.ndarray, tris: np.ndarray) -> None:
    """Refuse control triangles whose feature points coincide or lie on one line, naming them."""
    corners = points[tris]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    scale = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    bad = np.flatnonzero(areas <= 1e-8 * scale**2)
    if scale == 0.0 or len(bad):
        names = ", ".join("/".join(f"FP {ids[k]}" for k in tris[t]) for t in bad[:3])
        more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
        raise Mpeg4Error(
            f"feature points coincide or lie on one line in control triangles {names}{more}: move "
            "them apart and run Set Up again"
        )


def _rest_now(face) -> np.ndarray:
    """The face's rest shape as it is now: the stored one while our deformation is shown, else the mesh."""
    mesh = face.data
    if mesh.shape_keys is None and face.mpeg4_face.enabled:
        stored = rest_shape.stored_rest(mesh)
        if stored is not None:
            return stored
    return rest_shape.current_rest(mesh)


def plan(face) -> Plan:
    """Work out the whole set-up; raises Mpeg4Error with a clear message, changes nothing."""
    if face is None or face.type != "MESH":
        raise Mpeg4Error("select the face mesh first")
    if len(face.data.vertices) == 0:
        raise Mpeg4Error(f"{face.name} has no vertices")
    if face.mode == "EDIT":
        raise Mpeg4Error(f"{face.name} is in Edit Mode: go back to Object Mode first")
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:  # its skeleton and parts hang on the old set-up
        raise Mpeg4Error(f"{face.name} uses Elastic Bones: switch the Engine to Planar Bones, set up, and switch back")
    coll = face_data.fp_collection(face)
    empties = fp_empties.candidates(coll) if coll is not None else {}
    if not empties:
        name = coll.name if coll else face_data.fp_collection_name(face)
        raise Mpeg4Error(
            f"no feature point empties in collection {name!r}: place them with Place Feature Points "
            "(or name empties 'FP 2.1', 'FP 9.3', ...)"
        )
    fp_empties.check_adoptable(face, empties)
    notes = []
    rest = _rest_now(face)
    edges = face_data.mesh_edges(face.data)  # read once: the checks, the masks, the parts and the binding use them
    planned = fp_empties.planned_locations(face, empties, rest)
    now = face_data.local_positions(face, empties)
    snapped = sum(1 for fp_id in planned if np.abs(planned[fp_id] - now[fp_id]).max() > 1e-6)
    if snapped:
        notes.append(f"snapped {snapped} feature points onto the surface")
    neutral = fp_empties.neutral_locations(empties, planned)
    axes = face_frame(neutral)
    _check_fps(rest, edges, now, neutral, axes, notes)
    ids, tris, tri_masks = build_control(face, neutral, axes)
    points = np.array([neutral[fp_id] for fp_id in ids], dtype=np.float64)
    _check_triangles(ids, points, tris)
    if len(ids) < len(neutral):
        notes.append(f"control mesh over {len(ids)} of {len(neutral)} FPs ({len(tris)} triangles)")
    try:
        fapu = tuple(compute_fapu(neutral, axes).as_dict().values())
    except FapuError as exc:
        fapu = (0.0,) * 5
        notes.append(Warn(f"FAP import needs FAPU: {exc}"))
    made = _planned_masks(face, rest, edges, neutral, notes) if face.mpeg4_face.use_masks else {}
    parts = inner_parts.plan_parts(face, rest, edges, neutral, axes, notes)
    inputs = binding_store.gather(
        face, rest, points, tris, tri_masks, fapu[1], ids, made_masks=made, made_parts=parts, mesh_edges=edges
    )
    try:
        binding = inputs.bind()
    except np.linalg.LinAlgError as exc:
        raise Mpeg4Error(
            f"the feature points cannot bind {face.name} ({exc}): check for points placed on top of each other"
        ) from exc
    key = inputs.key
    neck = head_motion.plan_head_turn(face, rest, neutral, axes, notes)
    return Plan(
        empties,
        planned,
        neutral,
        ids,
        points,
        tris,
        tri_masks,
        fapu,
        rest,
        binding,
        key,
        notes,
        made,
        axes,
        parts,
        neck,
    )


def _check_fps(rest: np.ndarray, edges: np.ndarray, placed: dict, neutral: dict, axes: np.ndarray, notes: list) -> None:
    """Refuse an FP set that breaks playback (a feature's FPs placed in part); warn of swapped pairs, FPs placed
    far off the surface and openings the mesh closes, naming the FPs."""
    refusals, warnings = face_checks.missing_fps(neutral)
    if refusals:
        raise Mpeg4Error(
            f"feature points missing: {'; '.join(refusals)}. Place them (Place Feature Points) and run Set Up "
            "Face again"
        )
    notes.extend(Warn(text) for text in warnings)
    swapped = face_checks.swapped_pairs(neutral, axes)
    if swapped:
        pairs = ", ".join(f"FP {left} and {right}" for left, right in swapped)
        notes.append(Warn(f"left and right look swapped in {pairs} (the left one is on the face's right): check them"))
    eyes = [neutral[f] for f in ("3.5", "3.6") if f in neutral]
    separation = float(np.linalg.norm(eyes[0] - eyes[1])) if len(eyes) == 2 else 0.0
    far = face_checks.far_off(placed, neutral, separation)
    if far:
        notes.append(Warn(f"FP {', '.join(far)} were placed far off the surface and snapped onto it: check them"))
    fused = face_checks.fused_openings(rest, edges, neutral)
    if fused:
        how = "cut the mesh open between the feature points"
        if any(name.startswith("lips") for name in fused):
            how += "; for the lips: Remove Set-Up, Open Sealed Mouth, then Set Up Face again"
        notes.append(Warn(f"the mesh has no opening at the {', '.join(fused)}: they cannot part ({how})"))


def _planned_masks(
    face, rest: np.ndarray, edges: np.ndarray, neutral: dict[str, np.ndarray], notes: list
) -> dict[str, np.ndarray]:
    """The mask vertex groups the face lacks, made from the FPs (geodesic sides of the openings)."""
    missing = binding_store.missing_masks(face)
    if not missing:
        return {}
    made = make_masks(rest, edges, face_data.neutral_array(neutral))
    made = {name: made[name] for name in missing if name in made}
    empty = [name for name in made if face.vertex_groups.get(name) is not None]
    if empty:
        notes.append(f"vertex groups {', '.join(empty)} had no weights: filled them from the feature points")
    if len(made) > len(empty):
        new = ", ".join(name for name in made if name not in empty)
        notes.append(f"made vertex groups {new} from the feature points (edit them to refine the masks)")
    unmade = [name for name in missing if name not in made]
    if unmade:
        names = ", ".join(unmade)
        notes.append(Warn(f"no vertex groups {names} and too few feature points to make them: not masked"))
    return made


def _write_masks(face, made: dict[str, np.ndarray]) -> None:
    """Write made masks as vertex groups and remember them, so Remove takes them away again."""
    if not made:
        return
    filled = list(face.get(face_data.FILLED_MASKS_PROP, ()))
    for name, weights in made.items():
        group = face.vertex_groups.get(name)
        if group is None:
            group = face.vertex_groups.new(name=name)
        elif name not in filled:
            filled.append(name)
        for value in np.unique(weights[weights > 0.0]):
            group.add(np.flatnonzero(weights == value).tolist(), float(value), "REPLACE")
    settings = face.mpeg4_face
    settings.made_masks = ",".join(sorted({*filter(None, settings.made_masks.split(",")), *made}))
    if filled:
        face[face_data.FILLED_MASKS_PROP] = filled


def _remove_made_masks(face) -> int:
    names = [name for name in face.mpeg4_face.made_masks.split(",") if name]
    filled = set(face.get(face_data.FILLED_MASKS_PROP, ()))
    for name in names:
        group = face.vertex_groups.get(name)
        if group is not None and name in filled:
            group.remove(list(range(len(face.data.vertices))))  # it was the user's, empty: empty again
        elif group is not None:
            face.vertex_groups.remove(group)
    if face_data.FILLED_MASKS_PROP in face:
        del face[face_data.FILLED_MASKS_PROP]
    return len(names)


def _hide(control) -> None:
    """A new control mesh starts hidden, as a helper cage (Alt+H shows it; then it follows the FPs)."""
    try:
        control.hide_set(True)
    except RuntimeError:  # not in the active view layer: nothing to hide there
        pass


def _write_control_object(face, coll, plan: Plan) -> bpy.types.Object:
    settings = face.mpeg4_face
    control = settings.control_object
    name = f"{face.name} Control"
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(plan.control_points.tolist(), [], plan.triangles.tolist())
    mesh[face_data.FP_IDS_PROP] = list(plan.control_ids)
    mesh[face_data.REST_PROP] = plan.control_points.astype(np.float32).ravel()
    mesh[face_data.TRIANGLE_MASKS_PROP] = [m or "" for m in plan.triangle_masks]
    mesh[face_data.FACE_AXES_PROP] = plan.axes.ravel()
    if control is None or face_data.CREATED_PROP not in control:
        control = bpy.data.objects.new(name, mesh)
        control[face_data.CREATED_PROP] = True
        coll.objects.link(control)
        control.parent = face
        control.display_type = "WIRE"
        control.hide_render = True
        control.show_in_front = True
        _hide(control)
        settings.control_object = control
    else:
        old = control.data
        control.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
    return control


def set_up(face) -> list[str]:
    """Set `face` up afresh; returns report lines. Raises Mpeg4Error (and changes nothing) on a problem."""
    p = plan(face)
    settings = face.mpeg4_face
    notes = list(p.notes)
    if settings.enabled:
        live.pause(face)  # back to rest without the property update (which would apply the old binding)
    coll = fp_empties.ensure_fp_collection(face)
    reparented = fp_empties.adopt(face, p.empties, p.planned, p.neutral)
    if reparented:
        notes.append(f"parented {reparented} feature point empties to {face.name}")
    _write_control_object(face, coll, p)
    settings.fapu = p.fapu
    mesh = face.data
    rest_shape.store_rest(mesh, p.rest)
    _write_masks(face, p.made_masks)
    inner_parts.write_parts(face, p.made_parts)
    head_motion.write_head_turn(face, p.head_turn)
    binding_store.save(face, p.binding, p.key)
    settings["still_upper_face"] = settings.still_upper_face  # stored, even at its default (`live.on_load_post`)
    settings["enabled"] = False  # the handlers leave the face at rest while lashes and brows bind to it
    notes.extend(hook_followers(face, p.empties))
    settings.status = ""
    settings.enabled = True
    notes.extend(eyelid_rig.notes(face))  # the lids' rig is made as Deform turns on
    scene = bpy.context.scene
    if not scene.render.use_lock_interface:
        scene.render.use_lock_interface = True
        scene[LOCK_INTERFACE_PROP] = True
        notes.append("turned on Render > Lock Interface (Blender's advice for handlers that edit meshes)")
    return notes


def hook_followers(face, empties) -> list[str]:
    """Fill the empty part fields by name, then hook each part to what drives it (the face is at rest)."""
    settings = face.mpeg4_face
    guessed = followers.find_followers(face)
    notes = []
    for name, driver in followers.PARTS.items():
        ob = getattr(settings, name) or guessed[name]
        if ob is None or ob == face:
            continue
        setattr(settings, name, ob)
        if driver == "skull":
            notes.append(f"{ob.name} stays with the skull")
        elif driver == "surface":
            if ob.type != "MESH":
                notes.append(Warn(f"{ob.name} is not a mesh: it cannot follow the face's skin"))
                continue
            followers.follow_surface(ob, face)
            notes.append(f"{ob.name} follows the face's skin")
        elif driver in empties:
            if name.endswith("eye"):
                centre = followers.eye_centre(face, ob)
                problem = followers.follow_gaze(face, ob, empties[driver], centre, face_data.face_axes(face))
                if problem:
                    notes.append(Warn(problem))
            else:
                followers.follow_location(ob, empties[driver])
            notes.append(f"{ob.name} follows FP {driver}")
    return notes


def remove(face) -> list[str]:
    """Undo set-up, import and bake: the file goes back to how it was before set-up."""
    settings = face.mpeg4_face
    notes = []
    live.forget(face)
    if elastic_rig.remove(face):  # first: its parts go back to their followers' drivers
        notes.append("removed the Elastic Bones skeleton")
    notes.extend(remove_fitting(face))
    mesh = face.data
    rest_shape.restore_rest(mesh)
    rest_shape.remove_own_shape_key(face)
    binding_store.clear(face)
    rest_shape.clear_rest(mesh)
    notes.extend(arkit_keys.remove(face))  # before the bakes: the last of them takes a Basis made for them
    notes.extend(bake.remove_bakes(face))
    empties = face_data.fp_empties(face)
    removed_actions = animation.remove_streams([face, *empties.values()])
    if remove_speech(face):
        notes.append("removed the face's speech strips and their audio")
    head_motion.restore_rest(face)
    if removed_actions:
        notes.append(f"removed {removed_actions} imported FAP stream(s)")
    for name in followers.PARTS:
        followers.remove_follow(getattr(settings, name))
    if inner_parts.remove_parts(face):
        notes.append("removed the part vertex groups set-up had made")
    if head_motion.remove_head_turn(face):
        notes.append(f"removed the {head_motion.HEAD_TURN_GROUP} vertex group set-up had made")
    made = _remove_made_masks(face)
    if made:
        notes.append(f"removed the {made} mask vertex groups set-up had made")
    control = settings.control_object
    if control is not None and face_data.CREATED_PROP in control:
        old = control.data
        bpy.data.objects.remove(control)
        if old.users == 0:
            bpy.data.meshes.remove(old)
    created = fp_empties.release(face)
    if created:
        notes.append(f"removed {created} feature point empties set-up had made")
    scene = bpy.context.scene
    if scene.get(LOCK_INTERFACE_PROP) and not any(
        ob.type == "MESH" and ob != face and binding_store.is_bound(ob) for ob in scene.objects
    ):
        scene.render.use_lock_interface = False
        del scene[LOCK_INTERFACE_PROP]
    face.property_unset("mpeg4_face")
    return notes
