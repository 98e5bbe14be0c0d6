"""Fitting the face to a person (Escher, Pandzic, Magnenat-Thalmann): Fit to Feature Points, Import and Export
FDP, Fit to Calibration Mesh and Back to Generic; the services and their operators.

Every fit starts from the generic face (recorded by `fitting_store` at the first fit) and works out
everything before the scene changes: the given FPs, the completed FP set (§3.1.1), the DFFD binding of the
generic face (cached), the fitted rest mesh (§3.1 or §3.3), where each rigid part goes, the UVs (§3.2). Then
it writes the fitted face and runs Set Up again, so FAPU and the Planar Bones binding are those of the
fitted face and a .fap stream plays on it at once. A set-up that refuses the fitted face puts everything
back as it was.

Rigid parts (eyeballs, teeth, tongue, lashes) keep their meshes: each follows the least-squares similarity
(rotation, uniform scale, translation; Umeyama 1991) of its own FPs' motion, applied to its transform, so
an eye is re-centred between its pupil, corners and lids and the lower teeth go with the jaw and lip FPs.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from bpy.props import FloatProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper
from mathutils import Euler, Matrix, Quaternion, Vector

from ..errors import Mpeg4Error
from ..fitting import xface_fdp
from ..fitting.calibration import fit_to_calibration_mesh
from ..fitting.cylinder import on_outer_surface
from ..fitting.dffd import DffdBinding, bind_dffd, deform_dffd
from ..fitting.fdp_file import Fdp, FdpFileError, parse_fdp, write_fdp
from ..fitting.feature_point_set import COINCIDENT_FRACTION, coincident_groups, extent, fp_array
from ..fitting.missing_points import CompletedFeaturePoints, complete_feature_points
from ..fitting.texture import texture_coordinates
from ..fitting.xface_fdp import XfaceFdp
from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.fapu import Fapu, FapuError, check_plausible, compute_fapu
from ..user_files import file_problem, read_regular_file
from . import face_data, face_setup, fap_io, fitting_store, followers, fp_empties, live, poll, rest_shape
from .fitting_store import FaceShape, PartPose
from .reporting import Mpeg4Operator, Warn, progress

AXES = BLENDER_FACE_AXES
# the FPs each rigid part follows
PART_FPS = {
    "left_eye": ("3.5", "3.7", "3.11", "3.1", "3.3", "3.9", "3.13"),
    "right_eye": ("3.6", "3.12", "3.8", "3.2", "3.4", "3.10", "3.14"),
    "upper_teeth": ("9.8", "9.10", "2.2", "2.6", "2.7", "2.4", "2.5"),
    "lower_teeth": ("9.9", "9.11", "2.3", "2.8", "2.9", "2.1", "2.10"),
    "tongue": ("6.1", "6.2", "6.3", "6.4"),
}
FIT_SIZE_LIMIT = 100.0  # the given FPs' spread against the generic face's: beyond it, another unit, not a person
FLAT_FRACTION = 1e-3  # FPs whose second spread is below this fraction of the first are too flat to turn a part


# ----------------------------------------------------------------------------- rigid parts


def rigid_parts(face) -> dict[bpy.types.Object, tuple[str, ...]]:
    """Object -> the FPs it follows: the followers set-up found, the upper teeth and lashes among the children."""
    settings = face.mpeg4_face
    guessed = followers.find_followers(face)
    parts = {}
    for role in ("left_eye", "right_eye", "lower_teeth", "tongue"):
        ob = getattr(settings, role) or guessed[role]
        if ob is not None:
            parts[ob] = PART_FPS[role]
    for child in face.children:
        name = child.name.lower()
        if child.type != "MESH" or child in parts:
            continue
        if "teeth" in name and ("upper" in name or "top" in name):
            parts[child] = PART_FPS["upper_teeth"]
        elif "lash" in name:
            centre = child.matrix_local @ (sum((Vector(c) for c in child.bound_box), Vector()) / 8.0)
            side = centre.x / max(max(c[0] for c in face.bound_box) - min(c[0] for c in face.bound_box), 1e-9)
            left, right = PART_FPS["left_eye"], PART_FPS["right_eye"]
            parts[child] = left if side > 0.05 else right if side < -0.05 else left + right
    return parts


def similarity(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """The 4x4 rotation, uniform scale and translation that best maps points `before` onto `after` (Umeyama)."""
    centre_before, centre_after = before.mean(axis=0), after.mean(axis=0)
    p, q = before - centre_before, after - centre_after
    u, spread, vt = np.linalg.svd(q.T @ p)
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rotation = u @ flip @ vt
    scale = float(np.sum(spread * np.diag(flip)) / np.sum(p * p))
    out = np.eye(4)
    out[:3, :3] = scale * rotation
    out[:3, 3] = centre_after - scale * rotation @ centre_before
    return out


def _turns_rigidly(points: np.ndarray) -> bool:
    """Enough spread in two directions to fix a rotation."""
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    return len(points) >= 3 and spread[1] > FLAT_FRACTION * spread[0]


def part_motion(fp_ids, generic: dict[str, np.ndarray], fitted: dict[str, np.ndarray]) -> np.ndarray:
    """The similarity a part with FPs `fp_ids` follows; the whole face's when its own FPs are too few."""
    ids = [fp_id for fp_id in fp_ids if fp_id in generic and fp_id in fitted]
    if not _turns_rigidly(np.array([generic[f] for f in ids]).reshape(-1, 3)):
        ids = [fp_id for fp_id in generic if fp_id in fitted]
    return similarity(np.array([generic[f] for f in ids]), np.array([fitted[f] for f in ids]))


def _basis_space(face, ob) -> Matrix:
    """The map from the space of `ob`'s own transform to the face's local space."""
    if ob.parent == face and ob.parent_type == "OBJECT":
        return ob.matrix_parent_inverse.copy()
    return face.matrix_world.inverted() @ ob.matrix_world @ ob.matrix_basis.inverted()


def moved_pose(face, ob, pose: PartPose, motion: np.ndarray) -> PartPose:
    """`pose` of `ob` carried by the face-local similarity `motion`; the mesh itself is not touched."""
    space = _basis_space(face, ob)
    local = space.inverted() @ Matrix(motion.tolist()) @ space
    _translation, turn, scales = local.decompose()
    factor = (abs(scales.x * scales.y * scales.z)) ** (1.0 / 3.0)
    changes = {"location": tuple(local @ Vector(pose.location)), "scale": tuple(factor * s for s in pose.scale)}
    if pose.rotation_mode == "QUATERNION":
        changes["rotation_quaternion"] = tuple(turn @ Quaternion(pose.rotation_quaternion))
    elif pose.rotation_mode == "AXIS_ANGLE":
        angle, *axis = pose.rotation_axis_angle
        axis, angle = (turn @ Quaternion(axis, angle)).to_axis_angle()
        changes["rotation_axis_angle"] = (angle, *axis)
    else:
        old = Euler(pose.rotation_euler, pose.rotation_mode)
        changes["rotation_euler"] = tuple((turn @ old.to_quaternion()).to_euler(pose.rotation_mode, old))
    return dataclasses.replace(pose, **changes)


# ----------------------------------------------------------------------------- planning a fit


@dataclass
class FitPlan:
    """Everything a fit writes, computed before the scene changes."""

    generic: FaceShape
    record_generic: bool  # the generic face was captured now (first fit): save it
    binding: DffdBinding
    key: str
    completion: CompletedFeaturePoints
    fitted: FaceShape
    notes: list[str]


def _refuse_animated(face) -> None:
    animated = [
        ob.name
        for ob in face_data.fp_empties(face).values()
        if ob.animation_data is not None and (ob.animation_data.action or len(ob.animation_data.nla_tracks))
    ]
    if animated:
        raise Mpeg4Error(
            f"{', '.join(animated[:3])}{' and others' if len(animated) > 3 else ''} are animated: fitting changes the "
            "neutral face, which the keys are relative to; remove the animation (or Remove Set-Up) first"
        )


def generic_face(face) -> tuple[FaceShape, bool]:
    """The generic face: the recorded one, or (first fit) the face as set up now; True when captured now."""
    _refuse_animated(face)
    generic = fitting_store.load_generic(face)
    if generic is not None:
        return generic, False
    if fitting_store.has_generic(face):
        raise Mpeg4Error(
            f"{face.name}'s mesh was edited after fitting and no longer fits its generic shape: Remove Set-Up "
            "keeps it as it is"
        )
    neutral = {}
    for fp_id, ob in face_data.fp_empties(face).items():
        stored = ob.get(face_data.EMPTY_REST_PROP)
        if stored is None or len(stored) != 3:
            raise Mpeg4Error(f"{ob.name} has no neutral position: run Set Up Face first")
        neutral[fp_id] = np.array(stored, dtype=np.float64)
    shape = fitting_store.capture(face, neutral, rigid_parts(face))
    own = rest_shape.SHAPE_KEY_NAME
    keys = {name: co for name, co in shape.keys.items() if name != own}
    return dataclasses.replace(shape, positions=shape.rest, keys=keys), True


def placed_fps(face, generic: FaceShape) -> dict[str, np.ndarray]:
    """The FPs as the artist placed them: every empty on the face's outer surface, and those inside (teeth,
    tongue, 7.1), which a picture cannot show, only where they were moved; of FPs one on the generic face
    only the moved ones."""
    empties = face_data.fp_empties(face)
    now = face_data.local_positions(face, empties)
    unknown = [fp_id for fp_id in now if fp_id not in generic.fps]
    if unknown:
        raise Mpeg4Error(
            f"FP {', '.join(unknown)} {'was' if len(unknown) == 1 else 'were'} placed after the first fit: the generic "
            "face has no such point (Back to Generic, Set Up Face, then fit)"
        )
    tolerance = COINCIDENT_FRACTION * extent(np.array(list(now.values())).reshape(-1, 3))
    moved = set()
    for fp_id, ob in empties.items():
        neutral = ob.get(face_data.EMPTY_REST_PROP)
        if neutral is None or np.linalg.norm(now[fp_id] - np.array(neutral, dtype=np.float64)) > tolerance:
            moved.add(fp_id)
    given = {fp_id: p for fp_id, p in now.items() if on_outer_surface(fp_id) or fp_id in moved}
    ids, points = fp_array(generic.fps, "generic face")
    for group in coincident_groups(ids, points):
        if any(fp_id in moved for fp_id in group):
            for fp_id in group:
                if fp_id not in moved:
                    given.pop(fp_id, None)
    return given


def dffd_binding(context, face, generic: FaceShape) -> tuple[DffdBinding, str]:
    """The generic face's DFFD binding: cached by a digest of its rest shape and FPs, else computed now."""
    key = fitting_store.binding_key(generic.rest, generic.fps)
    binding = fitting_store.load_binding(face, key)
    if binding is None:
        with progress(context, len(generic.rest)) as step:
            binding = bind_dffd(generic.rest.astype(np.float64), generic.fps, progress=lambda done, _n: step(done))
    return binding, key


def plan_fit(context, face, given, calibration=None) -> FitPlan:
    """The fit of the generic face to the `given` FPs (face-local; or a function of the generic face giving
    them), or onto `calibration` (vertices, triangles and FPs of a calibration mesh, face-local) with the FP
    fit where the mesh does not reach."""
    generic, record = generic_face(face)
    if callable(given):
        given = given(face, generic)
    _check_size(given, generic.fps)
    completion = complete_feature_points(generic.fps, given, AXES)  # checks the FPs before the long bind
    binding, key = dffd_binding(context, face, generic)
    vertices = deform_dffd(binding, completion.positions)
    notes = [f"fitted {face.name} to {len(given)} feature points" + _completed(completion)]
    if calibration is not None:
        mesh_vertices, triangles, mesh_fps = calibration
        fit = fit_to_calibration_mesh(
            generic.rest.astype(np.float64), generic.fps, mesh_vertices, triangles, mesh_fps, AXES, fallback=vertices
        )
        vertices = fit.vertices
        notes[0] = (
            f"fitted {face.name} onto the calibration mesh: {int(fit.on_ray.sum())} vertices on their rays, "
            f"{int(fit.interpolated.sum())} interpolated, {int(fit.fallback.sum())} from the feature-point fit"
            + _completed(completion)
        )
    if not np.all(np.isfinite(vertices)):
        raise Mpeg4Error("the fit gave positions that are not finite: check the feature points")
    fitted = fitted_shape(face, generic, vertices, completion.positions)
    if fitted.parts:
        notes.append(f"moved {', '.join(sorted(fitted.parts))} with the fit")
    return FitPlan(generic, record, binding, key, completion, fitted, notes)


def _check_size(given: dict[str, np.ndarray], generic: dict[str, np.ndarray]) -> None:
    """Refuse FPs that are not finite or whose spread is not within FIT_SIZE_LIMIT of the generic face's: a fit
    changes the face's shape, not its unit (scale the object for that)."""
    bad = [fp_id for fp_id, p in given.items() if not np.all(np.isfinite(p))]
    if bad:
        raise Mpeg4Error(f"FP {', '.join(bad[:5])} {'is' if len(bad) == 1 else 'are'} not at a finite position")
    common = [fp_id for fp_id in given if fp_id in generic]
    if len(common) < 2:
        return  # complete_feature_points says what is missing
    spread = extent(np.array([given[f] for f in common]))
    own = extent(np.array([generic[f] for f in common]))
    if own > 0.0 and not own / FIT_SIZE_LIMIT <= spread <= own * FIT_SIZE_LIMIT:
        raise Mpeg4Error(
            f"the feature points span {spread:.4g} units where the face's own span {own:.4g}, more than "
            f"{FIT_SIZE_LIMIT:g} times {'larger' if spread > own else 'smaller'}: a fit changes the face's shape, "
            "not its size; scale the face (or give the points in the face's units) and fit again"
        )


def _completed(completion: CompletedFeaturePoints) -> str:
    missing = len(completion.interpolated) + len(completion.affine)
    if not missing:
        return ""
    return (
        f" ({missing} completed: {len(completion.interpolated)} interpolated, {len(completion.outside)} of them "
        f"outside the given points, {len(completion.affine)} carried by their affine fit)"
    )


def fitted_shape(face, generic: FaceShape, vertices: np.ndarray, fps: dict[str, np.ndarray]) -> FaceShape:
    """The face after the fit: the fitted rest (shape keys keep their offsets), FPs and moved rigid parts."""
    rest = vertices.astype(np.float32)
    motion = vertices - generic.rest.astype(np.float64)
    keys = {name: (co.astype(np.float64) + motion).astype(np.float32) for name, co in generic.keys.items()}
    mesh_keys = face.data.shape_keys
    if mesh_keys is not None:
        keys[mesh_keys.reference_key.name] = rest
        keys[rest_shape.SHAPE_KEY_NAME] = rest
    empties = face_data.fp_empties(face)
    follows = {ob.name: fp_ids for ob, fp_ids in rigid_parts(face).items()}
    parts = {}
    for name, pose in generic.parts.items():
        ob = bpy.data.objects.get(name)
        if ob is not None:
            parts[name] = moved_pose(face, ob, pose, part_motion(follows.get(name, ()), generic.fps, fps))
    return FaceShape(rest, rest.copy(), keys, {fp_id: fps[fp_id] for fp_id in empties if fp_id in fps}, parts)


# ----------------------------------------------------------------------------- writing a fit


def _current(face, parts) -> FaceShape:
    empties = face_data.fp_empties(face)
    return fitting_store.capture(face, face_data.local_positions(face, empties), parts)


def write_shape(context, face, shape: FaceShape, parts) -> list[str]:
    """Write `shape` and set the face up again; on a refused set-up (or any failure) put the face back and
    re-raise."""
    before = _current(face, parts)
    live.forget(face)
    try:
        fitting_store.put(face, shape)
        context.view_layer.update()  # followers' world matrices, which set-up reads for the eyes' pivots
        return face_setup.set_up(face)
    except BaseException:  # whatever stopped it, the face goes back as it was
        live.forget(face)
        fitting_store.put(face, before)
        context.view_layer.update()
        raise


def write_fit(context, face, plan: FitPlan) -> list[str]:
    parts = [bpy.data.objects[name] for name in plan.fitted.parts]
    notes = plan.notes + write_shape(context, face, plan.fitted, parts)
    if plan.record_generic:
        fitting_store.save_generic(face, plan.generic)
    if fitting_store.stored_binding_key(face) != plan.key:
        fitting_store.save_binding(face, plan.binding, plan.key)
    return notes


def fit_to_feature_points(context, face) -> list[str]:
    """Fit the face to its FP empties as they stand now."""
    return write_fit(context, face, plan_fit(context, face, placed_fps))


def back_to_generic(context, face) -> list[str]:
    """Put the generic face back (mesh bit for bit, FPs, rigid parts, texture) and set it up again."""
    _refuse_animated(face)
    generic = fitting_store.load_generic(face)
    if generic is None:
        raise Mpeg4Error(f"{face.name} has no generic shape to go back to (it was never fitted, or was edited since)")
    parts = [ob for name in generic.parts if (ob := bpy.data.objects.get(name)) is not None]
    notes = write_shape(context, face, generic, parts)
    if fitting_store.restore_texture(face):
        notes.append("removed the FDP texture coordinates and image")
    fitting_store.remove_holder(face)  # the DFFD binding stays cached for this session
    return [f"{face.name} is back to its generic shape", *notes]


# ----------------------------------------------------------------------------- FDP files


def read_fdp_file(path: str) -> Fdp | XfaceFdp:
    """Our FDP or an XFace .fdp (XML: it starts with '<'), read once through the safe reader."""
    name = str(Path(path))
    data = read_regular_file(path, xface_fdp.MAX_BYTES, FdpFileError, name, "too large for an FDP file")
    if data.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<"):
        return xface_fdp.parse_xface_fdp(data, name)
    return parse_fdp(data, name)


def import_fdp(context, face, path: str, xface_unit: float) -> list[str]:
    """Fit the face to an FDP file's FPs (with its texture and FAPU), or apply what an XFace .fdp carries."""
    fdp = read_fdp_file(path)
    if isinstance(fdp, XfaceFdp):
        return apply_xface(face, fdp, xface_unit)
    if fdp.fapu is not None:
        check_plausible(fdp.fapu, f"{path}: fapu", like=fap_io.face_fapu(face))
    plan = plan_fit(context, face, fdp.in_mesh(AXES))
    notes = []
    uvs = None
    if fdp.texture_coordinates:
        texture = texture_coordinates(plan.fitted.rest, plan.completion.positions, fdp.texture_coordinates, AXES)
        uvs = texture.uvs
        if texture.unused:
            notes.append(Warn(f"texture coordinates of FP {', '.join(texture.unused)} not used (not on the face)"))
    image_path = None
    if fdp.image is not None:
        image_path = Path(fdp.image) if os.path.isabs(fdp.image) else Path(path).parent / fdp.image
        if uvs is None:
            notes.append(Warn(f"the image {fdp.image} comes without texture coordinates: not used"))
            image_path = None
        elif (problem := file_problem(image_path)) is not None:
            raise Mpeg4Error(f"{path}: the image {fdp.image[:80]}: {problem}")
    image, created = _load_image(image_path) if image_path is not None else (None, False)
    try:
        notes = write_fit(context, face, plan) + notes
    except Mpeg4Error:
        if created:
            bpy.data.images.remove(image)
        raise
    if uvs is not None:
        fitting_store.apply_texture(face, uvs, image, created)
        notes.append(f"texture coordinates in UV map {fitting_store.UV_MAP_NAME!r}")
        if image is not None:
            notes.append(f"image {image.name!r} in material {face.active_material.name!r}")
    if fdp.fapu is not None:
        face.mpeg4_face.fapu = tuple(fdp.fapu.as_dict().values())
        notes.append("FAPU from the file (Set Up Face measures them from the points again)")
    return notes


def _load_image(path: Path) -> tuple[bpy.types.Image, bool]:
    before = set(bpy.data.images)
    try:
        image = bpy.data.images.load(str(path), check_existing=True)
    except RuntimeError as exc:
        raise Mpeg4Error(f"cannot read the image {path}: {exc}") from None
    created = image not in before
    if image.size[0] == 0 or image.size[1] == 0:
        if created:
            bpy.data.images.remove(image)
        raise Mpeg4Error(f"the image {path} has no pixels")
    return image, created


def apply_xface(face, xface: XfaceFdp, unit: float) -> list[str]:
    """Report what an XFace .fdp carries; of it, only the FAPU applies to another face (scaled by `unit`)."""
    binds = ", ".join(
        f"{b.item}" + (f" (pivot {', '.join(f'{v:.4g}' for v in b.pivot)})" if b.pivot is not None else "")
        for b in xface.binds
    )
    fp_ids = sorted({fp.fp_id for fp in xface.feature_points})
    meshes = sorted({file for entity in xface.entities if entity.alias == "Rest" for file, _ in entity.meshes})
    notes = [
        f"XFace FDP {xface.version}: {len(xface.entities)} entities, binds {binds or 'none'}",
        f"{len(fp_ids)} FPs as control vertices of {', '.join(meshes) or 'its meshes'}, which it does not contain: "
        "no FP positions, nothing to fit",
    ]
    if xface.fapu is None:
        notes.append(Warn("it gives no FAPU: nothing applied"))
        return notes
    fapu = tuple(unit * v for v in xface.fapu.as_dict().values())
    check_plausible(Fapu(*fapu), f"XFace FAPU x {unit:g}", like=fap_io.face_fapu(face))
    face.mpeg4_face.fapu = fapu
    shown = ", ".join(f"{name} {1000 * v:.1f} mm" for name, v in zip(xface.fapu.as_dict(), fapu, strict=True))
    notes.append(f"FAPU from the file x {unit:g}: {shown} (Set Up Face measures them from the points again)")
    return notes


def export_fdp(face, path: str) -> list[str]:
    """Write the face's FP empties as they stand now (and the FAPU they give) as an FDP file."""
    empties = face_data.fp_empties(face)
    if not empties:
        raise Mpeg4Error(f"{face.name} has no feature point empties to export")
    positions = face_data.local_positions(face, empties)
    notes = []
    try:
        fapu = compute_fapu(positions, AXES)
    except FapuError as exc:
        fapu = None
        notes.append(Warn(f"no FAPU written: {exc}"))
    write_fdp(path, Fdp({fp_id: AXES @ p for fp_id, p in positions.items()}, fapu=fapu))
    return [f"wrote {len(positions)} feature points{' and FAPU' if fapu else ''} to {path}", *notes]


# ----------------------------------------------------------------------------- calibration mesh


def calibration_targets(context, face) -> tuple[list, list]:
    """(selected meshes with FP empties, selected meshes without) other than the face and its own objects."""
    own = {face.mpeg4_face.control_object, *rigid_parts(face)}
    with_fps, without = [], []
    for ob in context.selected_objects:
        if ob.type != "MESH" or ob == face or ob in own:
            continue
        coll = face_data.fp_collection(ob)
        (with_fps if coll is not None and fp_empties.candidates(coll) else without).append(ob)
    return with_fps, without


def _target_reason(context, face) -> str | None:
    with_fps, without = calibration_targets(context, face)
    if len(with_fps) > 1:
        return f"Select one calibration mesh ({', '.join(ob.name for ob in with_fps)} have feature points)"
    if with_fps:
        return None
    if without:
        name = without[0].name
        return (
            f"{name} has no feature points: place them (Place Feature Points with {name} active) or put empties "
            f"named 'FP 2.1', 'FP 9.3', ... in a collection '{name} FPs'"
        )
    return "Select the calibration mesh too (a scan or another character with its own feature points)"


def calibration_data(context, face, target) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The target's evaluated mesh (face-local vertices, triangles) and its FPs (face-local)."""
    fps = face_data.local_positions(face, fp_empties.candidates(face_data.fp_collection(target)))
    depsgraph = context.evaluated_depsgraph_get()
    evaluated = target.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", vertices)
        triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
    finally:
        evaluated.to_mesh_clear()
    if not len(triangles):
        raise Mpeg4Error(f"the calibration mesh {target.name} has no faces")
    to_face = np.array(face.matrix_world.inverted() @ target.matrix_world, dtype=np.float64)
    vertices = vertices.reshape(-1, 3) @ to_face[:3, :3].T + to_face[:3, 3]
    return vertices, triangles.reshape(-1, 3), fps


def fit_to_calibration(context, face) -> list[str]:
    reason = _target_reason(context, face)
    if reason is not None:
        raise Mpeg4Error(reason)
    target = calibration_targets(context, face)[0][0]
    vertices, triangles, fps = calibration_data(context, face, target)
    return write_fit(context, face, plan_fit(context, face, fps, calibration=(vertices, triangles, fps)))


# ----------------------------------------------------------------------------- operators


def _no_generic(context) -> str | None:
    reason = poll.not_set_up(context)
    if reason is None and not fitting_store.has_generic(face_data.active_face(context)):
        return f"{face_data.active_face(context).name} has not been fitted"
    return reason


class MPEG4_OT_fit_to_feature_points(Mpeg4Operator, bpy.types.Operator):
    """Fit the face to its feature point empties as they stand now (move them onto a reference picture or scan
    first); eyes, teeth and tongue follow, and the face is set up again"""

    bl_idname = "mpeg4.fit_to_feature_points"
    bl_label = "Fit to Feature Points"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return fit_to_feature_points(context, poll.face(context))


class MPEG4_OT_import_fdp(Mpeg4Operator, bpy.types.Operator, ImportHelper):
    """Fit the face to a person's Facial Definition Parameters: feature points, and texture coordinates with an
    image (MPEG-4 FDP .json); an XFace .fdp gives its FAPU"""

    bl_idname = "mpeg4.import_fdp"
    bl_label = "Import FDP"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json;*.fdp", options={"HIDDEN"})
    xface_unit: FloatProperty(
        name="XFace Unit",
        description="An XFace .fdp gives FAPU in its head's model units: one unit in the face's units "
        "(0.001: millimetres to metres)",
        default=0.001,
        min=1e-9,
        soft_max=1.0,
        precision=4,
    )

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return import_fdp(context, poll.face(context), self.filepath, self.xface_unit)


class MPEG4_OT_export_fdp(Mpeg4Operator, bpy.types.Operator, ExportHelper):
    """Write the face's feature points as they stand now (and the FAPU they give) as an MPEG-4 FDP file"""

    bl_idname = "mpeg4.export_fdp"
    bl_label = "Export FDP"
    bl_options = {"REGISTER"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    @classmethod
    def unavailable(cls, context):
        reason = poll.no_face(context)
        if reason is None and not face_data.fp_empties(face_data.active_face(context)):
            return f"{face_data.active_face(context).name} has no feature point empties"
        return reason

    def run(self, context):
        return export_fdp(poll.face(context), self.filepath)


class MPEG4_OT_fit_to_calibration_mesh(Mpeg4Operator, bpy.types.Operator):
    """Lay the active face onto the other selected mesh (a scan or another character with its own feature points),
    with the fit to those points where the mesh does not reach; the face is set up again"""

    bl_idname = "mpeg4.fit_to_calibration_mesh"
    bl_label = "Fit to Calibration Mesh"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context) or _target_reason(context, face_data.active_face(context))

    def run(self, context):
        return fit_to_calibration(context, poll.face(context))


class MPEG4_OT_fit_reset(Mpeg4Operator, bpy.types.Operator):
    """Put the generic face back as it was before the first fit (mesh, feature points, eyes and teeth, texture)
    and set it up again"""

    bl_idname = "mpeg4.fit_reset"
    bl_label = "Back to Generic"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return _no_generic(context)

    def run(self, context):
        return back_to_generic(context, poll.face(context))


CLASSES = (
    MPEG4_OT_fit_to_feature_points,
    MPEG4_OT_import_fdp,
    MPEG4_OT_export_fdp,
    MPEG4_OT_fit_to_calibration_mesh,
    MPEG4_OT_fit_reset,
)
