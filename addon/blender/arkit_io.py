"""ARKit captures in and out of a set-up face: a capture as shape-key animation or as a FAP stream; a FAP stream
as ARKit weights (Live Link Face CSV); the face with its ARKit morph targets as glTF.

Target "SHAPE_KEYS" keys the capture's 52 weights onto the face's ARKit shape keys (arkit_keys); target
"FAPS" turns it into a FAP stream (arkit.mapping.capture_to_stream) and imports that as a .fap is imported
(fap_io), so it plays on either engine and exports as .fap. The file is read and checked, and the stream
decoded onto the face, before anything in the scene changes.
"""

from __future__ import annotations

import os

import bpy
import numpy as np

from ..arkit.captures import Capture, read_capture, write_live_link_csv
from ..arkit.mapping import EYE_FAPS, HEAD_FAPS, capture_faps, capture_to_stream, faps_to_weights, fp_distances
from ..errors import Mpeg4Error
from ..mpeg4.decode import hold_missing
from ..mpeg4.fap_file import FapStream
from ..mpeg4.fapu import AU
from ..mpeg4.stream_timing import scene_frames
from ..speech.high_level import apply_high_level
from . import arkit_keys, face_data, fap_io, rest_shape

TARGETS = ("SHAPE_KEYS", "FAPS")


def import_capture(context, face, path, target: str, options: fap_io.ImportOptions, fps: float = 30.0) -> list[str]:
    """Import the capture at `path` onto `face` (`fps` times files without timing); returns report lines."""
    source = os.path.basename(path)
    capture = read_capture(path, fps=fps)
    if target == "SHAPE_KEYS":
        fap_io.require_setup(face)
        scene = context.scene
        frames = scene_frames(
            capture.frame_numbers,
            capture.fps,
            scene.render.fps / scene.render.fps_base,
            options.start_frame,
            use_stream_fps=options.use_stream_fps,
            source=source,
        )
        notes = arkit_keys.key_capture(context, face, capture, frames)
        last = int(frames[-1])
        if options.set_frame_range and last > scene.frame_end:
            scene.frame_end = last
            notes.append(f"scene end frame set to {last}")
        return notes
    stream = capture_to_stream(capture)
    decoded = fap_io.decode_stream(context, face, stream, options, source)
    notes = fap_io.key_stream(context, face, decoded, options)
    if capture.head is not None:
        notes.append("the capture's head turns went to FAPs 48-50")
    if capture.eyes is not None:
        notes.append("the capture's eye turns went to FAPs 23-26 (in place of its eyeLook weights)")
    return notes


# --- out -----------------------------------------------------------------------------------------------


def write_arkit_csv(face, stream: FapStream, path) -> float:
    """Write a FAP stream as ARKit weights (Live Link Face CSV, timecode at the stream's rate) for `face`: per frame
    the bounded least-squares weights (arkit.mapping.faps_to_weights), the head's FAPs as HeadYaw/Pitch/Roll and
    the eyes' as Left/RightEyeYaw/Pitch. Returns the round trip's mean feature-point error on the face (model
    units): the file read back and played as a capture, against the stream as played."""
    empties = fap_io.require_setup(face)
    fapu = fap_io.face_fapu(face)
    mask, values = apply_high_level(
        stream.mask, stream.values, stream.viseme, stream.expression, frame_numbers=stream.frame_numbers
    )
    values = hold_missing(mask, values)
    sent = mask.any(axis=0)
    head = values[:, [n - 1 for n in HEAD_FAPS]] * AU if sent[[n - 1 for n in HEAD_FAPS]].any() else None
    eyes = values[:, [n - 1 for n in EYE_FAPS]] * AU if sent[[n - 1 for n in EYE_FAPS]].any() else None
    weights = faps_to_weights(values, fapu)
    capture = Capture(stream.name, stream.fps, stream.frame_numbers, weights, head, eyes)
    write_live_link_csv(capture, path)
    back, _mask = capture_faps(read_capture(path, timecode_fps=max(1, round(stream.fps))))
    neutral = face_data.neutral_positions(empties)
    distances = fp_distances(neutral, values, back, fapu, eye_pivots=fap_io.eye_pivots(face))
    return float(np.nanmean(distances))


def export_arkit_glb(context, face, path) -> list[str]:
    """The face and its rendered parts with their 52 ARKit shape keys as morph targets, named as ARKit names them,
    in one binary glTF (Blender's exporter); the keys are made first when the face lacks them. The live effect
    is turned off for the export (its own shape key is not a morph target) and comes back after it."""
    notes = [] if arkit_keys.has_keys(face) else arkit_keys.make_keys(context, face)
    settings = face.mpeg4_face
    was_enabled = settings.enabled
    settings.enabled = False  # restores the rest shape
    rest_shape.remove_own_shape_key(face)
    parts = [ob for ob in face.children if ob.type == "MESH" and not ob.hide_render]
    chosen = {face, *parts}
    selected = [ob for ob in context.view_layer.objects if ob.select_get()]
    active = context.view_layer.objects.active
    try:
        for ob in context.view_layer.objects:
            ob.select_set(ob in chosen)
        context.view_layer.objects.active = face
        bpy.ops.export_scene.gltf(
            filepath=str(path),
            export_format="GLB",
            use_selection=True,
            export_apply=False,
            export_morph=True,
            export_morph_normal=False,
            export_animations=False,
        )
    finally:
        for ob in context.view_layer.objects:
            ob.select_set(ob in selected)
        context.view_layer.objects.active = active
        settings.enabled = was_enabled
    if not os.path.exists(path):
        raise Mpeg4Error(f"the glTF exporter wrote nothing to {path}")
    notes.append(f"wrote {os.path.basename(path)}: {len(chosen)} meshes with ARKit morph targets")
    return notes
