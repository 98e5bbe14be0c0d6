"""Planar Bones against Blender's Surface Deform on the sample head: bind time and per-frame time.

    /work/venv/bin/python scripts/bench.py [--face sample_blends/makehuman_head.blend] [--frames 60]
        [--levels 0 1 2]

The head is subdivided (Catmull-Clark, a Subdivision Surface modifier applied to a copy) to each level;
both deformers run in this one process on that mesh against the same control mesh (the template's FPs;
Planar Bones with the lip and eyelid masks from the vertex groups, which the subdivision interpolates,
and the add-on's default coverage of every vertex). The control mesh follows a smooth FP animation of a
few millimetres per point; each figure is the median over the frames, after two warm-up frames.

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
from evaluate import DEFAULT_FACE, SampleFace, load_face, read_vertices, surface_deform_control, vertex_masks  # noqa: E402
from surface_deform import SurfaceDeform, copy_object, write_positions  # noqa: E402

from addon.deform.planar_bones import bind, evaluate  # noqa: E402
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


def bench_level(face: SampleFace, level: int, positions: np.ndarray) -> dict:
    obj = subdivided(face, level)
    mesh = obj.data
    rest = read_vertices(mesh).astype(np.float64)
    masks = vertex_masks(obj)
    start = time.perf_counter()
    binding = bind(
        rest, face.control_rest, face.triangles, vertex_masks=masks, triangle_masks=list(TRIANGLE_MASKS)
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

    pb_ms = median_ms(planar_bones, positions)
    pb_evaluated_ms = median_ms(planar_bones_evaluated, positions)
    write_positions(mesh, rest.astype(np.float32))

    control = surface_deform_control(face, f"Control level {level}")
    sd_start = time.perf_counter()
    deform = SurfaceDeform.bind(obj, control, f"Surface Deform level {level}")
    sd_bind_s = time.perf_counter() - sd_start
    sd_buffer = np.empty((len(rest), 3), np.float32)

    def surface_deform(control_positions: np.ndarray) -> None:
        deform.move_control(control_positions)
        depsgraph.update()
        deform.read_deformed(depsgraph, sd_buffer)

    sd_ms = median_ms(surface_deform, positions)
    return {
        "level": level,
        "vertices": len(rest),
        "pairs": binding.n_pairs,
        "pb_bind_s": bind_s,
        "sd_bind_s": sd_bind_s,
        "pb_ms": pb_ms,
        "pb_evaluated_ms": pb_evaluated_ms,
        "sd_ms": sd_ms,
        "sd_jittered": deform.jittered,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--face", default=str(DEFAULT_FACE))
    parser.add_argument("--frames", type=int, default=60, help="timed frames (at least 50)")
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    if args.frames < 50:
        parser.error("--frames must be at least 50")
    face = load_face(Path(args.face))
    positions = animation(face.control_rest, args.frames + WARM_UP)
    rows = [bench_level(face, level, positions) for level in args.levels]

    print(f"`/work/venv/bin/python scripts/bench.py {' '.join(sys.argv[1:])}`".replace(" `", "`"))
    print()
    print(f"Median over {args.frames} frames; control mesh {len(face.control_rest)} FPs, "
          f"{len(face.triangles)} triangles; numpy {np.__version__}, Blender {bpy.app.version_string}.")  # fmt: skip
    print()
    print("| level | vertices | pairs | PB bind (s) | SD bind (s) | PB frame (ms) | PB frame + depsgraph (ms) "
          "| SD frame (ms) | PB/SD | (PB + depsgraph)/SD |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        jitter = " (jittered)" if r["sd_jittered"] else ""
        print(
            f"| {r['level']} | {r['vertices']} | {r['pairs']} | {r['pb_bind_s']:.3f} | {r['sd_bind_s']:.3f}{jitter} "
            f"| {r['pb_ms']:.2f} | {r['pb_evaluated_ms']:.2f} | {r['sd_ms']:.2f} "
            f"| {r['pb_ms'] / r['sd_ms']:.2f} | {r['pb_evaluated_ms'] / r['sd_ms']:.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
