"""Heads as users bring them, made from the sample: other topologies, joined parts, a body, other transforms.

    .venv/bin/python -m scripts.bench.variants OUT [--face FACE.blend] [--only NAME ...]

Writes one .blend per variant into OUT (the sample taken down first with Remove, so each file is a face a
user brings with its FP empties placed, not set up). Each variant is an importable function that takes the
face's mesh object and changes it in place, keeping its FP empties and part objects where they belong:

- `voxel_remesh(face, size)`: the neck closed, then Blender's voxel Remesh (the vertex groups keep their names
  but lose their weights, as the modifier leaves them);
- `decimate(face, ratio)`, `triangulate(face)`, `subdivide(face, jitter)`: other topologies;
- `join_parts(face)`: the eyeballs, teeth and tongue joined into the face (one object, as downloads come);
- `join_body(face)`: a neck and shoulders grown from the neck opening (one connected mesh);
- `scale(face, factor)`: the mesh and everything on it `factor` times larger, in its own coordinates;
- `rotate_y_up(face)`: the mesh data Y-up under a 90° object rotation about X, as a Y-up import leaves it;
- `delete_vertex_groups(face)`, `empty_vertex_groups(face)`: no masks, or masks with no weights.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
HEAD = "Head"


def _apply_modifier(face, kind: str, **settings) -> None:
    modifier = face.modifiers.new(f"variant {kind.lower()}", kind)
    for name, value in settings.items():
        setattr(modifier, name, value)
    with bpy.context.temp_override(object=face, active_object=face, selected_objects=[face]):
        bpy.ops.object.modifier_apply(modifier=modifier.name)


def _edit(face):
    """A BMesh of the face's mesh (bmesh is importable once bpy is)."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(face.data)
    return bmesh, bm


def _boundary_loops(bm) -> list[list]:
    """The mesh's open boundaries, each a list of its edges."""
    boundary = {e for e in bm.edges if e.is_boundary}
    loops = []
    while boundary:
        stack, loop = [boundary.pop()], []
        while stack:
            edge = stack.pop()
            loop.append(edge)
            for v in edge.verts:
                for other in v.link_edges:
                    if other in boundary:
                        boundary.remove(other)
                        stack.append(other)
        loops.append(loop)
    return loops


def _neck_loop(bm) -> list:
    """The neck opening: the open boundary lowest on the head (largest, among equals)."""
    loops = _boundary_loops(bm)
    if not loops:
        raise ValueError("the face has no open boundary (no neck opening)")
    return min(loops, key=lambda loop: (np.mean([v.co.z for e in loop for v in e.verts]), -len(loop)))


def close_neck(face) -> None:
    """Fill the neck opening with one n-gon, so a remesh sees a closed surface."""
    bmesh, bm = _edit(face)
    bmesh.ops.holes_fill(bm, edges=_neck_loop(bm), sides=0)
    bm.to_mesh(face.data)
    bm.free()


def voxel_remesh(face, size: float) -> None:
    """Voxel remesh at `size` (metres in the face's own coordinates), the neck closed first."""
    close_neck(face)
    _apply_modifier(face, "REMESH", mode="VOXEL", voxel_size=size, use_smooth_shade=True)


def decimate(face, ratio: float = 0.5) -> None:
    _apply_modifier(face, "DECIMATE", decimate_type="COLLAPSE", ratio=ratio)


def triangulate(face) -> None:
    _apply_modifier(face, "TRIANGULATE", quad_method="BEAUTY", ngon_method="BEAUTY")


def subdivide(face, jitter: float = 0.25, seed: int = 0) -> None:
    """One cut per edge, then every new vertex moved along the surface by up to `jitter` x its shortest edge (the
    median edge of the mesh moved the lids' fine vertices past their neighbours: folded at rest)."""
    bmesh, bm = _edit(face)
    old = len(bm.verts)
    bmesh.ops.subdivide_edges(bm, edges=list(bm.edges), cuts=1, use_grid_fill=True)
    bm.normal_update()
    bm.verts.ensure_lookup_table()
    rng = np.random.default_rng(seed)
    for v in bm.verts[old:]:
        move = rng.uniform(-1.0, 1.0, 3)
        normal = np.array(v.normal)
        move -= normal * (move @ normal)
        v.co += type(v.co)(move * jitter * min(e.calc_length() for e in v.link_edges))
    bm.to_mesh(face.data)
    bm.free()


PART_NAMES = ("eye", "teeth", "tooth", "tongue")


def join_parts(face) -> list[str]:
    """Join the face's part children (eyeballs, teeth, tongue) into it; returns the names joined."""
    parts = [ob for ob in face.children if ob.type == "MESH" and any(w in ob.name.lower() for w in PART_NAMES)]
    names = [ob.name for ob in parts]
    if parts:
        with bpy.context.temp_override(active_object=face, selected_editable_objects=[face, *parts]):
            bpy.ops.object.join()
    return names


def join_body(face, neck: float = 0.08, shoulders: float = 0.2, depth: float = 0.12) -> None:
    """Grow a neck (`neck` long) and shoulders (`shoulders` to each side, `depth` down) from the neck opening,
    capped at the bottom: one connected mesh, the head on a body."""
    bmesh, bm = _edit(face)
    loop = _neck_loop(bm)

    def extrude(edges, offset, widen=1.0):
        made = bmesh.ops.extrude_edge_only(bm, edges=edges)["geom"]
        verts = [g for g in made if isinstance(g, bmesh.types.BMVert)]
        centre = sum((v.co for v in verts), type(verts[0].co)()) / len(verts)
        for v in verts:
            v.co.x = centre.x + (v.co.x - centre.x) * widen
            v.co.z += offset
        return [g for g in made if isinstance(g, bmesh.types.BMEdge) and g.is_boundary]

    loop = extrude(loop, -neck)
    width = max(v.co.x for e in loop for v in e.verts) - min(v.co.x for e in loop for v in e.verts)
    loop = extrude(loop, -0.03, widen=1.0 + 2.0 * shoulders / max(width, 1e-9))
    loop = extrude(loop, -depth)
    bmesh.ops.holes_fill(bm, edges=loop, sides=0)
    bm.normal_update()
    bm.to_mesh(face.data)
    bm.free()


def _transform_local(face, matrix: Matrix) -> None:
    """Change the face's own coordinates by `matrix`: its mesh and its children's transforms (FP empties and
    parts, children with an identity parent inverse) move with it."""
    face.data.transform(matrix)
    for child in face.children:
        child.matrix_basis = matrix @ child.matrix_basis


def scale(face, factor: float) -> None:
    """The face `factor` times larger in its own coordinates (a mesh modelled in other units)."""
    _transform_local(face, Matrix.Scale(factor, 4))
    for child in face.children:  # a part's mesh is scaled with it, not only its location
        if child.type == "MESH":
            child.data.transform(Matrix.Scale(factor, 4))
            child.scale = (1.0, 1.0, 1.0)
        else:
            child.scale /= factor


def rotate_y_up(face) -> None:
    """Y-up mesh data under a +90° X rotation of the object, as Blender's Y-up importers leave a model: it
    looks the same in the scene, but its own up axis is +Y and it faces +Z."""
    to_y_up = Matrix.Rotation(-math.pi / 2, 4, "X")
    _transform_local(face, to_y_up)
    face.matrix_basis = face.matrix_basis @ to_y_up.inverted()


def delete_vertex_groups(face) -> None:
    face.vertex_groups.clear()


def empty_vertex_groups(face) -> None:
    """Keep the groups' names, drop every weight (what a Remesh or a re-import leaves)."""
    everything = list(range(len(face.data.vertices)))
    for group in face.vertex_groups:
        group.remove(everything)


VARIANTS: dict[str, Callable] = {
    "no_groups": delete_vertex_groups,
    "empty_groups": empty_vertex_groups,
    "remesh_4mm": lambda face: voxel_remesh(face, 0.004),
    "remesh_2mm": lambda face: voxel_remesh(face, 0.002),
    "decimated": decimate,
    "triangulated": triangulate,
    "subdivided": subdivide,
    "joined_parts": join_parts,
    "with_body": join_body,
    "scaled_x10": lambda face: scale(face, 10.0),
    "scaled_x0.01": lambda face: scale(face, 0.01),
    "y_up": rotate_y_up,
}


def open_unset(path: Path):
    """Open `path` and take its face down with Remove (the add-on must be registered): the face as brought."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    face = bpy.data.objects[HEAD]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob == face)
    bpy.context.view_layer.objects.active = face
    if face.mpeg4_face.control_object is not None:
        bpy.ops.mpeg4.remove_face()
    return face


def build(out: Path, face_file: Path = SAMPLE, only: list[str] | None = None) -> list[Path]:
    """Write each variant of the face in `face_file` to OUT/<name>.blend; returns the files."""
    import addon

    addon.register()
    out.mkdir(parents=True, exist_ok=True)
    written = []
    try:
        for name, make in VARIANTS.items():
            if only and name not in only:
                continue
            face = open_unset(face_file)
            make(face)
            path = out / f"{name}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
            print(f"{name}: {len(face.data.vertices)} vertices -> {path}")
            written.append(path)
    finally:
        addon.unregister()
    return written


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder for the variant .blend files")
    parser.add_argument("--face", type=Path, default=SAMPLE, help="the face to vary (an object named Head)")
    parser.add_argument("--only", nargs="*", choices=sorted(VARIANTS), help="make only these variants")
    args = parser.parse_args()
    build(args.out, args.face, args.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
