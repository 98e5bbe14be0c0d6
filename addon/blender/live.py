"""The live, modifier-like effect: each enabled face follows its FP empties on every frame and edit.

Handlers (registered in registration.py) call `apply_scene`. Per face a small playback state is kept
by the face's session_uid (the binding comes from binding_store's cache), so a frame costs: read the
control empties, one `evaluate`, one float32 write. Nothing is written when the control positions did
not change, which also keeps the depsgraph handler from feeding itself.

The pose written into the mesh must never become its shape. In Edit Mode the effect pauses and the
edit mesh shows the rest shape; a shape key added while posed gets the rest positions back; a mesh whose
vertex count changed while posed (an applied modifier) is kept as it is and the effect turns off with a
message. Problems turn the effect off and leave a message in the face's `status`, which the panel shows;
a handler never raises.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
from dataclasses import dataclass

import bpy
import numpy as np

from ..deform import fused, unfold
from ..deform.lips import LipGuard, bind_lip_guard, guard_lips, mouth_sides, press_apart
from ..deform.loose_parts import DRIVERS, RigidParts, move_parts
from ..deform.neck import turn_back
from ..deform.planar_bones import Binding, evaluate, playback, prepare_playback
from ..errors import Mpeg4Error
from ..mpeg4.decode import head_pivot
from ..mpeg4.feature_points import FP_IDS, fp_index
from . import (
    binding_store,
    elastic_rig,
    elastic_skin,
    eyelid_rig,
    face_data,
    fp_empties,
    head_motion,
    inner_parts,
    rest_shape,
    skin_view,
)

log = logging.getLogger(__name__)

MODES = {"PLANAR_BONES": "planar_bones", "SOFFD": "soffd"}
PAUSED_IN_EDIT_MODE = "Paused in Edit Mode (the rest shape is shown)"
OUT = np.float32  # the deformed positions, as the mesh holds them
_NATIVE_GUARD = True  # the compiled guard where the kernel has it (its numpy reference: lips.guard_lips)


@dataclass
class _State:
    key: str
    binding: Binding
    reader: face_data.FpReader  # the control FPs' empties (the control mesh's vertex order), then the lids' others
    n_control: int
    fp_rows: np.ndarray  # each read FP's row in FP_IDS order
    out: np.ndarray
    on_shape_key: bool  # the mesh had shape keys when this state was made
    last: np.ndarray | None = None
    control_shown: np.ndarray | None = None  # the `last` the control mesh shows
    mode: str = ""
    lip_guard: LipGuard | None = None  # keeps the lips' skin from passing through each other
    lips_guarded: bool | None = None  # the Keep Lips Apart setting `lip_guard` was made for
    lip_points: np.ndarray | None = None  # the control points that move the lips' skin or the seam between them
    lip_arrays: fused.GuardArrays | None = None  # `lip_guard` for the compiled kernel
    playback: fused.Playback | None = None  # the kernel's frame-to-frame evaluator of `out` in `mode`, if any
    guard_made: tuple | None = None  # (its inputs, the guard): a rebind keeps it when they did not change
    lip_skin_groups: np.ndarray | None = None  # the playback's groups of what the lip guard may move
    fps: np.ndarray | None = None  # (84, 3) the last read FPs in FP_IDS order (`_fp_array`)
    skin: unfold.SkinMesh | None = None  # Unfold Skin's view of the face, once per state (`_skin_mesh`)
    skin_slot: list | None = None  # the look kept beside `skin` by `skin_view`
    look_made: tuple | None = None  # (playback, skin, `unfold.Look`) at the playback's groups (`_look`)
    parts: RigidParts | None = None  # the eyeballs, teeth and tongue inside the face object, moved rigidly
    part_rows: np.ndarray | None = None  # the rows of `fps` that drive them
    parts_last: np.ndarray | None = None  # those rows at the last frame
    part_groups: np.ndarray | None = None  # the playback's groups holding their vertices
    body: tuple[np.ndarray, np.ndarray] | None = None  # a head on a body: (vertices, share of the head turn undone)
    body_groups: np.ndarray | None = None  # the playback's groups holding them
    pivot: np.ndarray | None = None  # FP 7.1 at rest: what the head turns about
    turn: np.ndarray | None = None  # the head turn at the last frame (mesh coordinates)

    @functools.cached_property
    def control_ids(self) -> tuple[str, ...]:
        """The control mesh's FP ids, in its vertex order."""
        return tuple(self.reader.fp_ids[: self.n_control])


_states: dict[int, _State] = {}
_editing: set[int] = set()  # faces paused in Edit Mode, by session_uid
_busy = False


def forget(face: bpy.types.Object | None = None) -> None:
    """Drop cached state (all faces, or one)."""
    if face is None:
        _states.clear()
        _editing.clear()
        _scenes.clear()  # it holds objects: after undo or loading they are gone
        binding_store.forget()
        elastic_rig.forget()
        elastic_skin.forget()
        eyelid_rig.forget(keep_made=True)
    else:
        _states.pop(face.session_uid, None)
        elastic_rig.forget(face)
        elastic_skin.forget(face)
        eyelid_rig.forget(face, keep_made=True)
        if face.type == "MESH":
            binding_store.forget(face)


def _linked(ob) -> bool:
    return ob is not None and bool(ob.users_collection)


def _state(face) -> _State:
    mesh = face.data
    key = binding_store.stored_key(face)
    state = _states.get(face.session_uid)
    if state is not None and state.key == key and state.binding.n_vertices == len(mesh.vertices):
        return state
    binding = binding_store.load(face)
    if binding is None:
        raise LookupError("the face is not bound: run Set Up Face")
    if binding.n_vertices != len(mesh.vertices):
        raise LookupError(f"the mesh has {len(mesh.vertices)} vertices but was bound with {binding.n_vertices}")
    control = face.mpeg4_face.control_object
    ids = list(control.data.get(face_data.FP_IDS_PROP, ()))
    out = np.empty((binding.n_vertices, 3), dtype=OUT)
    present = face_data.fp_empties(face)
    watched = [fp_id for fp_id in eyelid_rig.WATCHED if fp_id not in ids and fp_id in present]
    parts = inner_parts.rigid_parts(face, binding.rest_vertices)
    if parts is not None:
        drivers = [DRIVERS[role] for role in parts.vertices if role in DRIVERS]
        watched += [fp_id for fp_id in drivers if fp_id not in ids and fp_id not in watched and fp_id in present]
    reader = face_data.FpReader(ids + watched)  # one read a frame serves the deformer and the eyelids
    rows = np.array([fp_index(fp_id) for fp_id in reader.fp_ids], dtype=np.intp)
    state = _State(key, binding, reader, len(ids), rows, out, mesh.shape_keys is not None, parts=parts)
    state.body = head_motion.body_share(face)
    if state.body is not None:
        state.pivot = head_pivot(face_data.neutral_positions(present))
    if parts is not None:
        state.part_rows = np.array([fp_index(DRIVERS[role]) for role in parts.vertices if role in DRIVERS], np.intp)
    earlier = _states.get(face.session_uid)
    state.guard_made = None if earlier is None else earlier.guard_made  # a setting's rebind leaves the lips as they are
    _states[face.session_uid] = state
    return state


LIP_FPS = {"2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9"}
MOUTH_BOX_ROWS = [fp_index("8.1"), fp_index("8.2")]  # the outer lip contour bounds the lips' vertices (`mouth_sides`)


def _lip_guard(face, state: _State) -> tuple[LipGuard | None, np.ndarray | None]:
    """The lip guard for the face's rest shape and the control points that move what it guards (the lips'
    skin, the seam between them); (None, None) when it is off or the face lacks inner-lip FPs or lip masks
    (nothing then keeps the lips' skin apart but the FPs' order), or the masks leave a lip without a vertex."""
    control_ids = state.control_ids
    if not face.mpeg4_face.keep_lips_apart or not LIP_FPS <= set(control_ids):
        return None, None
    masks = binding_store.set_up_masks(face)
    if "upper_lip" not in masks or "lower_lip" not in masks:
        return None, None
    binding = state.binding
    neutral = face_data.neutral_positions(face_data.fp_empties(face))
    if not np.isfinite(neutral[MOUTH_BOX_ROWS]).all():
        return None, None
    axes = face_data.face_axes(face)
    triangles = face_data.mesh_fans(face.data)[0]
    upper, lower = mouth_sides(
        binding.rest_vertices, masks["upper_lip"], masks["lower_lip"], neutral, axes=axes, triangles=triangles
    )
    if state.parts is not None:  # teeth and tongue in the mouth are no lip
        upper[state.parts.all_vertices] = lower[state.parts.all_vertices] = False
    if not (upper.any() and lower.any()):
        return None, None
    inputs = (binding.rest_vertices, binding.control_rest, np.array(control_ids), triangles, upper, lower, axes)
    made = state.guard_made
    if made is not None and binding_store.same_inputs(made[0], inputs):
        guard = made[1]  # 0.3 s at 68k vertices (the skin beside the lips, along the mesh): not again
    else:
        guard = bind_lip_guard(*inputs[:2], tuple(control_ids), *inputs[3:6], axes=axes)
        state.guard_made = inputs, guard
    moving = np.unique(binding.pair_triangle[np.isin(binding.pair_vertex, guard.vertices)])
    seam = [k for k, fp_id in enumerate(control_ids) if fp_id in LIP_FPS]
    return guard, np.union1d(binding.triangles[moving].ravel(), seam)


def _skin_mesh(face, state: _State) -> unfold.SkinMesh:
    """Unfold Skin's view of the face's rest shape and faces: taken once for a state from `skin_view`, which keeps
    it for the next state (a setting's rebind) while the rest shape and the polygons' corners are the same."""
    if state.skin is None:
        state.skin, state.skin_slot = skin_view.skin_mesh(face, state.binding.rest_vertices)
    return state.skin


def _look(face, state: _State, skin: unfold.SkinMesh) -> unfold.Look:
    """Unfold Skin's look at the groups the playback wrote (made again when its layout or the skin changes)."""
    made, playback = state.look_made, state.playback
    if made is None or made[0] is not playback or made[1] is not skin:
        layout = playback.layout
        slot = state.skin_slot  # kept by `skin_view` with `skin`
        look = slot[0]  # the look at the last layout's groups, kept while the grouping is the same
        if (
            look is None
            or look.mesh is not skin
            or len(look.off_rest) != len(layout.group_mask)
            or not np.array_equal(look.grouping, layout.vertex_group)
        ):
            look = slot[0] = unfold.group_look(skin, layout.vertex_group, len(layout.group_mask))
        state.look_made = made = playback, skin, dataclasses.replace(look, off_rest=playback.off_rest)
    return made[2]


def _guard_arrays(guard: LipGuard) -> fused.GuardArrays:
    return fused.GuardArrays.of(
        guard.vertices,
        guard.side,
        guard.slack,
        guard.knots,
        guard.order,
        guard.starts,
        guard.spread,
        guard.axes,
        guard.reach,
        guard.width,
        guard.skin,
        guard.sources,
        guard.shares,
    )


def _start_playback(face, state: _State, mode: str) -> None:
    """A frame-to-frame evaluator of the face's output in `mode` (None without the compiled kernel), told which
    vertices the eyelids may move after the deformer (the lip guard says when it moved the lips' skin)."""
    state.playback = playback(state.binding, mode, state.out, eyelid_rig.turned_vertices(face, state.binding))
    skin = None if state.lip_guard is None or state.playback is None else state.lip_guard.skin
    state.lip_skin_groups = None if skin is None else state.playback.groups_of(skin)
    parts = None if state.parts is None or state.playback is None else state.parts.all_vertices
    state.part_groups = None if parts is None else state.playback.groups_of(parts)
    body = None if state.body is None or state.playback is None else state.body[0]
    state.body_groups = None if body is None else state.playback.groups_of(body)


def control_positions(face, state: _State) -> np.ndarray:
    """(M, 3) face-local positions of the control FPs, in the control mesh's vertex order."""
    return state.reader.read(face)[: state.n_control]


def _fp_array(state: _State, read: np.ndarray) -> np.ndarray:
    """(84, 3) the read FPs in FP_IDS order, NaN for the others (the state's array, rewritten each frame)."""
    if state.fps is None:
        state.fps = np.full((len(FP_IDS), 3), np.nan)
    state.fps[state.fp_rows] = read
    return state.fps


def _posed_changed_mesh(face, state: _State | None) -> bool:
    """Guard the rest shape against edits made while the face was posed; True when the effect must stop."""
    mesh = face.data
    if state is None or state.last is None:
        return False
    if len(mesh.vertices) != state.binding.n_vertices:
        disable(
            face,
            f"Deformation turned off: {face.name}'s mesh changed from {state.binding.n_vertices} to "
            f"{len(mesh.vertices)} vertices. The mesh is kept as it is (Ctrl+Z brings the old one back); run "
            "Set Up Face to bind it",
            keep_mesh=True,
        )
        return True
    if mesh.shape_keys is not None and not state.on_shape_key:
        # a key added while posed copied the pose: give every vertex still at the pose its rest position back
        rest = state.binding.rest_vertices.astype(np.float32)
        for block in mesh.shape_keys.key_blocks:
            co = rest_shape.read_key(block)
            at_pose = np.all(co == state.out, axis=1)
            co[at_pose] = rest[at_pose]
            block.data.foreach_set("co", co.ravel())
        mesh.attributes["position"].data.foreach_set("vector", rest.ravel())
        mesh.update()
        forget(face)
    return False


def _pause_for_edit_mode(face) -> None:
    """Entering Edit Mode: show (and so edit) the rest shape, not the pose."""
    import bmesh

    _editing.add(face.session_uid)
    state = _states.get(face.session_uid)
    mesh = face.data
    face.mpeg4_face.status = PAUSED_IN_EDIT_MODE
    if state is None or state.last is None or state.on_shape_key:
        return
    bm = bmesh.from_edit_mesh(mesh)
    if len(bm.verts) != state.binding.n_vertices:
        return
    rest = state.binding.rest_vertices.astype(np.float32)
    for vert, pose, back in zip(bm.verts, state.out, rest, strict=True):
        if tuple(vert.co) == tuple(pose):  # not yet edited
            vert.co = back
    bmesh.update_edit_mesh(mesh, loop_triangles=False, destructive=False)
    state.last = None


def _resume_after_edit_mode(face) -> bool:
    """Back from Edit Mode: go on if the mesh is the bound rest shape, else keep the edit and stop."""
    _editing.discard(face.session_uid)
    mesh = face.data
    binding = binding_store.load(face)
    now = rest_shape.current_rest(mesh)
    if face.mpeg4_face.status == PAUSED_IN_EDIT_MODE:
        face.mpeg4_face.status = ""
    if binding is not None and now.shape == binding.rest_vertices.shape:
        if np.array_equal(now, binding.rest_vertices.astype(np.float32)):
            return True
    disable(
        face,
        f"Deformation turned off: {face.name} was edited in Edit Mode. Run Set Up Face to bind the new shape",
        keep_mesh=True,
    )
    return False


def apply_face(face, force: bool = False, present: frozenset | None = None) -> bool:
    """Deform `face` from its empties; returns False (and disables the effect) on a problem. `present`: the
    session ids of the scene's objects, where the control mesh is found without looking through every
    collection of the file (it may also be in a collection outside the scene)."""
    settings = face.mpeg4_face
    if settings.engine == elastic_rig.ELASTIC:  # the Armature modifier deforms: pose the skeleton, not the mesh
        return _apply_elastic(face, force)
    if face.mode == "EDIT":
        if face.session_uid not in _editing:
            _pause_for_edit_mode(face)
        return True
    if face.session_uid in _editing and not _resume_after_edit_mode(face):
        return False
    try:
        control = settings.control_object
        in_scene = present is not None and control is not None and control.session_uid in present
        if not (in_scene or _linked(control)):
            raise LookupError("the control mesh was deleted")
        if _posed_changed_mesh(face, _states.get(face.session_uid)):
            return False
        state = _state(face)
        read = state.reader.read(face)
        points, fps = read[: state.n_control], _fp_array(state, read)
        mode = MODES[settings.mode]
        same = state.last is not None and np.array_equal(points, state.last)
        parts_still = state.parts is None or (
            state.parts_last is not None and np.array_equal(fps[state.part_rows], state.parts_last, equal_nan=True)
        )
        turn = None if state.body is None else head_motion.mesh_turn(face)
        turn_still = turn is None or (state.turn is not None and np.array_equal(turn, state.turn))
        still = same and parts_still and turn_still
        if not force and state.mode == mode and still and eyelid_rig.still(face, state.binding, fps):
            _show_control(settings.control_object, state)
            return True
        control_ids = state.control_ids
        driving = eyelid_rig.hold(face, state.binding, control_ids, points)  # the lids turn on their own
        if state.lips_guarded != settings.keep_lips_apart:
            (state.lip_guard, state.lip_points), state.lips_guarded = _lip_guard(face, state), settings.keep_lips_apart
            state.lip_arrays = None if state.lip_guard is None else _guard_arrays(state.lip_guard)
            state.playback = None  # the guarded vertices changed: start again
        if state.playback is None or state.mode != mode:
            _start_playback(face, state, mode)
        off_rest = None  # the playback's groups that may be off their rest in `out` this frame (None: unknown)
        if np.array_equal(driving, state.binding.control_rest):
            state.out[...] = state.binding.rest_vertices  # the neutral face exactly, not up to rounding
            if state.playback is not None:
                state.playback.changed()
        else:
            if state.playback is None or not state.playback.evaluate(driving):
                evaluate(state.binding, driving, mode=mode, out=state.out)
                state.playback = None  # out was written whole: a new evaluator next frame
            else:
                off_rest = state.playback.off_rest
            _keep_lips_apart(state, driving, off_rest)
        if eyelid_rig.apply(face, state.binding, state.out, fps) and off_rest is not None:  # no V, no crossing
            off_rest[state.playback.rewritten] = 1  # the lids turned their groups
        if state.parts is not None:  # eyeballs, teeth and tongue: rigid, wherever the skin's deformers put them
            move_parts(state.parts, state.out, fps)
            state.parts_last = fps[state.part_rows].copy()
            if state.playback is not None:
                state.playback.changed(state.part_groups)  # the next frame writes them afresh
                if off_rest is not None:
                    off_rest[state.part_groups] = 1
        state.turn = turn
        if turn is not None and not np.array_equal(turn, np.eye(3)):  # the body stays as the head turns
            turn_back(state.out, *state.body, turn, state.pivot)
            if state.playback is not None:
                state.playback.changed(state.body_groups)
                if off_rest is not None:
                    off_rest[state.body_groups] = 1
        if settings.unfold_skin:  # no face shows its back
            skin = _skin_mesh(face, state)
            # at rest no face is turned over: only faces with a corner off its rest can be (0.1 ms of a look at
            # every face at 17k vertices, a third of that at the demo's moving skin)
            # the look is made with the playback (0.15 s at 53k vertices: at set-up, not at the first frame that moves)
            look = None if state.playback is None else _look(face, state, skin)
            look = None if off_rest is None else look
            moved = unfold.open_folds_guarded(
                skin,
                state.out,
                lambda: _keep_lips_apart(state, driving, None),  # the seam and the contact again after the membrane
                look,
                max_steps=unfold.frame_steps(skin.n_vertices),
                guarded=None if state.lip_guard is None else state.lip_guard.skin,
                work=unfold.FRAME_WORK,
            )
            if len(moved) and state.playback is not None:
                state.playback.changed(state.playback.groups_of(moved))  # the next frame writes them afresh
        rest_shape.write_positions(face.data, state.out)
        state.last, state.mode = points, mode
        _show_control(settings.control_object, state)
    except (LookupError, Mpeg4Error) as exc:
        disable(face, f"Deformation turned off: {exc}")
        return False
    if settings.status:
        settings.status = ""
    return True


def _keep_lips_apart(state: _State, driving: np.ndarray, off_rest: np.ndarray | None) -> bool:
    """The lip guard on `state.out` (the lips press on each other, never pass) where the lips' points moved;
    whether it moved any skin. Also where the seam does not part the lips (`lips.press_apart`), before Unfold Skin and
    in its rounds after the membrane. In numpy (session 11) the two took turns in those rounds by ever
    smaller amounts (90 to 9 um) to the last round, the subdivided variant's frames 6x its median, so the contact ran
    once a frame; compiled (ABI 14) and in the rounds again (session 15), no frame of the three shared heads, the
    subdivided variant or the sample's variants played is over 2.0x its moving median in CPU time, and the scan's slit
    no longer crosses where the membrane opened the triangles bridging its walls (demo 11 pairs in a frame -> 3)."""
    lips = state.lip_points
    if state.lip_guard is None or np.array_equal(driving[lips], state.binding.control_rest[lips]):
        return False
    moved = fused.guard_lips_into(state.lip_arrays, state.out, driving) if _NATIVE_GUARD else None
    if moved is None:
        moved = guard_lips(state.lip_guard, state.out, driving)
    moved = press_apart(state.lip_guard, state.out) or moved
    if moved and state.playback is not None:
        state.playback.changed(state.lip_skin_groups)  # the next frame writes them afresh
        if off_rest is not None:
            off_rest[state.lip_skin_groups] = 1
    return bool(moved)


def _apply_elastic(face, force: bool) -> bool:
    """Pose the skeleton; with Unfold Skin on, open the skinning's folds under the Armature modifier (paused in
    Edit Mode, where the edit mesh shows the rest shape)."""
    try:
        editing = face.mode == "EDIT"
        if editing:
            _editing.add(face.session_uid)
            elastic_skin.leave_for_edit_mode(face)
        elif face.session_uid in _editing:  # back from Edit Mode: this frame's folds again
            _editing.discard(face.session_uid)
            force = True
        posed = elastic_rig.apply_pose(face, force)
        if not face.mpeg4_face.unfold_skin:
            elastic_skin.restore(face)
        elif posed is not None and not editing:
            elastic_skin.apply(face, posed.groups, posed.transforms)
    except (LookupError, Mpeg4Error) as exc:
        disable(face, f"Deformation turned off: {exc}")
        return False
    if face.mpeg4_face.status:
        face.mpeg4_face.status = ""
    return True


def _show_control(control, state: _State) -> None:
    """The control mesh follows the empties while it is visible; hidden (as set-up leaves it), it costs nothing
    per frame (its re-evaluation was a tenth of a played frame) and catches up when next shown and applied."""
    if control.visible_get() and state.control_shown is not state.last:
        _write_control(control, state.last)
        state.control_shown = state.last


def _write_control(control, points: np.ndarray) -> None:
    mesh = control.data
    if len(mesh.vertices) == len(points):
        mesh.attributes["position"].data.foreach_set("vector", points.astype(np.float32).ravel())
        mesh.update()


def _restore_control(face) -> None:
    control = face.mpeg4_face.control_object
    if _linked(control) and face_data.REST_PROP in control.data:
        _write_control(control, np.asarray(control.data[face_data.REST_PROP]).reshape(-1, 3))


def pause(face) -> None:
    """Show the rest shape without touching the Deform setting (set-up does this before measuring)."""
    forget(face)
    rest_shape.restore_rest(face.data)
    _restore_control(face)
    elastic_rig.rest_pose(face)


def disable(face, message: str, keep_mesh: bool = False) -> None:
    """Turn the effect off with a message; the mesh goes back to rest unless `keep_mesh` (a user's edit)."""
    log.warning("%s: %s", face.name, message)
    forget(face)
    settings = face.mpeg4_face
    settings.status = message
    if keep_mesh:
        settings["enabled"] = False  # the ID property, so the update does not write the old rest over the edit
        if face.data.shape_keys is not None:
            rest_shape.restore_rest(face.data)  # only our own key: it must not keep showing the pose
    elif settings.enabled:
        settings.enabled = False  # its update restores the rest mesh


def settings_changed(face, rebind: bool) -> None:
    """Property update: rebind (in the background) if a binding parameter changed, then apply or restore."""
    if rebind and binding_store.is_bound(face):
        mode = MODES[face.mpeg4_face.mode]  # the kernel's layout is made on the worker thread too
        binding_store.request_rebind(face, done=refresh, prepare=lambda binding: prepare_playback(binding, mode, OUT))
        return
    refresh(face)


def refresh(face) -> None:
    """Show the face with its current settings and binding: deformed when enabled, else at rest."""
    if face.mpeg4_face.enabled:
        apply_face(face, force=True)
    else:
        pause(face)


@dataclass
class _Objects:
    """A scene's objects as last seen: their session ids, and the meshes among them."""

    uids: bytes
    present: frozenset
    meshes: list


_scenes: dict[int, _Objects] = {}  # by the scene's session_uid


def _objects(scene) -> _Objects:
    """The scene's objects, looked through again only when they changed: one `foreach_get` a frame instead of
    a Python loop over every object (84 FP empties and the rest), and a set to find the control mesh in. (The
    scene collection's `all_objects` are the scene's objects, from a cache: half the cost of `scene.objects`.)"""
    objects = scene.collection.all_objects
    uids = np.empty(len(objects), dtype=np.int64)
    objects.foreach_get("session_uid", uids)
    seen = _scenes.get(scene.session_uid)
    if seen is None or seen.uids != uids.tobytes():
        seen = _Objects(uids.tobytes(), frozenset(uids.tolist()), [ob for ob in objects if ob.type == "MESH"])
        _scenes[scene.session_uid] = seen
    return seen


def apply_scene(scene) -> None:
    global _busy
    if _busy:
        return
    _busy = True
    try:
        seen = _objects(scene)
        for ob in seen.meshes:
            if ob.mpeg4_face.enabled:
                try:
                    apply_face(ob, present=seen.present)
                except Exception as exc:  # a bug must not repeat on every frame: log it once, stop the face
                    log.exception("live deformation of %s failed", ob.name)
                    disable(ob, f"Deformation turned off after an internal error: {exc}")
    finally:
        _busy = False


def _mirror_edit(scene, depsgraph) -> None:
    """X-Mirror: the partner of an FP empty the user is moving follows it across the face's mid-plane."""
    active = bpy.context.view_layer.objects.active if bpy.context.view_layer else None
    if active is None or active.type != "EMPTY" or active.animation_data is not None:
        return
    face = active.parent
    if face is None or face.type != "MESH" or not face.mpeg4_face.use_x_mirror:
        return
    if getattr(bpy.context.screen, "is_animation_playing", False):
        return
    if any(u.is_updated_transform and u.id.original == active for u in depsgraph.updates):
        fp_empties.mirror_move(face, active)


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    apply_scene(scene)


def _needs_edit_check(face) -> bool:
    """Cheap test for what a geometry update can mean: Edit Mode, a new shape key, a changed vertex count."""
    if face.mode == "EDIT" or face.session_uid in _editing:
        return True
    state = _states.get(face.session_uid)
    mesh = face.data
    return state is not None and (
        (mesh.shape_keys is not None) != state.on_shape_key or len(mesh.vertices) != state.binding.n_vertices
    )


@bpy.app.handlers.persistent
def on_depsgraph_update(scene, depsgraph):
    if _busy:
        return
    updates = depsgraph.updates
    if any(u.is_updated_transform for u in updates):  # an empty (or the face) moved
        _mirror_edit(scene, depsgraph)
        apply_scene(scene)
    elif any(u.is_updated_geometry for u in updates):  # our own writes, or an edit to guard against
        faces = [ob for ob in scene.objects if ob.type == "MESH" and ob.mpeg4_face.enabled]
        if any(_needs_edit_check(face) for face in faces):
            apply_scene(scene)


@bpy.app.handlers.persistent
def on_load_post(*_args):
    forget()
    skin_view.forget()
    eyelid_rig.forget()  # another file: nothing of the last one's rigs is wanted again
    keep_paper_cover()


def keep_paper_cover() -> None:
    """A face bound before Still Skin Around Eyes existed was bound with the paper's cover: show the setting off, as
    its binding is, rather than on (its default), so that it plays as saved and a later rebind does not change its
    upper face unasked. Set-up stores the setting, so an unset one means an older file. The raw ID property is
    written: no update callback, no rebind."""
    for ob in bpy.data.objects:
        settings = getattr(ob, "mpeg4_face", None)
        if ob.type == "MESH" and settings is not None and binding_store.is_bound(ob):
            if not settings.is_property_set("still_upper_face"):
                settings["still_upper_face"] = False


@bpy.app.handlers.persistent
def on_undo_redo(*_args):
    # undo brings back older mesh data and empties: cached poses and bindings may no longer match them
    forget()
