"""FAP streams in and out of a set-up face.

Import: .fap -> held FAP values (decode.hold_missing) -> gain and clamp (the options), then each group's gain
and soft limit (the face's settings, fap_groups.shape_faps) -> FP positions
(decode.fap_to_fp, head rotation left out) -> keys on the FP empties; head pitch/yaw/roll -> keys on the
face's delta transform (head_motion), turning the head about 7.1 while leaving the user's own transform
alone. All keys of one stream go into one action named after the file (animation.StreamActions).
Everything is read, decoded and checked (times, sizes, values) before anything in the scene changes, so
a bad file leaves the scene as it was. Export is the inverse (encode.fp_to_fap, head_motion.from_delta).

Gains apply live: the last stream imported in place of the face's motion is remembered (its FAP values
before the group gains, in the face's settings), and changing a gain or Plausible Ranges keys it again
from them (`apply_gains`), unless its keys were edited since (then the user's edits win and the panel says
so). A stream added on top of other motion is keyed once; its gains apply at import only.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass

import numpy as np

from ..errors import Mpeg4Error
from ..mpeg4.decode import fap_to_fp, head_pivot, hold_missing
from ..mpeg4.encode import fp_to_fap, recoverable_faps
from ..mpeg4.fap_file import FapStream, read_fap, write_fap
from ..mpeg4.fap_groups import GROUP_NAMES, shape_faps
from ..mpeg4.faps import N_FAPS
from ..mpeg4.fapu import AU, Fapu
from ..mpeg4.feature_points import FP_IDS, fp_index
from ..mpeg4.stream_timing import check_values, gain_and_clamp, scene_frames
from ..speech.high_level import apply_high_level
from . import animation, binding_store, elastic_rig, face_data, followers, head_motion, inner_parts, rest_shape
from .reporting import Warn, progress

HEAD_FAPS = slice(47, 50)


@dataclass(frozen=True)
class ImportOptions:
    start_frame: int
    use_stream_fps: bool = True  # resample the stream's time to the scene's fps (else one frame per frame)
    gain: float = 1.0
    clamp: float | None = None  # largest |FAP value| after the gain, in FAP units
    add: bool = False  # add to the existing motion (sampled at the stream's frames) instead of replacing it
    fill_partners: bool = False
    set_frame_range: bool = True


def face_fapu(face) -> Fapu:
    values = tuple(face.mpeg4_face.fapu)
    if not all(v > 0 for v in values):
        raise Mpeg4Error(
            f"{face.name} has no FAPU yet: place the eye, nose and mouth feature points and run Set Up Face"
        )
    return Fapu(*values)


def eye_pivots(face) -> np.ndarray | None:
    """(2, 3) face-local centres of the left and right eyeballs (fitted spheres), or None without both eyes."""
    settings = face.mpeg4_face
    objects = (settings.left_eye, settings.right_eye)
    inside = {} if all(objects) else inner_parts.eye_centres(face, rest_shape.reference_positions(face.data))
    centres = [
        followers.eye_centre(face, eye) if eye is not None else inside.get(role)
        for eye, role in zip(objects, ("left_eye", "right_eye"), strict=True)
    ]
    return None if any(c is None for c in centres) else np.array(centres)


def group_gains(face) -> dict[str, float]:
    settings = face.mpeg4_face
    return {name: getattr(settings, f"gain_{name}") for name in GROUP_NAMES}


# part field -> (the FAPs that move it, what the stream then lacks without it)
PART_FAPS = {
    "left_eye": ((23, 25), "the left eye's turns (FAP 23, 25)"),
    "right_eye": ((24, 26), "the right eye's turns (FAP 24, 26)"),
    "lower_teeth": ((3, 14, 15), "the lower teeth moving with the jaw (FAP 3, 14, 15)"),
    "upper_teeth": ((3,), "upper teeth inside the opened mouth (FAP 3)"),
    "tongue": ((43, 44, 45, 46, 47), "the tongue's motion (FAP 43-47)"),
    "lashes": ((19, 20, 21, 22), "eyelashes on the moving lids (FAP 19-22)"),
    "brows": ((31, 32, 33, 34, 35, 36, 37, 38), "brow hair on the moving brows (FAP 31-38)"),
}


WARN_PARTS = {"left_eye", "right_eye", "lower_teeth", "tongue"}  # moved by their FAPs; the others are optional


def missing_parts(face, mask: np.ndarray) -> list[str]:
    """A message for each face part the stream moves (its FAPs are present) but the face does not have."""
    settings = face.mpeg4_face
    present = np.asarray(mask, dtype=bool).any(axis=0)
    notes = []
    for name, (numbers, what) in PART_FAPS.items():
        inside = face.vertex_groups.get(inner_parts.GROUPS.get(name, "")) is not None
        if getattr(settings, name) is None and not inside and present[[n - 1 for n in numbers]].any():
            label = settings.bl_rna.properties[name].name
            text = f"no {label} set in Face Parts: {what} will not show (set it, then run Set Up Face)"
            notes.append(Warn(text) if name in WARN_PARTS else text)
    return notes


def require_setup(face):
    if not binding_store.is_bound(face):
        raise Mpeg4Error(f"{face.name} is not set up: run Set Up Face first")
    empties = face_data.fp_empties(face)
    if not empties:
        raise Mpeg4Error(f"{face.name} has no feature point empties")
    return empties


def _check_reach(face, points: np.ndarray, neutral: np.ndarray, source: str) -> None:
    """Refuse a stream that would throw feature points implausibly far (a file with absurd values)."""
    size = float(max(face.dimensions) / max(max(face.scale), 1e-9)) or 1.0
    moved = np.linalg.norm(points - neutral[None], axis=2)
    worst = np.nanmax(moved) if np.isfinite(moved).any() else 0.0
    if not np.all(np.isfinite(points[:, np.isfinite(neutral[:, 0])])) or worst > 10.0 * size:
        frame, k = np.unravel_index(np.nanargmax(np.where(np.isfinite(moved), moved, np.inf)), moved.shape)
        raise Mpeg4Error(
            f"{source}: frame {frame} moves FP {FP_IDS[k]} {worst:.3g} model units, more than ten "
            "times the face's size: lower the Gain or set Clamp"
        )


@dataclass
class DecodedStream:
    """A stream decoded onto one face and checked, ready to key: nothing in the scene has changed yet."""

    source: str
    name: str
    frames: np.ndarray  # (F,) scene frames
    points: np.ndarray  # (F, 84, 3) face-local FP positions
    neutral: np.ndarray  # (84, 3)
    head: tuple[np.ndarray, np.ndarray] | None  # per-frame delta rotation values and delta location
    high_level: bool  # the stream carried FAP 1 or 2
    notes: list  # what the face lacks to show the whole stream
    faps: np.ndarray | None = None  # (F, 68) the FAP values before the group gains (kept for `apply_gains`)


def decode_stream(context, face, stream: FapStream, options: ImportOptions, source: str) -> DecodedStream:
    """Decode and check a stream for `face` (times, sizes, values, reach); raises Mpeg4Error, changes nothing."""
    empties = require_setup(face)
    face_fapu(face)  # a face without FAPU is refused before the stream is looked at
    if len(stream.frame_numbers) == 0:
        raise Mpeg4Error(f"{source}: the stream has no frames")
    scene = context.scene
    scene_fps = scene.render.fps / scene.render.fps_base
    frames = scene_frames(
        stream.frame_numbers,
        stream.fps,
        scene_fps,
        options.start_frame,
        use_stream_fps=options.use_stream_fps,
        source=source,
    )
    # FAP 1 (viseme) and 2 (expression) through the face tables; low-level FAPs of the same frame win
    mask, values = apply_high_level(
        stream.mask, stream.values, stream.viseme, stream.expression, frame_numbers=stream.frame_numbers
    )
    values = hold_missing(mask, values, options.fill_partners)
    values = gain_and_clamp(values, mask, options.gain, options.clamp)
    check_values(values, mask, source=source)
    has_head = bool(mask[:, HEAD_FAPS].any())
    points, neutral, head_delta = _positions(face, empties, values, has_head, source)
    name = os.path.splitext(source)[0]
    high_level = bool(stream.mask[:, :2].any())
    notes = missing_parts(face, mask)
    return DecodedStream(source, name, frames, points, neutral, head_delta, high_level, notes, faps=values)


def _positions(face, empties, values: np.ndarray, has_head: bool, source: str):
    """FAP values (before the group gains) -> FP positions (F, 84, 3), neutral (84, 3) and the head's delta
    transform (or None), with the face's group gains and ranges; checked, nothing changed."""
    fapu = face_fapu(face)
    values = shape_faps(values, group_gains(face), limit=face.mpeg4_face.use_soft_limits)
    if has_head:
        head_motion.check_rotation_mode(face)
    head = values[:, HEAD_FAPS] * AU
    values[:, HEAD_FAPS] = 0.0
    neutral = face_data.neutral_positions(empties)
    points = fap_to_fp(neutral, values, fapu, axes=face_data.face_axes(face), eye_pivots=eye_pivots(face))
    # an FP whose FAPs move it relative to an FP the face lacks (6.1 from 6.2) comes out NaN: it stays still
    points = np.where(np.isfinite(points), points, neutral[None])
    _check_reach(face, points, neutral, source)
    head_delta = head_motion.to_delta(face, head, head_pivot(neutral)) if has_head else None
    return points, neutral, head_delta


def import_fap(context, face, path, options: ImportOptions) -> list[str]:
    source = os.path.basename(path)
    decoded = decode_stream(context, face, read_fap(path), options, source)
    return key_stream(context, face, decoded, options)


def key_stream(context, face, decoded: DecodedStream, options: ImportOptions) -> list[str]:
    """Key a decoded stream onto the face's FP empties (and head) as one action named after it."""
    empties = require_setup(face)
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:
        elastic_rig.require_skeleton(face)  # its keys are baked below: refuse before anything is keyed
    frames, points, neutral = decoded.frames, decoded.points, decoded.neutral
    streams = animation.StreamActions(decoded.name, decoded.source)
    written = []  # each curve's keys as keyed, in `_keyed_curves` order
    with progress(context, len(empties) + 1) as step:
        for i, (fp_id, ob) in enumerate(empties.items()):
            k = fp_index(fp_id)
            keyed = points[:, k]
            if options.add:  # the existing motion, sampled where the stream has keys, plus the stream's offsets
                base = [animation.sample(ob, "location", axis, frames, ob.location[axis]) for axis in range(3)]
                keyed = np.stack(base, axis=1) + keyed - neutral[k]
            fcurve = animation.replace_motion(ob, streams)
            written += [animation.set_keys(fcurve("location", axis), frames, keyed[:, axis]) for axis in range(3)]
            step(i)
        if decoded.head is not None:
            rotation, dloc = decoded.head
            if options.add:
                rotation, dloc = head_motion.compose_with_existing(face, frames, rotation, dloc)
            head_motion.remember_rest(face)
            fcurve = animation.replace_motion(face, streams)
            path, size = head_motion.rotation_path(face)
            written += [animation.set_keys(fcurve(path, axis), frames, rotation[:, axis]) for axis in range(size)]
            written += [animation.set_keys(fcurve("delta_location", axis), frames, dloc[:, axis]) for axis in range(3)]
        elif not options.add:
            animation.clear_stream_motion(face)  # a new stream without head motion replaces the old head motion
            head_motion.restore_rest(face)
        step(len(empties) + 1)
    _remember(face, decoded, None if options.add else empties, written)
    notes = [
        f"keyed {len(empties)} feature points over {len(frames)} frames of {decoded.source} (action {decoded.name!r})"
    ]
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:
        notes.append(elastic_rig.bake_keys(face, frames, streams))
    if decoded.head is not None:
        notes.append("keyed head rotation on the face's delta transform")
    if decoded.high_level:
        notes.append("played the stream's visemes and expressions (FAP 1, 2) through the face tables")
    notes.extend(decoded.notes)
    scene = context.scene
    last = int(np.ceil(frames[-1]))
    if options.set_frame_range and last > scene.frame_end:
        scene.frame_end = last
        notes.append(f"scene end frame set to {last}")
    return notes


RECORD = "stream"  # in the face's settings: the stream `apply_gains` keys again


def _keyed_curves(face, empties, head: bool):
    """The F-curves a remembered stream keyed (None where one is missing), in a fixed order."""
    curves = [animation.find_fcurve(ob, "location", axis) for ob in empties.values() for axis in range(3)]
    if head:
        path, size = head_motion.rotation_path(face)
        curves += [animation.find_fcurve(face, path, axis) for axis in range(size)]
        curves += [animation.find_fcurve(face, "delta_location", axis) for axis in range(3)]
    return curves


def _keys(curves) -> list[np.ndarray]:
    """Each curve's keys, (K, 2) float32 (frame, value)."""
    keys = []
    for fcurve in curves:
        co = np.empty(2 * len(fcurve.keyframe_points), dtype=np.float32)
        fcurve.keyframe_points.foreach_get("co", co)
        keys.append(co.reshape(-1, 2))
    return keys


def _checksum(keys: list[np.ndarray]) -> str:
    """A digest of the curves' keys, (K, 2) float32 each, curve by curve: what tells an edit since keying."""
    digest = hashlib.blake2b(digest_size=16)
    for k in keys:
        digest.update(len(k).to_bytes(8, "little"))  # where one curve ends and the next begins
        digest.update(np.ascontiguousarray(k, dtype=np.float32).tobytes())
    return digest.hexdigest()


def _remember(face, decoded: DecodedStream, empties, keys: list[np.ndarray]) -> None:
    """Keep what `apply_gains` needs to key the stream again, with the digest of its `keys` as keyed (the
    curves' keys, read back, give the same: set_keys returns them); `empties` None forgets (an added stream)."""
    settings = face.mpeg4_face
    if empties is None or decoded.faps is None:
        if settings.get(RECORD) is not None:
            del settings[RECORD]
        return
    head = decoded.head is not None
    settings[RECORD] = {
        "source": decoded.source,
        "frames": np.asarray(decoded.frames, dtype=np.float64),
        "faps": np.asarray(decoded.faps, dtype=np.float32).ravel(),
        "head": head,
        "fp_ids": list(empties),
        "checksum": _checksum(keys),
    }


def apply_gains(context, face) -> list[str]:
    """Key the remembered stream again with the face's current gains and ranges; [] when there is none.

    Raises Mpeg4Error, changing nothing, when the stream's keys were edited (or the empties changed) since."""
    record = face.mpeg4_face.get(RECORD)
    if record is None:
        return []
    source = str(record["source"])
    empties = require_setup(face)
    head = bool(record["head"])
    curves = _keyed_curves(face, empties, head)
    if list(record["fp_ids"]) != list(empties) or any(fcurve is None for fcurve in curves):
        del face.mpeg4_face[RECORD]  # the stream was taken off: gains apply to the next import
        return []
    if not isinstance(record["checksum"], str):  # key sums, as versions before the digest kept
        raise Mpeg4Error(
            f"{source} was imported by an earlier version of the add-on: the new gains apply when it is imported "
            "again (its keys are kept)"
        )
    keys = _keys(curves)
    if _checksum(keys) != record["checksum"]:
        raise Mpeg4Error(
            f"the keys of {source} were changed since it was imported: the new gains apply when it is imported "
            "again (your edits are kept)"
        )
    frames = np.array(record["frames"], dtype=np.float64)
    faps = np.array(record["faps"], dtype=np.float64).reshape(len(frames), N_FAPS)
    points, _neutral, head_delta = _positions(face, empties, faps, head, source)
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:
        elastic_rig.require_skeleton(face)
    columns = [points[:, fp_index(fp_id), axis] for fp_id in empties for axis in range(3)]
    if head_delta is not None:
        rotation, dloc = head_delta
        columns += [*rotation.T, *dloc.T]
    for i, (fcurve, old, values) in enumerate(zip(curves, keys, columns, strict=True)):
        if not np.array_equal(old, animation.linear_keys(frames, values)):
            keys[i] = animation.set_keys(fcurve, frames, values)  # only the curves the new gains move
    notes = [f"keyed {source} again with the new gains"]
    if face.mpeg4_face.engine == elastic_rig.ELASTIC:
        notes.append(elastic_rig.rebake_keys(face, frames))
    face.mpeg4_face[RECORD]["checksum"] = _checksum(keys)
    return notes


def export_fap(context, face, path, frame_start: int, frame_end: int) -> list[str]:
    empties = require_setup(face)
    fapu = face_fapu(face)
    if frame_end < frame_start:
        raise Mpeg4Error(f"frame range {frame_start}..{frame_end} is empty")
    scene = context.scene
    frames = np.arange(frame_start, frame_end + 1, dtype=np.float64)
    neutral = face_data.neutral_positions(empties)
    positions = np.full((len(frames), len(FP_IDS), 3), np.nan)
    with progress(context, len(empties)) as step:
        for i, (fp_id, ob) in enumerate(empties.items()):
            for axis in range(3):
                positions[:, fp_index(fp_id), axis] = animation.sample(ob, "location", axis, frames, ob.location[axis])
            step(i)
    values = fp_to_fap(neutral, positions, fapu, axes=face_data.face_axes(face), eye_pivots=eye_pivots(face))
    mask = np.zeros((len(frames), N_FAPS), dtype=bool)
    mask[:, [n - 1 for n in recoverable_faps(set(empties))]] = True

    path_name, size = head_motion.rotation_path(face)
    rest = getattr(face, path_name)
    rotation = np.stack([animation.sample(face, path_name, axis, frames, rest[axis]) for axis in range(size)], axis=1)
    identity = np.array([1.0, 0.0, 0.0, 0.0]) if size == 4 else np.zeros(3)
    if np.any(rotation != identity):
        values[:, HEAD_FAPS] = head_motion.from_delta(face, rotation) / AU
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
