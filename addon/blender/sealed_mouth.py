"""Open Sealed Mouth's service: find the cut along a sealed mouth (`deform.mouth_cut`), show it, and make it.

The cut changes the mesh (new vertices along the lower lip's side of the cut), so it is made before set-up: a face
that is set up is refused (Remove Set-Up, cut, Set Up Face again). The split is bmesh's: the cut's edges are split
(`split_edges`, which keeps every attribute, vertex group, shape key and UV of the copies), and where more faces
than two met along the cut (welded lips) the copies on one side of the cut are merged again, so each lip keeps one
surface.
"""

from __future__ import annotations

from collections import defaultdict

import bmesh
import numpy as np

from ..deform.mouth_cut import MouthCut, find_mouth_cut
from ..errors import Mpeg4Error
from ..mpeg4.face_frame import face_frame
from . import binding_store, face_data

SIDE_LAYER, ORIGIN_LAYER = "mpeg4_cut_side", "mpeg4_cut_origin"  # bmesh layers while cutting, then removed
UPPER, LOWER = 1, 2


def plan(face) -> MouthCut:
    """The cut along the face's sealed mouth; Mpeg4Error (nothing changed) when there is none to make."""
    if binding_store.is_bound(face):
        raise Mpeg4Error(
            f"{face.name} is set up: Open Sealed Mouth changes the mesh, so Remove Set-Up first, open the mouth, "
            "then run Set Up Face again"
        )
    mesh = face.data
    vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", vertices)
    sizes, corners = face_data.mesh_corners(mesh)
    positions = face_data.local_positions(face, face_data.fp_empties(face))
    return find_mouth_cut(vertices.reshape(-1, 3), sizes, corners, positions, face_frame(positions))


def describe(face, cut: MouthCut) -> str:
    """What the cut is, for the confirmation and the report."""
    edges = len(cut.path) - 1
    return (
        f"{edges} edges of {face.name} from FP 2.4 to FP 2.5 along the crease between the lips "
        f"({cut.length:.3g} units): the lower lip's side gets {len(cut.path) - 2} new vertices"
    )


def show(face, cut: MouthCut) -> list[str]:
    """Select the cut's edges (and only them), so Edit Mode shows where the cut would go; nothing else changes."""
    mesh = face.data
    on = np.zeros(len(mesh.vertices), bool)
    on[cut.path] = True
    edges = face_data.mesh_edges(mesh)
    keys = {tuple(sorted(e)) for e in cut.edges.tolist()}
    selected = np.array([tuple(sorted(e)) in keys for e in edges.tolist()], dtype=bool)
    mesh.vertices.foreach_set("select", on)
    mesh.edges.foreach_set("select", selected)
    mesh.polygons.foreach_set("select", np.zeros(len(mesh.polygons), bool))
    mesh.update()
    return [f"selected the {describe(face, cut)}: Tab into Edit Mode to see them; nothing cut"]


def cut_open(face, cut: MouthCut) -> list[str]:
    """Split the mesh along the cut: the lower side's faces at its inner vertices get copies of them."""
    mesh = face.data
    before = len(mesh.vertices)
    bm = bmesh.new()
    try:
        bm.from_mesh(mesh)
        side = bm.faces.layers.int.new(SIDE_LAYER)
        origin = bm.verts.layers.int.new(ORIGIN_LAYER)
        bm.verts.ensure_lookup_table()
        bm.faces.ensure_lookup_table()
        for vert in bm.verts:
            vert[origin] = vert.index
        for index in cut.upper.tolist():
            bm.faces[index][side] = UPPER
        for index in cut.lower.tolist():
            bm.faces[index][side] = LOWER
        edges = [bm.edges.get((bm.verts[a], bm.verts[b])) for a, b in cut.edges.tolist()]
        if any(edge is None for edge in edges):
            raise Mpeg4Error("the mesh changed since the cut was found: run Open Sealed Mouth again (nothing cut)")
        bmesh.ops.split_edges(bm, edges=edges)
        inner = set(cut.path[1:-1].tolist())
        ends = {int(cut.path[0]), int(cut.path[-1])}
        copies = defaultdict(list)
        for vert in bm.verts:
            if vert[origin] in inner:
                sides = {face_[side] for face_ in vert.link_faces}
                copies[(vert[origin], LOWER if LOWER in sides else UPPER)].append(vert)
            elif vert[origin] in ends:  # the mouth's corners stay one vertex each
                copies[(vert[origin], 0)].append(vert)
        # welded lips: where more than two faces met, bmesh split them all apart; each side's are one surface again
        for verts in copies.values():
            if len(verts) > 1:
                bmesh.ops.pointmerge(bm, verts=verts, merge_co=verts[0].co.copy())
        bm.faces.layers.int.remove(side)
        bm.verts.layers.int.remove(origin)
        bm.to_mesh(mesh)
    finally:
        bm.free()
    mesh.update()
    added = len(mesh.vertices) - before
    return [
        f"cut the mouth open: {len(cut.path) - 1} edges from FP 2.4 to FP 2.5, {added} new vertices on the lower "
        "lip's side (Undo takes it back); run Set Up Face"
    ]
