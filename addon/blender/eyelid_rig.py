"""The eyelids' turn over the eyeballs (deform/eyelids.py) on a set-up face, after Planar Bones.

The rig is made once per binding from the rest face: the lids are where the eyelid masks say (the upper
lid is where the lower-lid triangles may not reach, 1 - `lower_eyelid`, and the other way round), the
eyes turn about their fitted centres (the part fields), or a default eyeball radius behind each pupil.
Each frame the deformer gets the mid-lid FPs at rest (`hold`), then `apply` turns the lids in the deformed
positions by the lid and pupil FPs (3.1-3.6), which live.py reads with the control FPs in one pass.
"""

from __future__ import annotations

import functools

import numpy as np

from ..deform.auto_masks import make_masks
from ..deform.eyelids import EYE_FPS, EyelidRig, apply_eyelids, bind_eyelids, hold_lids
from ..deform.planar_bones import Binding
from ..mpeg4.decode import eye_centres
from ..mpeg4.fapu import Fapu
from ..mpeg4.feature_points import fp_index
from . import binding_store, face_data, followers, inner_parts

WATCHED = [fp_id for eye in EYE_FPS for fp_id in (eye[0], eye[1], eye[4])]  # the FPs whose motion the lids show
_WATCHED_ROWS = [fp_index(fp_id) for fp_id in WATCHED]
_rigs: dict[int, tuple[Binding, EyelidRig | None]] = {}
_last: dict[int, np.ndarray] = {}
_at_rest: dict[int, np.ndarray] = {}  # the watched FPs' rest positions the rig was made from, by face
_made: dict[int, tuple] = {}  # (the inputs, the rig) by face: a rebind that changes none of them keeps the rig


def forget(face=None, keep_made: bool = False) -> None:
    """Drop the rigs (all faces, or one). `keep_made`: keep the last rig made for each face, which is taken again
    only for equal inputs (an undo, a setting's rebind, Deform switched off and on: 0.23 s at 68k vertices)."""
    faces = list(_rigs.keys() | _last.keys() | _at_rest.keys() | _made.keys()) if face is None else [face.session_uid]
    for uid in faces:
        _rigs.pop(uid, None)
        _last.pop(uid, None)
        _at_rest.pop(uid, None)
        if not keep_made:
            _made.pop(uid, None)


def _make_rig(face, binding: Binding) -> EyelidRig | None:
    masks = binding_store.set_up_masks(face)
    if "upper_eyelid" not in masks or "lower_eyelid" not in masks:
        return None
    empties = face_data.fp_empties(face)
    neutral = face_data.neutral_positions(empties)
    _at_rest[face.session_uid] = neutral[_WATCHED_ROWS]
    settings = face.mpeg4_face
    axes = face_data.face_axes(face)
    centres = eye_centres(neutral @ axes.T, Fapu(*settings.fapu), None, axes) @ axes
    parts = inner_parts.rigid_parts(face, binding.rest_vertices)
    inside = {} if parts is None else parts.centres
    for k, (eye, role) in enumerate(((settings.left_eye, "left_eye"), (settings.right_eye, "right_eye"))):
        if eye is not None:
            centres[k] = followers.eye_centre(face, eye)
        elif role in inside:
            centres[k] = inside[role]
    pupils = neutral[[fp_index(eye[4]) for eye in EYE_FPS]]
    radii = np.linalg.norm(pupils - centres, axis=1)
    if not np.all(np.isfinite(radii) & (radii > 0)):
        return None
    upper, lower = 1.0 - masks["lower_eyelid"], 1.0 - masks["upper_eyelid"]
    if parts is not None:  # an eyeball inside the face object is no lid (its masks are 0 there: "the other lid")
        upper[parts.all_vertices] = lower[parts.all_vertices] = 0.0
    triangles = face_data.mesh_fans(face.data)[0]  # the weights are made so that no face turns over
    if parts is not None:  # an eyeball inside the face object is no skin: the lids see their opening past it
        triangles = triangles[~np.isin(triangles, parts.all_vertices).any(axis=1)]
    # lid masks set-up made from the FPs say no more of the margins than the FPs: the lids' opening from their FPs
    trace = not {"upper_eyelid", "lower_eyelid"} & set(settings.made_masks.split(","))
    inputs = (binding.rest_vertices, upper, lower, neutral, centres, radii, axes, triangles, trace)
    made = _made.get(face.session_uid)
    if made is not None and binding_store.same_inputs(made[0], inputs):
        return made[1]  # a setting's rebind: the lids' fold-free weights (0.2 s at 68k vertices) are as they were
    rig = bind_eyelids(
        *inputs[:7],
        triangles=triangles,
        trace_opening=trace,
        made_lids=functools.partial(_made_lids, face, binding) if trace else None,
    )
    _made[face.session_uid] = inputs, rig
    return rig


def _made_lids(face, binding: Binding) -> tuple[np.ndarray, np.ndarray] | None:
    """The upper and lower lids' memberships set-up would make from the FPs, for painted lid masks whose lid is
    their margin row alone (`eyelids.one_row_deep`); None without the FPs to make them."""
    made = make_masks(
        binding.rest_vertices, face_data.mesh_edges(face.data), face_data.neutral_positions(face_data.fp_empties(face))
    )
    if "upper_eyelid" not in made:
        return None
    upper, lower = 1.0 - made["lower_eyelid"], 1.0 - made["upper_eyelid"]
    parts = inner_parts.rigid_parts(face, binding.rest_vertices)
    if parts is not None:
        upper[parts.all_vertices] = lower[parts.all_vertices] = 0.0
    return upper, lower


def notes(face) -> list[str]:
    """What set-up tells of the lids' rig just made for `face`: the lid masks that were their margin row alone."""
    rig = current(face)
    if rig is None or not rig.deepened:
        return []
    names = ", ".join(f"{('left', 'right')[e]} {('upper', 'lower')[k]}" for e, k in rig.deepened)
    return [
        f"lid masks one row of vertices deep ({names}): those lids also turn the skin that masks made from the"
        " feature points reach (the vertex groups are unchanged; paint the lids deeper to decide it yourself)"
    ]


def _rig(face, binding: Binding) -> EyelidRig | None:
    cached = _rigs.get(face.session_uid)
    if cached is None or cached[0] is not binding:
        cached = (binding, _make_rig(face, binding))
        _rigs[face.session_uid] = cached
        _last.pop(face.session_uid, None)
    return cached[1]


def current(face) -> EyelidRig | None:
    """The lids' rig playback last used for `face`, or None (not played yet, or no lids' turn: an eye's FPs missing)."""
    cached = _rigs.get(face.session_uid)
    return None if cached is None else cached[1]


def hold(face, binding: Binding, control_ids, points: np.ndarray) -> np.ndarray:
    """The control points for the deformer: the mid-lid FPs at rest when the lids are rigged (`apply` turns them)."""
    return points if _rig(face, binding) is None else hold_lids(control_ids, points, binding.control_rest)


def still(face, binding: Binding, fps: np.ndarray) -> bool:
    """True when the lid and pupil FPs in `fps` (84, 3) are where they were at the last `apply`."""
    watched = fps[_WATCHED_ROWS]
    last = _last.get(face.session_uid)
    return _rig(face, binding) is None or (last is not None and np.array_equal(watched, last, equal_nan=True))


def apply(face, binding: Binding, out: np.ndarray, fps: np.ndarray) -> bool:
    """Turn the lids of the deformed positions `out` (N, 3) by the FPs `fps` (84, 3; NaN where absent), in place;
    False when they are at rest and `out` was left as it was."""
    rig = _rig(face, binding)
    if rig is None:
        return False
    watched = fps[_WATCHED_ROWS]
    _last[face.session_uid] = watched
    # at rest the lids turn by exactly 0 (most frames of speech): skip working that out
    if np.array_equal(watched, _at_rest.get(face.session_uid)):
        return False
    apply_eyelids(rig, out, fps)
    return True


def turned_vertices(face, binding: Binding) -> np.ndarray | None:
    """(K,) the vertices `apply` may move, or None when the lids are not rigged."""
    rig = _rig(face, binding)
    return None if rig is None else rig.vertices
