"""PC2 point caches (the format Blender's Mesh Cache modifier reads).

Layout, little-endian: 12-byte signature "POINTCACHE2\\0", int32 version (1), int32 number of points,
float32 start frame, float32 sample rate (frames per sample), int32 number of samples, then
samples x points x 3 float32 coordinates.

`PointCacheWriter` streams: the header (which needs the sample count up front) and then one sample at a
time, so memory does not grow with the sample count. It writes a temporary file next to the target and
renames it into place only when every sample is in, so a failed or cancelled write leaves no file and an
existing cache stays as it was.
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
TEMP_SUFFIX = ".part"


class PointCacheError(Mpeg4Error):
    """A point cache that cannot be written or read."""


class PointCacheWriter:
    """Write `samples` samples of `points` positions to `path`, one `write` per sample.

    `close` ends a complete file under its temporary name (`temp_path`), `commit` renames it into place,
    `discard` deletes it. As a context manager it commits on success and discards on any error.
    """

    def __init__(self, path: str, points: int, samples: int, start: float, rate: float = 1.0):
        if points < 0 or samples < 0:
            raise PointCacheError(f"a point cache needs a non-negative size, got {samples} x {points}")
        self.path = path
        self.points, self.samples, self.written = points, samples, 0
        folder = os.path.dirname(os.path.abspath(path))
        try:
            fd, self.temp_path = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=TEMP_SUFFIX, dir=folder)
        except OSError as exc:
            raise PointCacheError(f"cannot write a point cache in {folder}: {exc.strerror}") from exc
        self._file = os.fdopen(fd, "wb")
        header = np.array([(SIGNATURE, 1, points, start, rate, samples)], dtype=HEADER)
        self._guarded(self._file.write, header.tobytes())

    def _guarded(self, function, *args):
        """Run a file operation; an OS error (disk full, folder gone) discards the file and is reported."""
        try:
            return function(*args)
        except OSError as exc:
            self.discard()
            raise PointCacheError(f"cannot write {self.path}: {exc.strerror or exc}") from exc

    def write(self, positions: np.ndarray) -> None:
        """Append one sample: (points, 3) positions."""
        if self._file is None:
            raise PointCacheError(f"{self.path}: the point cache is already closed")
        sample = np.ascontiguousarray(positions, dtype="<f4")
        if sample.shape != (self.points, 3):
            raise PointCacheError(f"a sample must be ({self.points}, 3) positions, got {sample.shape}")
        if self.written == self.samples:
            raise PointCacheError(f"{self.path}: all {self.samples} samples are already written")
        self._guarded(self._file.write, sample.data)
        self.written += 1

    def close(self) -> None:
        """Finish the file under its temporary name; it must hold every sample."""
        if self._file is None:
            return
        if self.written != self.samples:
            self.discard()
            raise PointCacheError(f"{self.path}: only {self.written} of {self.samples} samples were written")
        self._guarded(self._file.close)
        self._file = None
        self._guarded(os.chmod, self.temp_path, 0o644)  # mkstemp makes it private; a cache is an ordinary file

    def commit(self) -> None:
        """Put the complete file in place (replacing an existing one in one step)."""
        self.close()
        if self.temp_path is None:
            raise PointCacheError(f"{self.path}: the point cache was discarded")
        self._guarded(os.replace, self.temp_path, self.path)
        self.temp_path = None

    def discard(self) -> None:
        """Delete the temporary file (nothing happens when it is already committed or discarded)."""
        if self._file is not None:
            self._file.close()
            self._file = None
        if self.temp_path is not None:
            if os.path.exists(self.temp_path):
                os.remove(self.temp_path)
            self.temp_path = None

    def __enter__(self) -> PointCacheWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def write_pc2(path: str, frames: np.ndarray, start: float, rate: float = 1.0) -> None:
    """Write (samples, points, 3) positions atomically (a temporary file renamed into place)."""
    frames = np.asarray(frames, dtype="<f4")
    if frames.ndim != 3 or frames.shape[2] != 3:
        raise PointCacheError(f"positions must be (samples, points, 3), got {frames.shape}")
    with PointCacheWriter(path, frames.shape[1], frames.shape[0], start, rate) as writer:
        for sample in frames:
            writer.write(sample)


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
