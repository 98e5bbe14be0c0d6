"""Write the template automatic placement registers to a user's head: `addon/placement/template.npz`.

    .venv/bin/python -m scripts.sample.build_placement_template [--face sample_blends/makehuman_head.blend]

From the sample head: its skin (vertices in the head's own frame, metres, Z up, facing -Y; quads split into
triangles), its 84 FP empties' positions, and for each FP that is a skin vertex that vertex's index (the
FP table places skin, ear and hair points on vertices), so a registered template carries them exactly;
and the same skin decimated (Blender's Collapse decimation, triangles) for the registration to solve on.
"""

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

from addon.deform.folds import fan_triangles
from addon.mpeg4.feature_points import FEATURE_POINTS

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
OUT = ROOT / "addon" / "placement" / "template.npz"
ON_VERTEX = 1e-7  # metres: an FP this close to a vertex is that vertex
COARSE_RATIO = 0.3  # of the faces kept in the decimated skin (about 1,300 vertices)


def _mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", vertices)
    vertices = vertices.reshape(-1, 3)
    sizes = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", sizes)
    corners = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", corners)
    triangles, _owner = fan_triangles(sizes, corners)
    return vertices, triangles


def _decimated(face) -> tuple[np.ndarray, np.ndarray]:
    modifier = face.modifiers.new("template", "DECIMATE")
    modifier.ratio = COARSE_RATIO
    modifier.use_collapse_triangulate = True
    evaluated = face.evaluated_get(bpy.context.evaluated_depsgraph_get())
    arrays = _mesh_arrays(evaluated.to_mesh())
    evaluated.to_mesh_clear()
    face.modifiers.remove(modifier)
    return arrays


def template_arrays(face) -> dict[str, np.ndarray]:
    vertices, triangles = _mesh_arrays(face.data)
    coarse_vertices, coarse_triangles = _decimated(face)
    inverse = face.matrix_world.inverted()
    positions = np.array([inverse @ bpy.data.objects[f"FP {fp.id}"].matrix_world.translation for fp in FEATURE_POINTS])
    distance = np.linalg.norm(vertices[None, :, :] - positions[:, None, :], axis=2)
    on_vertex = np.where(distance.min(axis=1) < ON_VERTEX, distance.argmin(axis=1), -1)
    return {
        "vertices": vertices.astype(np.float32),
        "triangles": triangles.astype(np.int32),
        "fp_positions": positions.astype(np.float32),
        "fp_vertices": on_vertex.astype(np.int32),
        "coarse_vertices": coarse_vertices.astype(np.float32),
        "coarse_triangles": coarse_triangles.astype(np.int32),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--face", type=Path, default=SAMPLE)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    bpy.ops.wm.open_mainfile(filepath=str(args.face))
    arrays = template_arrays(bpy.data.objects["Head"])
    np.savez_compressed(args.out, **arrays)
    placed = int((arrays["fp_vertices"] >= 0).sum())
    print(
        f"{args.out}: {len(arrays['vertices'])} vertices, {placed} of 84 FPs on vertices, "
        f"{len(arrays['coarse_vertices'])} decimated, {args.out.stat().st_size} bytes"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
