"""Automatic placement in Blender: the head's meshes handed to `placement` as world arrays, and its answer
turned into the FP empties exactly as manual placement makes them (`fp_empties.place`).

The head is the active mesh with its visible mesh children (eyeballs, teeth, tongue as separate objects)
and any other selected meshes; hidden objects (a reference copy, the control mesh) are not read. The
meshes' own data is read, not their evaluated shape (a skinned character is placed at rest, where set-up
binds it), and the empties go where the placement put them, which already snapped the skin points onto that
data: snapping them again onto the shape as shown would mix the two (an Armature modifier that scales a
character's centimetres to metres moved them a hundredfold). Each empty keeps its confidence
(`CONFIDENCE_PROP`); the face keeps the ids of the low ones (`LOW_PROP`), which the panel lists and Place
Feature Points can resume on.
"""

from __future__ import annotations

import numpy as np

from ..deform.folds import fan_triangles
from ..errors import Mpeg4Error
from ..mpeg4.feature_points import FEATURE_POINTS
from . import face_data, fp_empties

CONFIDENCE_PROP = "mpeg4_confidence"
LOW_PROP = "mpeg4_low_confidence"  # on the face: comma-separated FP ids placed with a low confidence
ESTIMATED_PROP = "mpeg4_estimated"  # on the face: FP ids estimated without their part (teeth, tongue, eyeball)


def head_objects(context, face) -> list:
    """The face, its visible mesh children (recursively) and the other selected visible meshes."""
    control = face.mpeg4_face.control_object
    found = [face]
    for ob in [*face.children_recursive, *context.selected_objects]:
        if ob.type == "MESH" and ob not in found and ob != control and ob.visible_get():
            found.append(ob)
    return found


def world_arrays(objects) -> tuple[np.ndarray, np.ndarray]:
    """All the objects' vertices in world space (V, 3) and their polygons as triangles (T, 3)."""
    vertices, triangles, offset = [], [], 0
    for ob in objects:
        mesh = ob.data
        if not len(mesh.polygons):
            continue
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        matrix = np.array(ob.matrix_world)
        vertices.append(co.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3])
        sizes = np.empty(len(mesh.polygons), dtype=np.int64)
        mesh.polygons.foreach_get("loop_total", sizes)
        corners = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", corners)
        fans, _owner = fan_triangles(sizes, corners)
        if np.linalg.det(matrix[:3, :3]) < 0:  # a mirroring transform turns the faces inside out
            fans = fans[:, ::-1]
        triangles.append(fans + offset)
        offset += len(mesh.vertices)
    if not vertices:
        raise Mpeg4Error(f"{objects[0].name} has no faces: automatic placement needs a surface")
    return np.vstack(vertices), np.vstack(triangles)


def apply(face, placement) -> list[str]:
    """Create or move the 84 empties to the placement; returns report lines."""
    for fp, position, confidence in zip(FEATURE_POINTS, placement.positions, placement.confidence, strict=True):
        (empty,) = fp_empties.place(face, fp.id, position, snap=False)
        empty[CONFIDENCE_PROP] = float(confidence)
    low = placement.low_confidence()
    face[LOW_PROP] = ",".join(low)
    face[ESTIMATED_PROP] = ",".join(placement.estimated)
    notes = [f"placed {len(FEATURE_POINTS)} feature points on {face.name}"]
    if low:
        notes.append(f"check {len(low)} low-confidence points: {', '.join(low)}")
    if placement.estimated:
        notes.append(f"estimated without their part: {', '.join(placement.estimated)}")
    return notes


def low_confidence(face) -> list[str]:
    """The FP ids the last automatic placement was unsure of and that still exist as empties."""
    stored = face.get(LOW_PROP, "")
    empties = face_data.fp_empties(face)
    return [fp_id for fp_id in stored.split(",") if fp_id and fp_id in empties] if isinstance(stored, str) else []
