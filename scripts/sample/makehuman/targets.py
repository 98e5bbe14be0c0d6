"""Reader for MakeHuman shape targets (`.target` / `.target.gz`): sparse per-vertex offsets."""

import gzip
from pathlib import Path

import numpy as np

from .errors import SourceDataError


def load_target(path: Path, vertex_count: int) -> np.ndarray:
    """Dense (vertex_count, 3) offsets in the OBJ frame; each data line is `vertex dx dy dz`."""
    opener = gzip.open if path.name.endswith(".gz") else open
    offsets = np.zeros((vertex_count, 3), dtype=np.float64)
    with opener(path, "rt", encoding="utf-8") as stream:
        for line_number, line in enumerate(stream, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if len(fields) != 4:
                raise SourceDataError(f"{path}:{line_number}: expected 'vertex dx dy dz', got {line.strip()!r}")
            vertex = int(fields[0])
            if not 0 <= vertex < vertex_count:
                raise SourceDataError(f"{path}:{line_number}: vertex {vertex} outside the base mesh")
            offsets[vertex] = [float(v) for v in fields[1:]]
    return offsets


def target_name(path: Path) -> str:
    """`mouth-open.target.gz` -> `mouth-open`."""
    return path.name.removesuffix(".gz").removesuffix(".target")
