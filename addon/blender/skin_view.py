"""Unfold Skin's view of each face: the `unfold.SkinMesh` of its rest shape and polygons, shared by the membrane
after Planar Bones (`live`) and the one under Elastic Bones' Armature modifier (`elastic_skin`).

Made once (0.06 s at 68k vertices) and kept, by the face's session_uid, while the rest shape and the polygons'
corners are the same: across a rebind, an undo, a bake (which start a new state) and a change of engine, so that a
bake's memory does not grow by it. Dropped when another file loads; faces no longer in the file are dropped when
another face's view is made.
"""

from __future__ import annotations

import bpy
import numpy as np

from ..deform import unfold
from ..deform.folds import fan_triangles
from . import binding_store, face_data

# by session_uid: (rest, polygon sizes, corners, the `unfold.SkinMesh`, [a look kept beside it by `live`])
_views: dict[int, tuple] = {}


def skin_mesh(face, rest: np.ndarray) -> tuple[unfold.SkinMesh, list]:
    """The view of ``face`` with (N, 3) float64 ``rest`` positions, and the one-item slot kept with it (the caller's
    look at the groups it last played, None at first)."""
    sizes, corners = face_data.mesh_corners(face.data)
    made = _views.get(face.session_uid)
    if made is None or not binding_store.same_inputs(made[:3], (rest, sizes, corners)):
        alive = {ob.session_uid for ob in bpy.data.objects if ob.type == "MESH"}
        for gone in [uid for uid in _views if uid not in alive]:  # faces deleted, or replaced by an undo
            del _views[gone]
        made = _views[face.session_uid] = (
            rest,
            sizes,
            corners,
            unfold.prepare(rest, fan_triangles(sizes, corners)[0]),
            [None],
        )
    return made[3], made[4]


def forget() -> None:
    _views.clear()
