"""Unfold Skin under the Armature modifier: Elastic Bones' folds opened each played frame (the bpy side of
`elastic.membrane`).

With a face on Elastic Bones and Unfold Skin on, every frame whose pose changed is skinned in numpy with the
weights the Armature modifier reads (the skeleton's vertex groups, each vertex's weights divided by their sum as
the modifier does; a vertex in no group stays put), its folds are opened by the membrane, and the moved vertices'
rest positions under the skinning go into the mesh (or into our shape key on a mesh with shape keys), which the
Armature modifier, first in the stack, skins onto the membrane's result. A frame without folds writes nothing, or
the rest shape back once where the frame before had changed it. The rest copy set-up made (`rest_shape`) brings
the mesh back exactly: Deform off, another engine, Remove.

What does not carry the membrane: a glTF export (a skeleton and skin weights; a morph target's shape is fixed, the
per-frame corrections are not) and a file played without this extension; both show the paper's skinning alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import bmesh
import numpy as np

from ..deform import unfold
from ..elastic.membrane import skin_unfolded
from ..elastic.skinning import blended_matrices
from . import face_data, rest_shape, skin_view

ALONE = 1e-4  # the Armature modifier leaves a vertex whose weights sum to no more than this where it is


@dataclass
class _Skin:
    made_from: tuple  # (bone group names, vertex count): made again when they change
    mesh: unfold.SkinMesh
    weights: object  # (N, B + 1) scipy sparse: the bones' columns in skeleton order, then one for "stays put"
    written: np.ndarray | None = None  # (V, 3) float32 rest positions the last frame wrote, at `vertices`
    # None: the mesh holds the rest shape; empty at first, as the mesh may hold an earlier state's corrections
    vertices: np.ndarray | None = field(default_factory=lambda: np.zeros(0, np.intp))


_skins: dict[int, _Skin] = {}  # by the face's session_uid
_at_rest: set[int] = set()  # faces without a state whose mesh was given its rest back (`restore`)


def forget(face=None) -> None:
    if face is None:
        _skins.clear()
        _at_rest.clear()
    else:
        _skins.pop(face.session_uid, None)
        _at_rest.discard(face.session_uid)


def _skin(face, groups: list[str]) -> _Skin:
    from scipy import sparse  # (Elastic Bones is refused without scipy: its skin weights need it)

    mesh = face.data
    made_from = (tuple(groups), len(mesh.vertices))
    skin = _skins.get(face.session_uid)
    if skin is not None and skin.made_from == made_from:
        return skin
    rest = rest_shape.reference_positions(mesh)
    if rest is None or len(rest) != len(mesh.vertices):
        raise LookupError(f"{face.name} has no rest shape: run Set Up Face again")
    read = face_data.group_weights(face, groups)
    weights = np.zeros((len(rest), len(groups) + 1))
    for column, name in enumerate(groups):
        if name in read:
            weights[:, column] = read[name]
    total = weights.sum(axis=1)
    alone = total <= ALONE
    weights[alone] = 0.0
    weights[alone, -1] = 1.0
    weights[~alone] /= total[~alone, None]
    view = skin_view.skin_mesh(face, rest.astype(np.float64))[0]  # the same view as after Planar Bones, if made
    skin = _Skin(made_from, view, sparse.csr_matrix(weights))
    _skins[face.session_uid] = skin
    return skin


def apply(face, groups: list[str], transforms: np.ndarray) -> None:
    """Open this frame's folds: `groups` the skinned bones' vertex group names, (B, 4, 4) their transforms."""
    skin = _skin(face, groups)
    moves = np.concatenate([transforms, np.eye(4)[None]])
    matrices = blended_matrices(skin.weights, moves)
    done = skin_unfolded(skin.mesh, matrices, unfold.frame_steps(skin.mesh.n_vertices))
    if not len(done.vertices) and skin.vertices is None:
        return
    positions = skin.mesh.rest.astype(np.float32)
    written = done.rest.astype(np.float32)
    positions[done.vertices] = written
    rest_shape.write_positions(face.data, positions)
    _at_rest.discard(face.session_uid)
    skin.written, skin.vertices = (written, done.vertices) if len(done.vertices) else (None, None)


def restore(face) -> None:
    """The rest shape back where a frame may have changed it (Unfold Skin turned off): once, then nothing until a
    frame writes again. Without a state (a file just opened) the mesh may hold a saved frame's corrections."""
    skin = _skins.get(face.session_uid)
    if (skin is not None and skin.vertices is None) or (skin is None and face.session_uid in _at_rest):
        return
    rest_shape.restore_rest(face.data)
    if skin is None:
        _at_rest.add(face.session_uid)
    else:
        skin.written = skin.vertices = None


def leave_for_edit_mode(face) -> None:
    """Entering Edit Mode: the vertices the last frame moved under the skinning get their rest back in the edit
    mesh (the membrane pauses while in Edit Mode), so an edit never keeps a frame's correction."""
    skin = _skins.get(face.session_uid)
    if skin is None or skin.vertices is None or skin.written is None:
        return
    vertices, written = skin.vertices, skin.written
    skin.written = skin.vertices = None
    if face.data.shape_keys is not None:  # the corrections are in our own key, not in the edited positions
        return
    bm = bmesh.from_edit_mesh(face.data)
    if len(bm.verts) != skin.mesh.n_vertices:
        return
    bm.verts.ensure_lookup_table()
    for v, co, back in zip(vertices.tolist(), written, skin.mesh.rest[vertices], strict=True):
        vert = bm.verts[v]
        if tuple(vert.co) == tuple(co):  # not yet edited
            vert.co = back
    bmesh.update_edit_mesh(face.data, loop_triangles=False, destructive=False)
