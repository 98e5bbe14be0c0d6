"""ARKit captures in: a capture file onto a set-up face, as shape-key animation or as a FAP stream.

Target "SHAPE_KEYS" keys the capture's 52 weights onto the face's ARKit shape keys (arkit_keys); target
"FAPS" turns it into a FAP stream (arkit.mapping.capture_to_stream) and imports that as a .fap is imported
(fap_io), so it plays on either engine and exports as .fap. The file is read and checked, and the stream
decoded onto the face, before anything in the scene changes.
"""

from __future__ import annotations

import os

from ..arkit.captures import read_capture
from ..arkit.mapping import capture_to_stream
from ..mpeg4.stream_timing import scene_frames
from . import arkit_keys, fap_io

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
