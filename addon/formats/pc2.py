"""PC2 point caches (the format Blender's Mesh Cache modifier reads).

Layout, little-endian: 12-byte signature "POINTCACHE2\\0", int32 version (1), int32 number of points,
float32 start frame, float32 sample rate (frames per sample), int32 number of samples, then
samples x points x 3 float32 coordinates.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from ..errors import Mpeg4Error

SIGNATURE = b"POINTCACHE2\0"
HEADER = np.dtype(
    [("signature", "S12"), ("version", "<i4"), ("points", "<i4"), ("start", "<f4"), ("rate", "<f4"), ("samples", "<i4")]
)


class PointCacheError(Mpeg4Error):
    """A point cache that cannot be written or read."""


def write_pc2(path: str, frames: np.ndarray, start: float, rate: float = 1.0) -> None:
    """Write (samples, points, 3) positions atomically (a temporary file renamed into place)."""
    frames = np.asarray(frames, dtype="<f4")
    if frames.ndim != 3 or frames.shape[2] != 3:
        raise PointCacheError(f"positions must be (samples, points, 3), got {frames.shape}")
    header = np.array([(SIGNATURE, 1, frames.shape[1], start, rate, frames.shape[0])], dtype=HEADER)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(suffix=".pc2.part", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(header.tobytes())
            fh.write(np.ascontiguousarray(frames).tobytes())
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a cache is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def read_pc2(path: str) -> tuple[np.ndarray, float, float]:
    """(samples, points, 3) float32 positions, start frame, sample rate."""
    with open(path, "rb") as fh:
        raw = fh.read()
    if len(raw) < HEADER.itemsize or raw[:12] != SIGNATURE:
        raise PointCacheError(f"{path}: not a PC2 point cache")
    header = np.frombuffer(raw[: HEADER.itemsize], dtype=HEADER)[0]
    count = int(header["samples"]) * int(header["points"]) * 3
    if header["samples"] < 0 or header["points"] < 0 or len(raw) != HEADER.itemsize + 4 * count:
        raise PointCacheError(f"{path}: size does not match its header")
    shape = (int(header["samples"]), int(header["points"]), 3)
    data = np.frombuffer(raw, dtype="<f4", offset=HEADER.itemsize).reshape(shape)
    return data.copy(), float(header["start"]), float(header["rate"])
