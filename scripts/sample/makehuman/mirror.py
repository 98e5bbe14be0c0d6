"""Left/right vertex correspondence of the symmetric hm08 mesh: (x, y, z) matched with (-x, y, z)."""

import numpy as np

from .errors import SourceDataError

# hm08 is symmetric to the printed precision of its OBJ (4 decimals in dm); 1e-3 dm = 0.1 mm.
MIRROR_TOLERANCE = 1e-3


def mirror_map(positions: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """For each base-mesh index in `vertices`, the base-mesh index of its mirror image among `vertices`."""
    vertices = np.asarray(vertices)
    points = positions[vertices]
    keys = np.round(points / MIRROR_TOLERANCE).astype(np.int64)
    lookup = {tuple(key): vertex for key, vertex in zip(keys.tolist(), vertices.tolist(), strict=True)}
    mirrored = keys * np.array([-1, 1, 1])
    result = np.array([lookup.get(tuple(key), -1) for key in mirrored.tolist()], dtype=np.int64)
    if (result < 0).any():
        missing = vertices[result < 0]
        raise SourceDataError(f"{missing.size} vertices have no mirror image, e.g. {missing[:5].tolist()}")
    return result
