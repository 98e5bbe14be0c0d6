"""The one store of a face's binding: computed here, saved with the .blend, cached in memory.

The deformer's arrays are saved as ID-property arrays (reading them back is a buffer copy) with a digest
of everything they depend on, so an opened file reuses its binding unless the rest data changed. They
live off the face's mesh, on a hidden Text data-block of their own (`face.mpeg4_face.binding_holder`,
named '.MPEG-4 binding <face>'): the depsgraph copies a mesh with all its ID properties whenever its
positions are written, which is every frame, and never evaluates a Text. Loaded bindings are cached per
face and key. Stored data is checked before use: a crafted file cannot request an allocation by a dtype
or a shape that does not match the array it came with.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import bpy
import numpy as np

from ..deform.face_binding import FADE_BELOW, FOLLOW_SMOOTHING_PER_ES0, bind_face
from ..deform.masks import image_masks, vertex_uvs
from ..deform.planar_bones import LOCAL_FIELDS, Binding
from ..errors import Mpeg4Error
from ..mpeg4.control_mesh import MASK_NAMES, mouth_rows, triangle_parts
from . import face_data, inner_parts, rest_shape
from .face_data import CREATED_PROP
from .reporting import report_outside_operator

log = logging.getLogger(__name__)

BINDING_PROP = "mpeg4_binding"
BINDING_KEY_PROP = "mpeg4_binding_key"
# the dtypes a binding is made of; anything else in a file is refused
LEGACY_MESH_PROPS = (BINDING_PROP, BINDING_KEY_PROP)
STORED_DTYPES = frozenset({"<f8", "<f4", "<i8", "<i4", "<i2", "|i1", "|b1"})
MAX_NDIM = 3

_cache: dict[int, tuple[str, Binding]] = {}
_mask_cache: dict[int, tuple[tuple, dict[str, np.ndarray]]] = {}


def same_inputs(kept: tuple, inputs: tuple) -> bool:
    """True when each array of `kept` equals its counterpart in `inputs` (shape and values): what was made from
    them at the last binding (the lip guard, the lids' weights, Unfold Skin's view) can be taken again."""
    return all(np.array_equal(a, b) for a, b in zip(kept, inputs, strict=True))


def forget(face: bpy.types.Object | None = None) -> None:
    """Drop cached bindings (all, or one face's)."""
    if face is None:
        _cache.clear()
        _mask_cache.clear()
    else:
        _cache.pop(face.session_uid, None)


def holder(face: bpy.types.Object):
    """The data-block holding the face's binding, or None."""
    return face.mpeg4_face.binding_holder if face.type == "MESH" else None


def stored_key(face: bpy.types.Object) -> str | None:
    held = holder(face)
    key = held.get(BINDING_KEY_PROP) if held is not None else None
    return key if isinstance(key, str) else None


def is_bound(face: bpy.types.Object) -> bool:
    return stored_key(face) is not None


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


def save(face: bpy.types.Object, binding: Binding, key: str) -> None:
    group = {}
    for field in dataclasses.fields(binding):
        if not field.init:
            continue
        value = getattr(binding, field.name)
        if isinstance(value, np.ndarray):
            # ID property arrays hold int32, float32 and float64; the ".dtype" says what to load them as
            stored = value.astype(np.int32) if value.dtype.kind in "iub" else value
            if field.name in LOCAL_FIELDS:
                stored = value.astype(np.float32)  # exact: bound with local_float32
            group[field.name] = np.ascontiguousarray(stored).ravel()
            group[field.name + ".shape"] = list(value.shape) or [0]
            group[field.name + ".dtype"] = value.dtype.str
        else:
            group[field.name] = value
    clear(face)  # replaced whole, never resized in place (nor shared with a duplicated face)
    held = bpy.data.texts.new(f".MPEG-4 binding {face.name}")
    held.use_fake_user = False  # the face's pointer keeps it; texts are made with a fake user
    held[CREATED_PROP] = True
    held[BINDING_PROP] = group
    held[BINDING_KEY_PROP] = key
    face.mpeg4_face.binding_holder = held
    _cache[face.session_uid] = (key, binding)


def stored_bytes(face: bpy.types.Object) -> int:
    """How many bytes the face's saved binding arrays take in the .blend."""
    held = holder(face)
    group = held.get(BINDING_PROP) if held is not None else None
    if group is None:
        return 0
    sizes = {"f": 4, "d": 8, "i": 4, "b": 1}
    return sum(len(v) * sizes.get(v.typecode, 8) for v in group.values() if hasattr(v, "typecode"))


def _stored_array(group, name: str) -> np.ndarray | None:
    """The array `name` of a stored group, or None when its dtype or shape is not one a binding has."""
    dtype, shape, data = group.get(name + ".dtype"), group.get(name + ".shape"), group.get(name)
    if not isinstance(dtype, str) or dtype not in STORED_DTYPES or not hasattr(data, "to_list"):
        return None
    if not hasattr(shape, "to_list") or not 1 <= len(shape) <= MAX_NDIM:
        return None
    shape = tuple(int(n) for n in shape)
    if any(n < 0 for n in shape):
        return None
    size = int(np.prod(shape, dtype=np.int64))
    if shape == (0,) or size == len(data):
        return np.array(data, dtype=np.dtype(dtype)).reshape(shape if size == len(data) else (0,))
    return None


def load(face: bpy.types.Object) -> Binding | None:
    """The face's binding (cached), or None when there is none or the stored one is unusable."""
    key = stored_key(face)
    if key is None:
        return None
    cached = _cache.get(face.session_uid)
    if cached is not None and cached[0] == key:
        return cached[1]
    group = holder(face).get(BINDING_PROP)
    if group is None or not hasattr(group, "keys"):
        return None
    values = {}
    for field in dataclasses.fields(Binding):
        if not field.init:
            continue
        if field.name + ".dtype" in group:
            values[field.name] = _stored_array(group, field.name)
            if values[field.name] is None:
                return None
        elif isinstance(group.get(field.name), int):
            values[field.name] = group[field.name]
        else:
            return None
    try:
        binding = Binding(**values)
    except (ValueError, IndexError, TypeError):
        return None
    _cache[face.session_uid] = (key, binding)
    return binding


def clear(face: bpy.types.Object) -> None:
    for prop in LEGACY_MESH_PROPS:  # where versions before 0.2 kept the binding
        if prop in face.data:
            del face.data[prop]
    held = holder(face)
    if held is not None:
        face.mpeg4_face.binding_holder = None
        if held.users == int(held.use_fake_user) and CREATED_PROP in held:
            bpy.data.texts.remove(held)
    forget(face)


# ----------------------------------------------------------------------------- computing a binding


def missing_masks(face) -> list[str]:
    """The mask names neither the face's mask image nor a vertex group with a weight provides (an empty group,
    as a Remesh modifier or a re-import leaves it, is no mask)."""
    if face.mpeg4_face.mask_image is not None:
        return []
    held = vertex_masks(face)
    return [name for name in MASK_NAMES if name not in held]


def vertex_masks(face) -> dict[str, np.ndarray]:
    """Per-vertex mask weights by mask name.

    From the face's mask image when it has one (one channel per mask, sampled at the UVs, paper 000
    Figure 9), else from the vertex groups named like the masks that hold a weight.
    """
    image = face.mpeg4_face.mask_image
    if image is not None:
        return _image_masks(face, image)
    return {name: w for name, w in face_data.group_weights(face, MASK_NAMES).items() if w.any()}


def _image_masks(face, image) -> dict[str, np.ndarray]:
    mesh = face.data
    if mesh.uv_layers.active is None:
        raise Mpeg4Error(
            f"{face.name} has no UV map to sample the mask image {image.name!r} with: add one or clear the mask image"
        )
    width, height = image.size
    if width == 0 or height == 0:
        raise Mpeg4Error(f"the mask image {image.name!r} has no pixels (is its file missing?)")
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    loop_vertex = face_data.mesh_corners(mesh)[1]
    loop_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    mesh.uv_layers.active.data.foreach_get("uv", loop_uv)
    uv = vertex_uvs(loop_vertex, loop_uv, len(mesh.vertices))
    return image_masks(pixels.reshape(height, width, image.channels), uv, MASK_NAMES)


@dataclass
class BindInputs:
    """Everything a binding depends on, read from the scene on the main thread; binding it needs no bpy."""

    rest: np.ndarray
    control_rest: np.ndarray
    triangles: np.ndarray
    triangle_masks: list
    masks: dict[str, np.ndarray]
    params: dict
    key: str
    rigid: np.ndarray  # the vertices of the rigid parts inside the face (eyeballs, teeth, tongue): bound to nothing
    edges: np.ndarray | None = None  # the mesh's edges, for Still Skin Around Eyes' smoothing

    def bind(self) -> Binding:
        """The binding as it will be saved: its local coordinates rounded to float32 (about 1e-7 of a control
        triangle's size, 1e-9 m on a face; weights, rest shape and control mesh stay float64, so the rest frame
        and the eq. 8 weight sums stay exact). The session plays the rounded values too, so a saved and
        reopened file plays bit for bit the same.

        Only the skin is bound: the rigid parts move as wholes (`inner_parts`), and binding them too made the
        coverage raise the mouth's control triangles to reach the tongue and teeth deep in the mouth, which moved
        the lips and chin of a face with its parts joined in 10-20 mm away from the same face with separate parts
        (and pushed the skin inside the mouth through itself)."""
        rest = self.rest.astype(np.float64)
        skin = np.setdiff1d(np.arange(len(rest)), self.rigid)
        masks = {name: weights[skin] for name, weights in self.masks.items()}
        edges = None
        if self.edges is not None:  # the skin's own edges, numbered as the skin's vertices
            renumber = np.full(len(rest), -1, dtype=np.int64)
            renumber[skin] = np.arange(len(skin))
            edges = renumber[self.edges]
            edges = edges[(edges >= 0).all(axis=1)]
        binding = bind_face(
            rest[skin],
            self.control_rest,
            self.triangles,
            vertex_masks=masks or None,
            triangle_masks=self.triangle_masks if masks else None,
            edges=edges,
            local_float32=True,
            **self.params,
        )
        if len(skin) == len(rest):
            return binding
        return dataclasses.replace(binding, rest_vertices=rest, pair_vertex=skin[binding.pair_vertex].astype(np.int32))


def _masks(face, fresh: bool, made: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """The face's mask weights; a setting change reuses the ones read at set-up (reading the vertex groups
    takes a throw-away scene evaluation, 60 ms at 68k vertices). `made`: masks set-up is about to write as
    vertex groups, taken as if they were there already."""
    if not face.mpeg4_face.use_masks:
        return {}
    return set_up_masks(face, fresh, made)


def set_up_masks(face, fresh: bool = False, made: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """`vertex_masks` as set-up last read them (read again when `fresh`, or when the mask image or the vertex
    count changed): what the binding was made from, which the eyelids and the lip guard are rigged from too."""
    settings = face.mpeg4_face
    source = (settings.mask_image.name if settings.mask_image else "", len(face.data.vertices))
    cached = _mask_cache.get(face.session_uid)
    if not fresh and cached is not None and cached[0] == source:
        return cached[1]
    masks = {**vertex_masks(face), **(made or {})}
    _mask_cache[face.session_uid] = (source, masks)
    return masks


def gather(
    face,
    rest: np.ndarray,
    control_rest: np.ndarray,
    triangles: np.ndarray,
    triangle_masks,
    es0: float,
    fp_ids,
    fresh=True,
    made_masks: dict[str, np.ndarray] | None = None,
    made_parts: dict[str, np.ndarray] | None = None,
    mesh_edges: np.ndarray | None = None,
) -> BindInputs:
    """The inputs of a binding with the face's current parameters; changes nothing in the scene. `fp_ids`: the
    control mesh's FP ids, in its vertex order; `made_parts`: part groups set-up is about to write (taken as the
    face's rigid parts instead of its part groups); `mesh_edges`: the face's edges when the caller has read them."""
    settings = face.mpeg4_face
    masks = _masks(face, fresh, made_masks)
    tri_masks = [m if m in masks else None for m in triangle_masks]
    params = {"radius_fraction": settings.radius_fraction, "falloff_exponent": settings.falloff_exponent, "es0": es0}
    # Python floats in the key's text: NumPy 2 writes a numpy scalar as np.float64(...), which would make a binding
    # saved under NumPy 1 (Blender 5.0 and older) look stale under NumPy 2
    params = {name: float(value) for name, value in params.items()}
    edges = None
    if settings.still_upper_face:
        params["triangle_parts"] = tuple(triangle_parts(fp_ids, triangles).tolist())
        params["mouth_rows"] = mouth_rows(fp_ids)
        edges = face_data.mesh_edges(face.data) if mesh_edges is None else mesh_edges
    members = made_parts or inner_parts.group_members(face)
    rigid = np.unique(np.concatenate([*members.values(), np.zeros(0, np.intp)])).astype(np.intp)
    keyed = {**params, "fade_below": FADE_BELOW}
    if len(rigid):  # a face without parts keeps the key it was saved with
        keyed["rigid"] = hashlib.blake2b(rigid.astype(np.int64).tobytes(), digest_size=16).hexdigest()
    if edges is not None:  # the smoothing's width and the mesh's edges it runs along
        keyed |= {
            "follow_smoothing": FOLLOW_SMOOTHING_PER_ES0,
            "edges": hashlib.blake2b(edges.tobytes(), digest_size=16).hexdigest(),
        }
    key = binding_key(rest, control_rest, triangles, keyed, masks)
    return BindInputs(rest, control_rest, triangles, tri_masks, masks, params, key, rigid, edges)


def control_data(face) -> tuple[np.ndarray, np.ndarray, list[str | None]]:
    """The stored control mesh: rest points (M, 3), triangles (T, 3) and per-triangle masks."""
    control = face.mpeg4_face.control_object
    if control is None or control.type != "MESH" or face_data.REST_PROP not in control.data:
        raise Mpeg4Error(f"{face.name} has no control mesh: run Set Up Face")
    mesh = control.data
    points = np.asarray(mesh[face_data.REST_PROP], dtype=np.float64)
    if points.size != 3 * len(mesh.vertices):
        raise Mpeg4Error(f"the control mesh {control.name!r} was edited: run Set Up Face")
    tris = np.array([list(p.vertices) for p in mesh.polygons if len(p.vertices) == 3], dtype=np.int64)
    masks = list(mesh.get(face_data.TRIANGLE_MASKS_PROP, [""] * len(tris)))
    if len(tris) != len(mesh.polygons) or len(masks) != len(tris):
        raise Mpeg4Error(f"the control mesh {control.name!r} was edited: run Set Up Face")
    return points.reshape(-1, 3), tris.reshape(-1, 3), [m or None for m in masks]


def stored_inputs(face) -> BindInputs:
    """The inputs of a new binding of the set-up face (after a setting changed)."""
    mesh = face.data
    rest = rest_shape.reference_positions(mesh)
    if rest is None or len(rest) != len(mesh.vertices):
        raise Mpeg4Error(f"{face.name}'s mesh changed since set-up: run Set Up Face again")
    points, tris, tri_masks = control_data(face)
    fp_ids = list(face.mpeg4_face.control_object.data.get(face_data.FP_IDS_PROP, ()))
    if len(fp_ids) != len(points):
        raise Mpeg4Error(f"the control mesh {face.mpeg4_face.control_object.name!r} was edited: run Set Up Face")
    return gather(face, rest, points, tris, tri_masks, face.mpeg4_face.fapu[1], fp_ids, fresh=False)


def rebind(face) -> None:
    """Bind again with the face's current parameters, now, if anything changed."""
    inputs = stored_inputs(face)
    if inputs.key != stored_key(face):
        save(face, inputs.bind(), inputs.key)


# ----------------------------------------------------------------------------- rebinding in the background

REBIND_DELAY = 0.25  # s after the last change of a setting (a slider drag sends many)
POLL = 0.05
BACKGROUND_REBIND: bool | None = None  # None: when Blender has a user interface (tests set it)


@dataclass
class _Job:
    face_name: str
    inputs: BindInputs
    done: Callable
    start_at: float
    prepare: Callable | None = None  # called with the new binding on the worker thread (to build what it can)
    thread: threading.Thread | None = None
    result: Binding | None = None
    error: BaseException | None = None


_jobs: dict[int, _Job] = {}


def request_rebind(face, done: Callable, prepare: Callable | None = None) -> None:
    """Rebind after a setting changed without blocking the interface: the old binding keeps playing, the
    new one is computed on a worker thread (the binder is numpy and needs no bpy), `prepare(binding)` runs
    there too, and it is stored, then `done(face)` runs, on the main thread. Without a user interface
    (background mode) it binds at once."""
    inputs = stored_inputs(face)
    if inputs.key == stored_key(face):
        _jobs.pop(face.session_uid, None)
        done(face)
        return
    if not (BACKGROUND_REBIND if BACKGROUND_REBIND is not None else not bpy.app.background):
        save(face, inputs.bind(), inputs.key)
        done(face)
        return
    _jobs[face.session_uid] = _Job(face.name, inputs, done, time.monotonic() + REBIND_DELAY, prepare)
    if not bpy.app.timers.is_registered(poll_jobs):
        bpy.app.timers.register(poll_jobs, first_interval=POLL)


def _work(job: _Job) -> None:
    try:
        job.result = job.inputs.bind()
    except BaseException as exc:  # handed to the main thread, which reports it
        job.error = exc
        return
    if job.prepare is not None:
        try:
            job.prepare(job.result)
        except Exception:  # only a head start: the first frame builds it again, and reports what goes wrong
            log.debug("preparing the new binding failed", exc_info=True)


def poll_jobs() -> float | None:
    """Timer: start due jobs, store finished ones; returns the next interval, None when nothing is left."""
    now = time.monotonic()
    for uid, job in list(_jobs.items()):
        if job.thread is None:
            if now >= job.start_at:
                job.thread = threading.Thread(target=_work, args=(job,), daemon=True)
                job.thread.start()
            continue
        if job.thread.is_alive():
            continue
        del _jobs[uid]
        face = bpy.data.objects.get(job.face_name)
        if face is None or face.session_uid != uid or face.type != "MESH":
            continue
        try:
            if job.error is not None:
                raise job.error
            if job.inputs.key == stored_inputs(face).key:  # nothing changed meanwhile
                save(face, job.result, job.inputs.key)
                job.done(face)
        except Exception as exc:
            report_outside_operator(face, exc)
    return POLL if _jobs else None


def busy(face) -> bool:
    """A rebind of this face is waiting or running."""
    return face.session_uid in _jobs
