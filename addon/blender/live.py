"""The live, modifier-like effect: each enabled face follows its FP empties on every frame and edit.

Handlers (registered in registration.py) call `apply_scene`. Per face the loaded binding is cached by
the face's session_uid and the stored binding key, so a frame costs: read the control empties, one
`evaluate`, one float32 write. Nothing is written when the control positions did not change, which
also keeps the depsgraph handler from feeding itself. Problems (a deleted empty or control mesh, a
mesh whose vertex count changed) turn the effect off and leave a message in the face's `status`,
which the panel shows; a handler never raises.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import bpy
import numpy as np

from ..deform.planar_bones import Binding, evaluate
from . import face_data

log = logging.getLogger(__name__)

MODES = {"PLANAR_BONES": "planar_bones", "SOFFD": "soffd"}
# Empties at rest read back through their world matrices differ from the stored rest by float32
# rounding (~1e-8 m); within this the face is written as its exact rest shape.
REST_TOLERANCE = 1e-7


@dataclass
class _State:
    key: str
    binding: Binding
    control_ids: list[str]
    out: np.ndarray
    names: list[str] | None = None  # object names of the control empties, looked up by name each frame
    last: np.ndarray | None = None
    mode: str = ""


_states: dict[int, _State] = {}
_busy = False


def forget(face: bpy.types.Object | None = None) -> None:
    """Drop cached state (all faces, or one)."""
    if face is None:
        _states.clear()
    else:
        _states.pop(face.session_uid, None)


def _linked(ob) -> bool:
    return ob is not None and bool(ob.users_collection)


def _state(face) -> _State:
    mesh = face.data
    key = mesh.get(face_data.BINDING_KEY_PROP)
    state = _states.get(face.session_uid)
    if state is not None and state.key == key and state.binding.n_vertices == len(mesh.vertices):
        return state
    loaded = face_data.load_binding(mesh)
    if loaded is None:
        raise LookupError("the face is not bound: run Set Up Face")
    binding, key = loaded
    if binding.n_vertices != len(mesh.vertices):
        raise LookupError(
            f"the mesh has {len(mesh.vertices)} vertices but was bound with {binding.n_vertices}: run Set Up again"
        )
    control = face.mpeg4_face.control_object
    ids = list(control.data.get(face_data.FP_IDS_PROP, ()))
    state = _State(key, binding, ids, np.empty((binding.n_vertices, 3), dtype=np.float32))
    _states[face.session_uid] = state
    return state


def control_empties(face, state: _State) -> dict:
    """The control FPs' empties in the control mesh's vertex order (by cached name, rescanned if stale)."""
    objects = bpy.data.objects
    if state.names is not None:
        found = [objects.get(name) for name in state.names]
        if all(
            ob is not None and ob.get(face_data.FP_PROP) == fp_id
            for ob, fp_id in zip(found, state.control_ids, strict=True)
        ):
            return dict(zip(state.control_ids, found, strict=True))
    empties = face_data.fp_empties(face)
    missing = [fp_id for fp_id in state.control_ids if fp_id not in empties]
    if missing:
        state.names = None
        raise LookupError(f"feature point empties missing: {', '.join(missing)}")
    state.names = [empties[fp_id].name for fp_id in state.control_ids]
    return {fp_id: empties[fp_id] for fp_id in state.control_ids}


def control_positions(face, state: _State) -> np.ndarray:
    """(M, 3) face-local positions of the control FPs, in the control mesh's vertex order."""
    return np.array(list(face_data.local_positions(face, control_empties(face, state)).values()))


def apply_face(face, force: bool = False) -> bool:
    """Deform `face` from its empties; returns False (and disables the effect) on a problem."""
    settings = face.mpeg4_face
    try:
        if not _linked(settings.control_object):
            raise LookupError("the control mesh was deleted")
        state = _state(face)
        points = control_positions(face, state)
        mode = MODES[settings.mode]
        if not force and state.mode == mode and state.last is not None and np.array_equal(points, state.last):
            return True
        if np.allclose(points, state.binding.control_rest, rtol=0.0, atol=REST_TOLERANCE):
            state.out[...] = state.binding.rest_vertices  # the neutral face exactly, not up to rounding
        else:
            evaluate(state.binding, points, mode=mode, out=state.out)
        face_data.write_positions(face.data, state.out)
        _write_control(settings.control_object, points)
        state.last, state.mode = points, mode
    except (LookupError, ValueError) as exc:
        disable(face, f"Deformation turned off: {exc}")
        return False
    if settings.status:
        settings.status = ""
    return True


def _write_control(control, points: np.ndarray) -> None:
    mesh = control.data
    if len(mesh.vertices) == len(points):
        mesh.attributes["position"].data.foreach_set("vector", points.astype(np.float32).ravel())
        mesh.update()


def disable(face, message: str) -> None:
    log.warning("%s: %s", face.name, message)
    forget(face)
    settings = face.mpeg4_face
    settings.status = message
    if settings.enabled:
        settings.enabled = False  # its update restores the rest mesh


def settings_changed(face, rebind: bool) -> None:
    """Property update: rebind if a binding parameter changed, then apply or restore."""
    if rebind and face.data.get(face_data.BINDING_PROP) is not None:
        from . import setup

        try:
            setup.rebind(face)
        except (LookupError, ValueError) as exc:
            disable(face, f"Rebinding failed: {exc}")
            return
    if face.mpeg4_face.enabled:
        apply_face(face, force=True)
    else:
        forget(face)
        face_data.restore_rest(face.data)
        control = face.mpeg4_face.control_object
        if _linked(control) and face_data.REST_PROP in control.data:
            _write_control(control, np.asarray(control.data[face_data.REST_PROP]).reshape(-1, 3))


def apply_scene(scene) -> None:
    global _busy
    if _busy:
        return
    _busy = True
    try:
        for ob in scene.objects:
            if ob.type == "MESH" and ob.mpeg4_face.enabled:
                try:
                    apply_face(ob)
                except Exception as exc:  # a bug must not repeat on every frame: log it once, stop the face
                    log.exception("live deformation of %s failed", ob.name)
                    disable(ob, f"Deformation turned off after an internal error: {exc}")
    finally:
        _busy = False


@bpy.app.handlers.persistent
def on_frame_change(scene, depsgraph=None):
    apply_scene(scene)


@bpy.app.handlers.persistent
def on_depsgraph_update(scene, depsgraph):
    # only transforms of objects can move an empty; skip pure data/selection updates cheaply
    if any(update.is_updated_transform for update in depsgraph.updates):
        apply_scene(scene)


@bpy.app.handlers.persistent
def on_load_post(*_args):
    forget()
