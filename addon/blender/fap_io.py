"""FAP streams in and out of a set-up face.

Import: .fap -> held FAP values (decode.hold_missing) -> FP positions (decode.fap_to_fp, head rotation
left out) -> keys on the FP empties; head pitch/yaw/roll -> keys on the face's delta rotation and
location, turning the head about 7.1 while leaving the user's own transform alone. Export is the
inverse (encode.fp_to_fap, decode.head_angles). The stream is read and checked before anything in the
scene changes, so a bad file leaves the scene as it was.
"""

from __future__ import annotations

import os

import numpy as np
from mathutils import Euler, Matrix

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.decode import fap_to_fp, head_angles, head_pivot, head_rotation, hold_missing
from ..mpeg4.encode import fp_to_fap, recoverable_faps
from ..mpeg4.fap_file import FapStream, read_fap, write_fap
from ..mpeg4.faps import N_FAPS
from ..mpeg4.fapu import AU, Fapu
from ..mpeg4.feature_points import FP_IDS, fp_index
from . import animation, face_data
from .reporting import UserError, progress

REST_PROP = face_data.EMPTY_REST_PROP
HEAD_FAPS = slice(47, 50)


def face_fapu(face) -> Fapu:
    values = tuple(face.mpeg4_face.fapu)
    if not all(v > 0 for v in values):
        raise UserError(
            f"{face.name} has no FAPU yet: place the eye, nose and mouth feature points and run Set Up Face"
        )
    return Fapu(*values)


def neutral_positions(face, empties) -> np.ndarray:
    """(84, 3) face-local rest positions of the FP empties (NaN where missing)."""
    return face_data.neutral_array(
        {fp_id: np.array(ob.get(REST_PROP, ob.location), dtype=np.float64) for fp_id, ob in empties.items()}
    )


def eye_pivots(face) -> np.ndarray | None:
    settings = face.mpeg4_face
    if settings.left_eye is None or settings.right_eye is None:
        return None
    inv = face.matrix_world.inverted()
    return np.array(
        [inv @ settings.left_eye.matrix_world.translation, inv @ settings.right_eye.matrix_world.translation]
    )


def _require_setup(face):
    if face_data.BINDING_KEY_PROP not in face.data:
        raise UserError(f"{face.name} is not set up: run Set Up Face first")
    empties = face_data.fp_empties(face)
    if not empties:
        raise UserError(f"{face.name} has no feature point empties")
    return empties


def _head_delta(face, angles: np.ndarray, pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame delta rotation (Euler XYZ) and delta location turning the face about `pivot` (local).

    With matrix_basis = T(loc + dloc) R_d R_u S (uniform scale s), turning local points about p by R_h
    needs R_d = R_u R_h R_u^-1 and dloc = R_u s (p - R_h p).
    """
    axes = BLENDER_FACE_AXES
    r_mesh = axes.T @ head_rotation(angles) @ axes
    r_user = (
        np.array(face.rotation_euler.to_matrix())
        if face.rotation_mode != "QUATERNION"
        else np.array(face.rotation_quaternion.to_matrix())
    )
    scale = float(np.mean(face.scale))
    r_delta = r_user @ r_mesh @ r_user.T
    dloc = scale * np.einsum("ij,fj->fi", r_user, pivot - np.einsum("fij,j->fi", r_mesh, pivot))
    euler = np.array([Matrix(r.tolist()).to_euler("XYZ") for r in r_delta])
    return euler, dloc


def import_fap(
    context, face, path, *, start_frame: int, fill_partners: bool = False, set_frame_range: bool = True
) -> list[str]:
    empties = _require_setup(face)
    fapu = face_fapu(face)
    stream = read_fap(path)
    if len(stream.frame_numbers) == 0:
        raise UserError(f"{os.path.basename(path)}: the stream has no frames")

    scene = context.scene
    values = hold_missing(stream.mask, stream.values, fill_partners)
    head = values[:, HEAD_FAPS] * AU
    values[:, HEAD_FAPS] = 0.0
    neutral = neutral_positions(face, empties)
    points = fap_to_fp(neutral, values, fapu, eye_pivots=eye_pivots(face))
    scene_fps = scene.render.fps / scene.render.fps_base
    frames = start_frame + stream.frame_numbers / stream.fps * scene_fps

    name = stream.name or os.path.splitext(os.path.basename(path))[0]
    kept = 0
    with progress(context, len(empties) + 1) as step:
        for i, (fp_id, ob) in enumerate(empties.items()):
            anim = ob.animation_data
            if anim is not None and anim.action is not None:
                anim.action.use_fake_user = True  # the previous animation stays in the file
                anim.action = None
                kept += 1
            k = fp_index(fp_id)
            for axis in range(3):
                fcurve = animation.ensure_fcurve(ob, "location", axis, f"FAP {name} {ob.name}")
                animation.set_keys(fcurve, frames, points[:, k, axis])
            step(i)
        notes = [f"keyed {len(empties)} feature points over {len(frames)} frames of {name!r}"]
        if stream.mask[:, HEAD_FAPS].any():
            pivot = head_pivot(neutral)
            euler, dloc = _head_delta(face, head, pivot)
            for axis in range(3):
                animation.set_keys(
                    animation.ensure_fcurve(face, "delta_rotation_euler", axis, face.name), frames, euler[:, axis]
                )
                animation.set_keys(
                    animation.ensure_fcurve(face, "delta_location", axis, face.name), frames, dloc[:, axis]
                )
            notes.append("keyed head rotation on the face's delta transform")
        step(len(empties) + 1)
    if kept:
        notes.append(f"kept {kept} earlier feature point actions (fake user)")
    if stream.mask[:, :2].any():
        notes.append("the stream's visemes/expressions (FAP 1, 2) need a face's viseme table and are not applied")
    last = int(np.ceil(frames[-1]))
    if set_frame_range and last > scene.frame_end:
        scene.frame_end = last
        notes.append(f"scene end frame set to {last}")
    return notes


def export_fap(context, face, path, frame_start: int, frame_end: int) -> list[str]:
    empties = _require_setup(face)
    fapu = face_fapu(face)
    if frame_end < frame_start:
        raise UserError(f"frame range {frame_start}..{frame_end} is empty")
    scene = context.scene
    frames = np.arange(frame_start, frame_end + 1, dtype=np.float64)
    neutral = neutral_positions(face, empties)
    positions = np.full((len(frames), len(FP_IDS), 3), np.nan)
    with progress(context, len(empties)) as step:
        for i, (fp_id, ob) in enumerate(empties.items()):
            for axis in range(3):
                positions[:, fp_index(fp_id), axis] = animation.sample(ob, "location", axis, frames, ob.location[axis])
            step(i)
    values = fp_to_fap(neutral, positions, fapu, eye_pivots=eye_pivots(face))
    mask = np.zeros((len(frames), N_FAPS), dtype=bool)
    mask[:, [n - 1 for n in recoverable_faps(set(empties))]] = True

    rest_rot = face.delta_rotation_euler
    rot = np.stack(
        [animation.sample(face, "delta_rotation_euler", axis, frames, rest_rot[axis]) for axis in range(3)], axis=1
    )
    if np.any(rot != 0.0):
        r_user = np.array(face.rotation_euler.to_matrix())
        r_delta = np.array([np.array(Euler(e.tolist(), "XYZ").to_matrix()) for e in rot])
        r_mesh = r_user.T @ r_delta @ r_user
        axes = BLENDER_FACE_AXES
        values[:, HEAD_FAPS] = head_angles(axes @ r_mesh @ axes.T) / AU
        mask[:, HEAD_FAPS] = True

    fps = scene.render.fps / scene.render.fps_base
    stream = FapStream(
        version="2.1",
        name=os.path.splitext(os.path.basename(path))[0],
        fps=fps,
        frame_numbers=np.arange(len(frames), dtype=np.int64),
        mask=mask,
        values=np.where(mask, np.round(values), 0.0),
        viseme=np.zeros((len(frames), 4)),
        expression=np.zeros((len(frames), 6)),
    )
    write_fap(stream, path)
    return [f"wrote {len(frames)} frames of {int(mask[0].sum())} FAPs to {os.path.basename(path)}"]
