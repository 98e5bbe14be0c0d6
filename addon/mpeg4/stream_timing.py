"""PLACEHOLDER (being written by a helper): stream timing and value checks."""

from __future__ import annotations

import numpy as np

from ..errors import Mpeg4Error


class StreamTimingError(Mpeg4Error):
    pass


def scene_frames(frame_numbers, stream_fps, scene_fps, start_frame, *, use_stream_fps=True, source=""):
    if not (0.001 <= stream_fps <= 10000):
        raise StreamTimingError(f"{source}: fps {stream_fps} out of range")
    n = np.asarray(frame_numbers, dtype=np.float64)
    frames = start_frame + (n / stream_fps * scene_fps if use_stream_fps else n)
    if frames.max() > 1048574:
        raise StreamTimingError(f"{source}: beyond Blender's last frame")
    return frames


def gain_and_clamp(values, mask, gain=1.0, clamp=None):
    out = np.array(values, dtype=np.float64)
    out[:, 2:] *= gain
    if clamp is not None:
        out[:, 2:] = np.clip(out[:, 2:], -clamp, clamp)
    return out


def check_values(values, mask, limit=1e6, source=""):
    if np.any(np.abs(np.where(mask[:, 2:], values[:, 2:], 0)) > limit):
        raise StreamTimingError(f"{source}: value too large")
