"""Reader for MakeHuman's Wavefront OBJ base mesh (hm08): positions, UVs, polygons and their groups."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import SourceDataError


@dataclass(frozen=True)
class ObjMesh:
    """A polygon mesh as stored in the OBJ, in MakeHuman's frame (decimetres, Y up, facing +Z).

    `face_offsets[f]:face_offsets[f + 1]` slices `corner_vertices`/`corner_uvs` for polygon f.
    """

    positions: np.ndarray  # (N, 3) float64
    uvs: np.ndarray  # (U, 2) float64
    corner_vertices: np.ndarray  # (C,) int64
    corner_uvs: np.ndarray  # (C,) int64
    face_offsets: np.ndarray  # (F + 1,) int64
    face_groups: np.ndarray  # (F,) int64 index into `group_names`
    group_names: tuple[str, ...]

    def group_faces(self, name: str) -> np.ndarray:
        """Indices of the polygons in group `name`."""
        if name not in self.group_names:
            raise SourceDataError(f"the base mesh has no group {name!r}")
        return np.flatnonzero(self.face_groups == self.group_names.index(name))

    def group_vertices(self, name: str) -> np.ndarray:
        """Sorted indices of the vertices used by the polygons of group `name`."""
        faces = self.group_faces(name)
        return np.unique(np.concatenate([self.face_corners(f) for f in faces]))

    def face_corners(self, face: int) -> np.ndarray:
        return self.corner_vertices[self.face_offsets[face] : self.face_offsets[face + 1]]


def load_obj(path: Path) -> ObjMesh:
    """Parse `v`, `vt`, `f` and `g` records; everything else (comments, `s`, `usemtl`) is ignored."""
    positions, uvs, corner_vertices, corner_uvs, offsets, groups = [], [], [], [], [0], []
    group_names: list[str] = []
    group = -1
    with open(path, encoding="utf-8") as stream:
        for line_number, line in enumerate(stream, 1):
            fields = line.split()
            if not fields:
                continue
            tag = fields[0]
            if tag == "v":
                positions.append([float(v) for v in fields[1:4]])
            elif tag == "vt":
                uvs.append([float(v) for v in fields[1:3]])
            elif tag == "g":
                name = " ".join(fields[1:])
                if name not in group_names:
                    group_names.append(name)
                group = group_names.index(name)
            elif tag == "f":
                if group < 0:
                    raise SourceDataError(f"{path}:{line_number}: polygon before any 'g' record")
                for corner in fields[1:]:
                    parts = corner.split("/")
                    corner_vertices.append(int(parts[0]) - 1)
                    corner_uvs.append(int(parts[1]) - 1 if len(parts) > 1 and parts[1] else -1)
                offsets.append(len(corner_vertices))
                groups.append(group)
    if not positions or len(offsets) < 2:
        raise SourceDataError(f"{path}: no vertices or no polygons")
    return ObjMesh(
        positions=np.asarray(positions, dtype=np.float64),
        uvs=np.asarray(uvs, dtype=np.float64).reshape(-1, 2),
        corner_vertices=np.asarray(corner_vertices, dtype=np.int64),
        corner_uvs=np.asarray(corner_uvs, dtype=np.int64),
        face_offsets=np.asarray(offsets, dtype=np.int64),
        face_groups=np.asarray(groups, dtype=np.int64),
        group_names=tuple(group_names),
    )
