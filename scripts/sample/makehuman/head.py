"""The head cut: head and neck of the hm08 skin plus the eye, teeth and tongue helpers, in Blender's frame."""

from dataclasses import dataclass

import numpy as np

from .obj import ObjMesh

# The neck is narrowest between y = 5.9 and 6.1 dm (x within +-0.5 dm); the shoulders widen below 5.8 dm.
NECK_CUT_Y = 5.9
DECIMETRE = 0.1

# Helper groups carried over as separate objects: object role -> OBJ group.
PART_GROUPS = {
    "eye_left": "helper-l-eye",
    "eye_right": "helper-r-eye",
    "teeth_upper": "helper-upper-teeth",
    "teeth_lower": "helper-lower-teeth",
    "tongue": "helper-tongue",
}
SKIN_GROUP = "body"


def to_blender(points_dm: np.ndarray) -> np.ndarray:
    """MakeHuman (x, y, z) dm, Y up, facing +Z -> Blender (x, -z, y) m, Z up, facing -Y (left stays +X)."""
    points_dm = np.asarray(points_dm, dtype=np.float64)
    return np.stack([points_dm[..., 0], -points_dm[..., 2], points_dm[..., 1]], axis=-1) * DECIMETRE


@dataclass(frozen=True)
class Part:
    """A polygon mesh cut from the base mesh; vertices renumbered, `mh_index` maps back to the base mesh."""

    mh_index: np.ndarray  # (N,) base-mesh vertex index of each vertex
    polygons: np.ndarray  # (F, 4) quads (hm08 is all quads) in local numbering
    corner_uvs: np.ndarray  # (F, 4, 2)

    def positions(self, base_positions_dm: np.ndarray) -> np.ndarray:
        """(N, 3) Blender-frame positions in metres, in the frame of the whole base mesh."""
        return to_blender(base_positions_dm[self.mh_index])


def _part(mesh: ObjMesh, faces: np.ndarray) -> Part:
    corners = np.stack([mesh.corner_vertices[mesh.face_offsets[f] : mesh.face_offsets[f + 1]] for f in faces])
    uv_corners = np.stack([mesh.corner_uvs[mesh.face_offsets[f] : mesh.face_offsets[f + 1]] for f in faces])
    mh_index, local = np.unique(corners, return_inverse=True)
    return Part(
        mh_index=mh_index,
        polygons=local.reshape(corners.shape),
        corner_uvs=mesh.uvs[uv_corners],
    )


def cut_head(mesh: ObjMesh) -> Part:
    """Skin polygons whose corners all lie above the neck cut."""
    faces = mesh.group_faces(SKIN_GROUP)
    corner_y = np.stack([mesh.positions[mesh.face_corners(f), 1] for f in faces])
    return _part(mesh, faces[(corner_y > NECK_CUT_Y).all(axis=1)])


def cut_parts(mesh: ObjMesh) -> dict[str, Part]:
    """The helper objects by role (see `PART_GROUPS`)."""
    return {role: _part(mesh, mesh.group_faces(group)) for role, group in PART_GROUPS.items()}


def joint_centre(mesh: ObjMesh, joint: str) -> np.ndarray:
    """Centre (dm, OBJ frame) of a `joint-*` marker cube of the base mesh."""
    return mesh.positions[mesh.group_vertices(f"joint-{joint}")].mean(axis=0)
