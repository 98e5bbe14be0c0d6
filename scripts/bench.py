"""Planar Bones against Blender's Surface Deform on the sample head: bind time and per-frame time.

    /work/venv/bin/python scripts/bench.py [--face sample_blends/makehuman_head.blend] [--frames 60]
        [--levels 0 1 2] [--cover face all]

The head is subdivided (Catmull-Clark, a Subdivision Surface modifier applied to a copy) to each level;
both deformers run in this one process on that mesh against the same control mesh (the template's FPs;
Planar Bones with the lip and eyelid masks from the vertex groups, which the subdivision interpolates).
Planar Bones is bound once per coverage choice (`bind(cover=...)`): `face`, the vertices over the control
mesh (as in `scripts/evaluate.py`, the more accurate choice there), and `all`, every vertex (the
`bind` default), which raises border radii to reach scalp and neck and so binds ~6x more pairs. The
control mesh follows a smooth FP animation of a few millimetres per point; each figure is the median
over the frames, after two warm-up frames.

* PB bind: `planar_bones.bind` (float64) including the evaluation arrays a binding builds.
* PB frame: `evaluate(binding, control, out=float32 buffer)` + `position` attribute `foreach_set`
  (float32) + `mesh.update()`: the add-on's per-frame work, ending with new positions in the mesh.
* PB frame + depsgraph: the same + `depsgraph.update()`, so Blender has also evaluated the mesh.
* SD frame: move the 57 control-mesh vertices (`foreach_set` float32 + `mesh.update()`),
  `depsgraph.update()` (evaluates the control mesh and the Surface Deform modifier), then read the
  evaluated positions with `evaluated_get(depsgraph)` + `foreach_get` into a float32 buffer.

The SD frame includes a depsgraph evaluation of the deformed object that the PB frame leaves to Blender's
next redraw, so the fair ratio is the one with "PB frame + depsgraph"; both ratios are printed.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "scripts")]

import bpy  # noqa: E402
from evaluate import (  # noqa: E402
    DEFAULT_FACE,
    FACE_COVER_DISTANCE,
    SampleFace,
    load_face,
    read_vertices,
    surface_deform_control,
    vertex_masks,
)
from surface_deform import SurfaceDeform, copy_object, write_positions  # noqa: E402

from addon.deform.planar_bones import bind, cover_over_control_mesh, evaluate  # noqa: E402
from addon.mpeg4.control_mesh import TRIANGLE_MASKS  # noqa: E402

WARM_UP = 2


def subdivided(face: SampleFace, level: int) -> bpy.types.Object:
    """A copy of the head with a Catmull-Clark Subdivision Surface modifier of `level` applied."""
    obj = copy_object(face.head, f"Head level {level}")
    if level:
        modifier = obj.modifiers.new("Subdivision", "SUBSURF")
        modifier.subdivision_type = "CATMULL_CLARK"
        modifier.levels = level
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_apply(modifier=modifier.name)
    return obj


def animation(control_rest: np.ndarray, frames: int) -> np.ndarray:
    """(frames, M, 3) smooth motion of each FP, up to 4 mm, every point with its own phase."""
    rng = np.random.default_rng(7)
    phase = rng.uniform(0.0, 2.0 * np.pi, control_rest.shape)
    amplitude = rng.uniform(0.001, 0.004, control_rest.shape)
    t = np.arange(frames)[:, None, None] / 24.0
    return control_rest + amplitude * np.sin(2.0 * np.pi * 0.7 * t + phase)


def median_ms(frame, positions: np.ndarray) -> float:
    for control in positions[:WARM_UP]:
        frame(control)
    times = []
    for control in positions[WARM_UP:]:
        start = time.perf_counter()
        frame(control)
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def bench_planar_bones(
    face: SampleFace, obj: bpy.types.Object, rest: np.ndarray, cover: str, positions: np.ndarray
) -> dict:
    mesh = obj.data
    masks = vertex_masks(obj)
    start = time.perf_counter()
    covered = (
        cover_over_control_mesh(rest, face.control_rest, face.triangles, FACE_COVER_DISTANCE)
        if cover == "face"
        else None
    )
    binding = bind(
        rest,
        face.control_rest,
        face.triangles,
        vertex_masks=masks,
        triangle_masks=list(TRIANGLE_MASKS),
        cover=covered,
    )
    bind_s = time.perf_counter() - start
    buffer = np.empty((len(rest), 3), np.float32)
    depsgraph = bpy.context.evaluated_depsgraph_get()

    def planar_bones(control: np.ndarray) -> None:
        evaluate(binding, control, out=buffer)
        write_positions(mesh, buffer)

    def planar_bones_evaluated(control: np.ndarray) -> None:
        planar_bones(control)
        depsgraph.update()

    result = {
        "pairs": binding.n_pairs,
        "bind_s": bind_s,
        "frame_ms": median_ms(planar_bones, positions),
        "evaluated_ms": median_ms(planar_bones_evaluated, positions),
    }
    write_positions(mesh, rest.astype(np.float32))
    depsgraph.update()
    return result


def bench_surface_deform(face: SampleFace, obj: bpy.types.Object, level: int, positions: np.ndarray) -> dict:
    control = surface_deform_control(face, f"Control level {level}")
    start = time.perf_counter()
    deform = SurfaceDeform.bind(obj, control, f"Surface Deform level {level}")
    bind_s = time.perf_counter() - start
    buffer = np.empty((len(obj.data.vertices), 3), np.float32)
    depsgraph = bpy.context.evaluated_depsgraph_get()

    def surface_deform(control_positions: np.ndarray) -> None:
        deform.move_control(control_positions)
        depsgraph.update()
        deform.read_deformed(depsgraph, buffer)

    result = {"bind_s": bind_s, "frame_ms": median_ms(surface_deform, positions), "jittered": deform.jittered}
    deform.obj.hide_viewport = True  # keep it out of the later levels' depsgraph updates
    control.hide_viewport = True
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--face", default=str(DEFAULT_FACE))
    parser.add_argument("--frames", type=int, default=60, help="timed frames (at least 50)")
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--cover", nargs="+", default=["face", "all"], choices=["face", "all"])
    args = parser.parse_args()
    if args.frames < 50:
        parser.error("--frames must be at least 50")
    face = load_face(Path(args.face))
    positions = animation(face.control_rest, args.frames + WARM_UP)
    rows = []
    for level in args.levels:
        obj = subdivided(face, level)
        rest = read_vertices(obj.data).astype(np.float64)
        surface = bench_surface_deform(face, obj, level, positions)
        for cover in args.cover:
            rows.append((level, len(rest), cover, bench_planar_bones(face, obj, rest, cover, positions), surface))
        obj.hide_viewport = True

    print(f"`/work/venv/bin/python scripts/bench.py {' '.join(sys.argv[1:])}`".replace(" `", "`"))
    print()
    print(f"Median over {args.frames} frames; control mesh {len(face.control_rest)} FPs, "
          f"{len(face.triangles)} triangles; numpy {np.__version__}, Blender {bpy.app.version_string}.")  # fmt: skip
    print()
    print("| level | vertices | cover | PB pairs | PB bind (s) | SD bind (s) | PB frame (ms) "
          "| PB frame + depsgraph (ms) | SD frame (ms) | PB/SD | (PB + depsgraph)/SD |")  # fmt: skip
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for level, vertices, cover, pb, sd in rows:
        jitter = " (jittered)" if sd["jittered"] else ""
        print(
            f"| {level} | {vertices} | {cover} | {pb['pairs']} | {pb['bind_s']:.3f} | {sd['bind_s']:.3f}{jitter} "
            f"| {pb['frame_ms']:.2f} | {pb['evaluated_ms']:.2f} | {sd['frame_ms']:.2f} "
            f"| {pb['frame_ms'] / sd['frame_ms']:.2f} | {pb['evaluated_ms'] / sd['frame_ms']:.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
