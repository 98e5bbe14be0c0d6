"""Checks of a parsed FAP stream against the scene, made before anything is keyed (no bpy; numpy only).

A stream's timing and values come from a file, so any of them may be absurd: an fps of 1e-300, a frame
number of 2**53 - 1, a value of 1e100. These checks run first and refuse such a stream with a message
naming the file, so that a refused import changes nothing. Nothing here allocates per scene frame: the
work is per stream frame (at most MAX_KEYS of them), so frames 0 and 1,000,000 make two keys, not a
million.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import Mpeg4Error
from .faps import FAPS, N_FAPS

__all__ = [
    "MAX_KEYS",
    "MAX_SPAN_FRAMES",
    "MAX_STREAM_FPS",
    "MAXFRAME",
    "MIN_STREAM_FPS",
    "MINFRAME",
    "VALUE_LIMIT",
    "StreamTimingError",
    "StreamValueError",
    "check_values",
    "gain_and_clamp",
    "scene_frames",
]

MAXFRAME = 1_048_574  # Blender's MAXFRAME (DNA_scene_types.h): no scene frame or key lies beyond it
MINFRAME = -MAXFRAME
MAX_SPAN_FRAMES = 1_048_574  # longest stretch of scene frames one stream may cover (about 12 hours at 24 fps)
MAX_KEYS = 2_000_000  # stream frames one import may key (22 hours at 25 fps); each frame keys every FP
MIN_STREAM_FPS = 0.001
MAX_STREAM_FPS = 10_000.0
# Largest |low-level FAP value| accepted, in FAP units (FAPU, or 1e-5 rad for angles). The largest in
# the real streams we know is 600,000 (Crystal.TTVS interpolation_emot.fap, FAP 23 yaw_l_eyeball,
# tuned for an old XFace that moved eyes by translation); the others stay below 60,000 (VREng jag.fap,
# head yaw 56,298). 1e7 leaves a factor 16 over that largest one, enough for it at the Gain's soft
# maximum of 2 with room to spare, while 1e7 units (10,000 mouth-nose separations, 100 rad) is no face
# motion: a larger value is a broken file or a wrong unit, and a value like 1e100 would make the scene's
# transforms infinite.
VALUE_LIMIT = 1e7


class StreamTimingError(Mpeg4Error):
    """A stream whose frames cannot be placed on the scene's timeline (fps, frame range, length)."""


class StreamValueError(Mpeg4Error):
    """A stream whose FAP values cannot be played (out of range), or an unusable Gain or Clamp."""


def _prefix(source: str) -> str:
    return f"{source}: " if source else ""


def _frame_text(frame: float) -> str:
    """A frame for a message: all its digits when it is an integer, else two decimals (or 6 digits)."""
    if frame.is_integer() and abs(frame) < 1e18:
        return str(int(frame))
    return f"{frame:.2f}".rstrip("0").rstrip(".") if abs(frame) < 1e15 else f"{frame:.6g}"


def scene_frames(
    frame_numbers: np.ndarray,
    stream_fps: float,
    scene_fps: float,
    start_frame: int,
    *,
    use_stream_fps: bool = True,
    source: str = "",
) -> np.ndarray:
    """(F,) float64 scene frame of each stream frame; StreamTimingError if the stream cannot be placed.

    With `use_stream_fps` the stream keeps its timing: frame n plays at n / stream_fps seconds, that is
    scene frame start_frame + n / stream_fps * scene_fps. Without, each stream frame is one scene frame:
    start_frame + n. The stream's fps is checked either way: a header with an impossible rate is a broken
    file. The frames must lie within Blender's frame range and span at most MAX_SPAN_FRAMES.
    """
    where = _prefix(source)
    n = np.asarray(frame_numbers)
    if n.ndim != 1:
        raise StreamTimingError(f"{where}frame numbers must be one number per frame, got shape {n.shape}")
    if len(n) > MAX_KEYS:
        raise StreamTimingError(
            f"{where}the stream has {len(n):,} frames; at most {MAX_KEYS:,} can be imported at once: split the file"
        )
    if not (math.isfinite(stream_fps) and MIN_STREAM_FPS <= stream_fps <= MAX_STREAM_FPS):
        raise StreamTimingError(
            f"{where}the stream's fps is {stream_fps!r}; a playable stream has {MIN_STREAM_FPS:g} to "
            f"{MAX_STREAM_FPS:g} frames per second"
        )
    if not (math.isfinite(scene_fps) and scene_fps > 0):
        raise StreamTimingError(f"{where}the scene's fps must be a positive finite number, found {scene_fps!r}")
    if not math.isfinite(start_frame):
        raise StreamTimingError(f"{where}the start frame must be a finite number, found {start_frame!r}")
    n = n.astype(np.float64)
    # scene_fps / stream_fps first: exactly 1 (or 2, ...) for matching rates, so frames stay integral
    frames = start_frame + (n * (scene_fps / stream_fps) if use_stream_fps else n)
    if len(frames) == 0:
        return frames
    outside = ~((frames >= MINFRAME) & (frames <= MAXFRAME))  # NaN (a non-finite frame number) too
    if outside.any():
        i = int(np.argmax(outside))
        side = (
            f"beyond Blender's last frame {MAXFRAME}"
            if frames[i] > MAXFRAME
            else f"before Blender's first frame {MINFRAME}"
        )
        raise StreamTimingError(
            f"{where}frame {_frame_text(float(n[i]))} of the stream lands on scene frame "
            f"{_frame_text(float(frames[i]))}, {side}"
        )
    first, last = float(frames.min()), float(frames.max())
    if last - first > MAX_SPAN_FRAMES:
        raise StreamTimingError(
            f"{where}the stream spans {_frame_text(last - first)} scene frames (from {_frame_text(first)} to "
            f"{_frame_text(last)}); one import may span at most {MAX_SPAN_FRAMES}"
        )
    return frames


def _check_shapes(values: np.ndarray, mask: np.ndarray) -> None:
    if values.ndim != 2 or values.shape[1] != N_FAPS or mask.shape != values.shape:
        raise StreamValueError(
            f"FAP values and mask must both be (frames, {N_FAPS}), got {values.shape} and {mask.shape}"
        )


def gain_and_clamp(values: np.ndarray, mask: np.ndarray, gain: float = 1.0, clamp: float | None = None) -> np.ndarray:
    """A new (F, 68) array: the low-level FAP values (FAP 3..68) times `gain`, then limited to ±`clamp`.

    FAP 1 and 2 (columns 0 and 1) are left as they are. Every low-level entry is scaled, masked in or
    not, because the values may be dense (a masked-out FAP holding its last value must scale with it);
    `mask` must match `values` in shape. Gain must be finite and >= 0, clamp finite and > 0 (or None).
    """
    if not (math.isfinite(gain) and gain >= 0):
        raise StreamValueError(f"Gain must be a finite number of at least 0, found {gain!r}")
    if clamp is not None and not (math.isfinite(clamp) and clamp > 0):
        raise StreamValueError(f"Clamp must be a finite number above 0 (or no clamp), found {clamp!r}")
    out = np.array(values, dtype=np.float64)
    _check_shapes(out, np.asarray(mask))
    low = out[:, 2:]
    with np.errstate(over="ignore"):  # an overflow becomes inf, which the clamp or check_values then meets
        low *= gain
    if clamp is not None:
        np.clip(low, -clamp, clamp, out=low)
    return out


def check_values(values: np.ndarray, mask: np.ndarray, limit: float = VALUE_LIMIT, source: str = "") -> None:
    """StreamValueError if a present low-level FAP value's magnitude exceeds `limit` FAP units.

    The error names the first such value in frame order: its frame index (counting from 0), FAP number
    and name; NaN and infinities are refused the same way. FAP 1 and 2 are not FAP-unit values and are
    not checked here.
    """
    if not (math.isfinite(limit) and limit > 0):
        raise StreamValueError(f"the value limit must be a finite number above 0, found {limit!r}")
    values = np.asarray(values, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    _check_shapes(values, mask)
    with np.errstate(invalid="ignore"):
        bad = mask[:, 2:] & ~(np.abs(values[:, 2:]) <= limit)
    if bad.any():
        frame, column = (int(i) for i in np.argwhere(bad)[0])
        fap = FAPS[column + 2]
        raise StreamValueError(
            f"{_prefix(source)}frame index {frame}: FAP {fap.number} ({fap.name}) is "
            f"{values[frame, column + 2]:.6g}, beyond the limit of {limit:g} FAP units; set the Clamp import "
            "option (or lower the Gain) to play this stream"
        )
