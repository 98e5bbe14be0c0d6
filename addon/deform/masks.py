"""Masks that keep control triangles from moving vertices across the mouth and eye openings.

The paper paints them as texture maps (paper 000, section 3, Figure 9); vertex groups work the same
way. A mask image carries one mask per channel, sampled at each vertex's UV coordinates.
"""

from __future__ import annotations

import numpy as np

from .inputs import DeformError


def sample_image(pixels: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear samples (N, C) of an (H, W, C) image at (N, 2) UVs in [0, 1] (v up, as Blender stores
    images: row 0 is the bottom). UVs outside [0, 1] are clamped to the border."""
    pixels = np.asarray(pixels, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    if pixels.ndim != 3 or pixels.shape[0] < 1 or pixels.shape[1] < 1:
        raise DeformError(f"a mask image must be (height, width, channels), got {pixels.shape}")
    if uv.ndim != 2 or uv.shape[1] != 2 or not np.all(np.isfinite(uv)):
        raise DeformError("mask UVs must be a finite (N, 2) array")
    height, width = pixels.shape[:2]
    # pixel centres sit at (i + 0.5) / size
    x = np.clip(uv[:, 0] * width - 0.5, 0.0, width - 1.0)
    y = np.clip(uv[:, 1] * height - 0.5, 0.0, height - 1.0)
    x0, y0 = np.floor(x).astype(np.intp), np.floor(y).astype(np.intp)
    x1, y1 = np.minimum(x0 + 1, width - 1), np.minimum(y0 + 1, height - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    top = pixels[y1, x0] * (1 - fx) + pixels[y1, x1] * fx
    bottom = pixels[y0, x0] * (1 - fx) + pixels[y0, x1] * fx
    return bottom * (1 - fy) + top * fy


def vertex_uvs(loop_vertex: np.ndarray, loop_uv: np.ndarray, n_vertices: int) -> np.ndarray:
    """(N, 2) one UV per vertex: the mean of its face corners' UVs (a seam vertex takes the mean of its
    sides, which a mask painted a little past its borders tolerates). Vertices in no face get (0, 0)."""
    loop_vertex = np.asarray(loop_vertex, dtype=np.intp)
    loop_uv = np.asarray(loop_uv, dtype=np.float64).reshape(-1, 2)
    count = np.bincount(loop_vertex, minlength=n_vertices).astype(np.float64)
    sums = np.stack([np.bincount(loop_vertex, loop_uv[:, k], minlength=n_vertices) for k in (0, 1)], axis=1)
    return sums / np.maximum(count, 1.0)[:, None]


def image_masks(pixels: np.ndarray, uv: np.ndarray, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Named masks from an image's channels, in order (e.g. R, G, B, A -> upper_lip, lower_lip, ...)."""
    samples = sample_image(pixels, uv)
    if samples.shape[1] < len(names):
        raise DeformError(f"the mask image has {samples.shape[1]} channels; {len(names)} masks need one each")
    return {name: np.clip(samples[:, k], 0.0, 1.0) for k, name in enumerate(names)}
