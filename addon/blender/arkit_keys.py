"""ARKit's 52 shape keys on a set-up face, made by its own engine, and ARKit captures keyed onto them.

Making the keys: for each recipe (arkit.recipes) the FP empties are put where the recipe's FAPs move them
(the face's group gains and ranges applied, as a stream plays; a recipe made 'over' another takes the ranges
on its base's FAPs only, since its own bring the base's motion back toward rest), the face's engine deforms the
face as it plays (Planar Bones with its lids, lip guard and Unfold Skin, or Elastic Bones through its Armature
modifier), and the change from the face at rest becomes a shape key named as ARKit names the shape, relative
to the reference key (so a shape-key stack the face already has is kept and adds on top). The parts that
follow feature points (eyeballs, lower teeth, tongue) are read as their drivers or bones place them, and
each part a recipe moves gets the same-named key of its own: eyeLook* turn the eyeballs, jawOpen moves the
lower teeth and the tongue. Where a recipe names a dedicated deformation (arkit.deformations), the points are
moved by it before the engine deforms the face ('whole_lip_push'); jawOpen's 'jaw_hinge' turns the skin the
engine deformed as the jaw turns (about a centre below its joints), each vertex by its share of the jaw's drop,
and the lower teeth and the tongue with it; tongueOut's 'tongue_forward' moves the tongue part forward by the
tip's thrust, which no FAP carries to the tongue body. Afterwards the empties are put back and the face shown as
before.

Every key made is listed on its mesh (`KEYS_PROP`), so running again replaces exactly them and Remove
Set-Up takes them (and a Basis key made for them) away; a key of the user's with an ARKit name is never
overwritten: the run is refused before anything changes.
"""

from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ..arkit.deformations import deform_points, jaw_hinge, jaw_turn, surface_normals
from ..arkit.recipes import ARKIT_INDEX, ARKIT_NAMES, load_recipes
from ..errors import Mpeg4Error
from ..mpeg4.decode import fap_to_fp
from ..mpeg4.fap_groups import shape_faps
from ..mpeg4.faps import N_FAPS
from ..mpeg4.feature_points import fp_index
from . import animation, bake, elastic_rig, face_data, fap_io, live, rest_shape
from .face_data import CREATED_PROP
from .reporting import Warn, progress

KEYS_PROP = "mpeg4_arkit_keys"  # on a mesh: the names of the ARKit keys made on it
PART_BASIS_PROP = "mpeg4_arkit_basis"  # on a part's mesh: its Basis key was made for the ARKit keys
FOLLOWING_PARTS = ("left_eye", "right_eye", "lower_teeth", "tongue")  # moved by FPs; the others by the skin
NEW_PREFIX = "MPEG-4 new "  # the name of a key being made, until the run succeeds
STILL = 1e-9  # a part whose transform changes less than this (model units, radians) has no key


def _face_points(
    face, empties, values: np.ndarray, deformation: str | None = None, over: np.ndarray | None = None
) -> np.ndarray:
    """(84, 3) face-local FP positions for FAP values (68,), with the face's group gains and ranges, moved further
    by the dedicated `deformation` a recipe names. `over`: the FAP values of a recipe made over `values` (its
    base's), added with the gains and without the ranges: they bring back what the base moved (mouthClose's lower
    lip rising as far as jawOpen carried it down), and a soft limit is a limit on how far a point goes from rest
    (fap_groups: "lips move about half an MNS0 past neutral"), which a point brought back toward rest does not
    pass; eased as a lip's own 1220 MNS would be, to about 500, the lips stayed 19 mm apart."""
    settings = face.mpeg4_face
    shaped = shape_faps(values[None], fap_io.group_gains(face), limit=settings.use_soft_limits)
    if over is not None:
        shaped = shaped + shape_faps(over[None], fap_io.group_gains(face), limit=False)
    neutral = face_data.neutral_positions(empties)
    axes = face_data.face_axes(face)
    points = fap_to_fp(neutral, shaped, fap_io.face_fapu(face), axes=axes, eye_pivots=fap_io.eye_pivots(face))[0]
    normals = _rest_normals(face, neutral) if deformation == "cheek_puff" else None
    return deform_points(deformation, neutral, points, axes, normals)


def _rest_normals(face, neutral: np.ndarray) -> np.ndarray:
    """(84, 3) the face mesh's outward surface normals at the FPs at rest (`deformations.surface_normals`)."""
    mesh = face.data
    normals = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertex_normals.foreach_get("vector", normals)
    vertices = rest_shape.read_key(mesh.shape_keys.reference_key) if mesh.shape_keys else _local_vertices(face)
    return surface_normals(neutral, np.asarray(vertices, dtype=np.float64), normals.reshape(-1, 3))


def _pose(empties, points: np.ndarray) -> None:
    for fp_id, ob in empties.items():
        ob.location = points[fp_index(fp_id)]


def _deformed(face) -> np.ndarray:
    """The face's vertices as its engine deforms them from the empties now (float64, mesh coordinates)."""
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:  # the pose, and Unfold Skin's corrections under it
        if not live.apply_face(face, force=True):
            raise Mpeg4Error(face.mpeg4_face.status or f"{face.name} could not be deformed")
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        mesh = face.evaluated_get(depsgraph).data
        out = np.empty(3 * len(mesh.vertices), dtype=np.float32)
        mesh.vertices.foreach_get("co", out)
        return out.reshape(-1, 3).astype(np.float64)
    if not live.apply_face(face, force=True):
        raise Mpeg4Error(face.mpeg4_face.status or f"{face.name} could not be deformed")
    return bake.deformed_positions(face.data).astype(np.float64)


def _part_matrices(parts) -> dict[str, Matrix]:
    bpy.context.view_layer.update()  # the parts' drivers (or bones) follow the empties
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return {name: ob.evaluated_get(depsgraph).matrix_world.copy() for name, ob in parts.items()}


def _parts(face) -> tuple[dict[str, bpy.types.Object], list[str]]:
    """The face's following parts that can take keys, and notes on those that cannot."""
    settings = face.mpeg4_face
    parts, notes = {}, []
    for name in FOLLOWING_PARTS:
        ob = getattr(settings, name)
        if ob is None or ob == face:
            continue
        if ob.type != "MESH":
            notes.append(Warn(f"{ob.name} is not a mesh: it gets no ARKit shape keys"))
        elif ob.data.users > 1:
            notes.append(Warn(f"{ob.name} shares its mesh with another object: it gets no ARKit shape keys"))
        else:
            parts[name] = ob
    return parts, notes


def _check_names(ob) -> None:
    """Refuse a mesh that has a key of the user's with an ARKit name (ours are listed in KEYS_PROP)."""
    key = ob.data.shape_keys
    ours = set(ob.data.get(KEYS_PROP, ()))
    if key is not None:
        theirs = [block.name for block in key.key_blocks if block.name in ARKIT_INDEX and block.name not in ours]
        if theirs:
            raise Mpeg4Error(
                f"{ob.name} already has shape keys named {', '.join(theirs[:4])}"
                f"{' ...' if len(theirs) > 4 else ''} that this add-on did not make: rename or remove them first"
            )


def _remove_keys(ob, drop_capture: bool) -> int:
    """Remove the ARKit keys made on `ob` (and a part's Basis made for them); how many went. A capture keyed onto
    them stays unless `drop_capture`: its F-curves find the keys made again by name."""
    mesh = ob.data
    names = list(mesh.get(KEYS_PROP, ()))
    key = mesh.shape_keys
    removed = 0
    if key is not None:
        if drop_capture:
            _clear_capture(key)
        for name in names:
            block = key.key_blocks.get(name)
            if block is not None:
                ob.shape_key_remove(block)
                removed += 1
    if KEYS_PROP in mesh:
        del mesh[KEYS_PROP]
    if mesh.get(PART_BASIS_PROP) and (mesh.shape_keys is None or len(mesh.shape_keys.key_blocks) == 1):
        if mesh.shape_keys is not None:  # the Basis made for the keys, alone now
            ob.shape_key_remove(mesh.shape_keys.key_blocks[0])
        del mesh[PART_BASIS_PROP]
    return removed


def _add_key(ob, name: str, co: np.ndarray, made: dict) -> None:
    """A new key under a temporary name (the earlier keys stay until every new one is made); `made[ob]` lists them."""
    block = ob.shape_key_add(name=f"{NEW_PREFIX}{name}", from_mix=False)
    block.relative_key = ob.data.shape_keys.reference_key
    block.data.foreach_set("co", np.ascontiguousarray(co, dtype=np.float32).ravel())
    block.slider_min, block.slider_max = 0.0, 1.0
    block.value = 0.0  # a new key starts at 1: the face must look as it did until a weight is set
    made.setdefault(ob, []).append(name)


def _take_back(made: dict, bases: list) -> None:
    """A failed run: its new keys and the Basis keys it added go; the earlier keys are as they were."""
    for ob, names in made.items():
        for name in names:
            block = ob.data.shape_keys.key_blocks.get(f"{NEW_PREFIX}{name}")
            if block is not None:
                ob.shape_key_remove(block)
    for ob in bases:
        if ob.data.shape_keys is not None and len(ob.data.shape_keys.key_blocks) == 1:
            ob.shape_key_remove(ob.data.shape_keys.key_blocks[0])
        for prop in (PART_BASIS_PROP, bake.CREATED_BASIS_PROP):
            if prop in ob.data:
                del ob.data[prop]


def _put_in_place(objects, made: dict) -> int:
    """A run that succeeded: the earlier keys go and the new ones take their names; how many earlier ones went."""
    removed = 0
    for ob in objects:
        removed += _remove_keys(ob, drop_capture=False)
        names = made.get(ob, [])
        for name in names:
            ob.data.shape_keys.key_blocks[f"{NEW_PREFIX}{name}"].name = name
        if names:
            ob.data[KEYS_PROP] = names
    return removed


def _local_vertices(ob) -> np.ndarray:
    co = np.empty(3 * len(ob.data.vertices), dtype=np.float32)
    ob.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def _moved_part(ob, rest: Matrix, posed: Matrix, base: np.ndarray) -> np.ndarray | None:
    """The part's reference-key vertices carried by the change rest -> posed (its local coordinates), or None."""
    change = np.array(rest.inverted() @ posed)
    if np.abs(change - np.eye(4)).max() <= STILL:
        return None
    return base @ change[:3, :3].T + change[:3, 3]


def _tongue_thrust(face, points: np.ndarray, neutral: np.ndarray) -> Vector:
    """'tongue_forward': how far (world) the tongue tip 6.1 moves beyond the tongue body 6.2, which the tongue
    part follows: the thrust no FAP gives the body."""
    tip, body = fp_index("6.1"), fp_index("6.2")
    extra = (points[tip] - neutral[tip]) - (points[body] - neutral[body])
    return face.matrix_world.to_3x3() @ Vector(extra)


def _jaw_turn(face, points: np.ndarray, neutral: np.ndarray) -> Matrix | None:
    """'jaw_hinge': the mandible's turn (world, `deformations.hinge_axis`), which the lower teeth and the tongue
    make with it (their drivers follow FPs by translation alone)."""
    turn = jaw_turn(neutral, points, face_data.face_axes(face))
    if turn is None:
        return None
    origin, axis, angle = turn
    world = face.matrix_world
    pivot = world @ Vector(origin)
    axis = (world.to_3x3() @ Vector(axis)).normalized()
    return Matrix.Translation(pivot) @ Matrix.Rotation(angle, 4, axis) @ Matrix.Translation(-pivot)


def _recipe_points(face, empties, table, name: str) -> np.ndarray:
    """The FP positions a shape's key is made from: its recipe's, on top of the base's a recipe made 'over' one
    names."""
    base = table.over.get(name)
    deformation = table.deformations.get(name)
    if base is None:
        return _face_points(face, empties, table.recipe(name), deformation)
    return _face_points(face, empties, table.recipe(base), deformation, over=table.recipe(name))


def make_keys(context, face) -> list[str]:
    """Make (or make again) the 52 ARKit shape keys on `face` and its following parts; returns report lines."""
    empties = fap_io.require_setup(face)
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:
        elastic_rig.require_skeleton(face)
    table = load_recipes()
    parts, notes = _parts(face)
    for ob in [face, *parts.values()]:
        _check_names(ob)
    # all checked first
    points = [_recipe_points(face, empties, table, name) for name in ARKIT_NAMES]

    scene = context.scene
    frame = (scene.frame_current, scene.frame_subframe)
    saved = {fp_id: ob.location.copy() for fp_id, ob in empties.items()}
    mesh = face.data
    bases = []  # the objects this run gave a Basis key
    if mesh.shape_keys is None:
        live.pause(face)  # the Basis copies the mesh: it must get the rest shape, not the pose
        face.shape_key_add(name="Basis", from_mix=False)
        mesh[bake.CREATED_BASIS_PROP] = True  # Remove takes it away with the last key on it
        bases.append(face)
    for ob in parts.values():
        if ob.data.shape_keys is None:
            ob.shape_key_add(name="Basis", from_mix=False)
            ob.data[PART_BASIS_PROP] = True
            bases.append(ob)
    basis = rest_shape.read_key(mesh.shape_keys.reference_key).astype(np.float64)
    neutral = face_data.neutral_positions(empties)
    part_basis = {name: rest_shape.read_key(ob.data.shape_keys.reference_key) for name, ob in parts.items()}
    made: dict = {}
    try:
        _pose(empties, _face_points(face, empties, np.zeros(N_FAPS)))
        rest = _deformed(face)
        part_rest = _part_matrices(parts)
        made_bases = {}  # each base an 'over' recipe names (made before it): its key's shape
        with progress(context, len(ARKIT_NAMES)) as step:
            for i, name in enumerate(ARKIT_NAMES):
                _pose(empties, points[i])
                deformation = table.deformations.get(name)
                shape = _deformed(face)
                base = table.over.get(name)
                if base is not None:  # the change its FAPs make on the base's pose; the parts ride the base
                    made_base = made_bases[base]
                    if table.deformations.get(base) == "jaw_hinge":  # each vertex by what it is left of the drop
                        shape = jaw_hinge(neutral, points[i], rest, shape, face_data.face_axes(face))
                    _add_key(face, name, basis + shape - made_base, made)
                    step(i)
                    continue
                if deformation == "jaw_hinge":  # the skin turns with the jaw, each vertex by its share
                    shape = jaw_hinge(neutral, points[i], rest, shape, face_data.face_axes(face))
                if name in table.over.values():
                    made_bases[name] = shape
                _add_key(face, name, basis + shape - rest, made)
                posed = _part_matrices(parts)
                mandible = _jaw_turn(face, points[i], neutral) if deformation == "jaw_hinge" else None
                for part, ob in parts.items():
                    change = posed[part]
                    if part == "tongue" and deformation == "tongue_forward":
                        change = Matrix.Translation(_tongue_thrust(face, points[i], neutral)) @ change
                    elif part in ("lower_teeth", "tongue") and mandible is not None:
                        change = mandible @ part_rest[part]
                    co = _moved_part(ob, part_rest[part], change, part_basis[part])
                    if co is not None:
                        _add_key(ob, name, co, made)
                step(i)
    except BaseException:
        _take_back(made, bases)
        raise
    finally:
        for fp_id, location in saved.items():
            empties[fp_id].location = location
        scene.frame_set(frame[0], subframe=frame[1])
        live.refresh(face)
    removed = _put_in_place([face, *parts.values()], made)
    again = " (replacing the earlier ones)" if removed else ""
    notes.insert(0, f"made {len(ARKIT_NAMES)} ARKit shape keys on {face.name}{again}")
    for ob in parts.values():
        made = list(ob.data.get(KEYS_PROP, ()))
        if made:
            notes.append(f"{ob.name}: {len(made)} matching keys ({', '.join(made)})")
    return notes


def remove(face) -> list[str]:
    """Take away the ARKit keys (and their capture keys) from the face and its parts; report lines."""
    settings = face.mpeg4_face
    removed = 0
    for ob in [face, *(getattr(settings, name) for name in FOLLOWING_PARTS)]:
        if ob is not None and ob.type == "MESH" and (KEYS_PROP in ob.data or PART_BASIS_PROP in ob.data):
            removed += _remove_keys(ob, drop_capture=True)
    return [f"removed {removed} ARKit shape keys"] if removed else []


# --- captures keyed onto the keys ---------------------------------------------------------------------


def has_keys(face) -> bool:
    return len(face.data.get(KEYS_PROP, ())) == len(ARKIT_NAMES)


def _clear_capture(key) -> None:
    """Take a capture's action off a Key datablock (a user's own action stays)."""
    anim = key.animation_data
    if anim is not None and anim.action is not None and animation.is_stream_action(anim.action):
        action = anim.action
        anim.action = None
        if action.users == 0:
            bpy.data.actions.remove(action)


def key_capture(context, face, capture, frames: np.ndarray) -> list[str]:
    """Key a capture's weights onto the ARKit keys of the face and its parts, at scene `frames`, as one action
    per mesh named after the capture; an earlier capture's keys are replaced."""
    if not has_keys(face):
        raise Mpeg4Error(f"{face.name} has no ARKit shape keys: run Make ARKit Shape Keys first, or import to FAPs")
    settings = face.mpeg4_face
    holders = [face, *(getattr(settings, name) for name in FOLLOWING_PARTS)]
    holders = [ob for ob in holders if ob is not None and ob.type == "MESH" and ob.data.get(KEYS_PROP)]
    keyed = 0
    with progress(context, len(holders)) as step:
        for i, ob in enumerate(holders):
            key = ob.data.shape_keys
            _clear_capture(key)
            action = bpy.data.actions.new(f"{capture.name} {ob.name}")
            action[CREATED_PROP] = True
            action[animation.STREAM_PROP] = capture.name
            anim = key.animation_data or key.animation_data_create()
            anim.action = action
            for name in ob.data[KEYS_PROP]:
                fcurve = animation.ensure_fcurve(key, f'key_blocks["{name}"].value', 0, action.name)
                animation.set_keys(fcurve, frames, capture.weights[:, ARKIT_INDEX[name]])
                keyed += 1
            step(i)
    return [f"keyed {keyed} ARKit shape keys over {len(frames)} frames of {capture.name}"]
