"""Read the browser's screenshots: 8-bit RGB or RGBA PNG, not interlaced (what Chromium writes), with zlib and
numpy only, so the test needs no imaging library."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
CHANNELS = {2: 3, 6: 4}  # colour type -> samples per pixel


def _paeth(a: int, b: int, c: int) -> int:
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def _unfilter(kind: int, row: np.ndarray, prior: np.ndarray, bpp: int) -> np.ndarray:
    """One scanline's bytes from its filtered bytes and the line above (PNG spec, section 9)."""
    if kind == 0:
        return row
    if kind == 1:
        return np.cumsum(row.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
    if kind == 2:
        return row + prior
    out, up = bytearray(row.tobytes()), prior.tobytes()
    for i in range(len(out)):
        left = out[i - bpp] if i >= bpp else 0
        if kind == 3:
            out[i] = (out[i] + ((left + up[i]) >> 1)) & 0xFF
        elif kind == 4:
            out[i] = (out[i] + _paeth(left, up[i], up[i - bpp] if i >= bpp else 0)) & 0xFF
        else:
            raise ValueError(f"PNG filter type {kind} is not one of 0-4")
    return np.frombuffer(bytes(out), np.uint8)


def read_png(path: Path) -> np.ndarray:
    """(height, width, channels) uint8."""
    data = Path(path).read_bytes()
    if not data.startswith(SIGNATURE):
        raise ValueError(f"{path}: not a PNG file")
    position, header, compressed = len(SIGNATURE), None, bytearray()
    while position < len(data):
        length, kind = struct.unpack_from(">I4s", data, position)
        body = data[position + 8 : position + 8 + length]
        position += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            compressed += body
        elif kind == b"IEND":
            break
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in CHANNELS or interlace:
        raise ValueError(f"{path}: only 8-bit RGB/RGBA without interlacing is read here")
    bpp = CHANNELS[colour]
    lines = np.frombuffer(zlib.decompress(bytes(compressed)), np.uint8).reshape(height, 1 + width * bpp)
    pixels = np.zeros((height, width * bpp), np.uint8)
    prior = pixels[0]
    for y in range(height):
        pixels[y] = prior = _unfilter(int(lines[y, 0]), lines[y, 1:], prior, bpp)
    return pixels.reshape(height, width, bpp)
