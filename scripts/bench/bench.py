"""Planar Bones against Blender's Surface Deform on the sample head: bind time and per-frame time.

    .venv/bin/python -m scripts.bench.bench [--face sample_blends/makehuman_head.blend] [--frames 60]
        [--levels 0 1 2] [--cover face all]

The head is subdivided (Catmull-Clark, a Subdivision Surface modifier applied to a copy) to each level;
both deformers run in this one process on that mesh against the same control mesh (the template's FPs;
Planar Bones with the lip and eyelid masks from the vertex groups, which the subdivision interpolates).
Planar Bones is bound once per coverage choice (`bind(cover=...)`, see `scripts/bench/evaluate.py`): `face`,
exactly what the add-on binds with (`addon.deform.face_binding`), and `all`, every vertex (the `bind`
default), which raises border radii to reach scalp and neck and so binds ~5x more pairs. The control
mesh follows a smooth FP animation of a few
millimetres per point. At each level everything is bound first, then every frame runs each deformer in
turn (so a load change on the machine hits all figures alike); each figure is the median over the
frames, after two warm-up frames.

* PB bind: computing the cover + `planar_bones.bind` (float64, with the evaluation arrays it builds).
* SD bind: copy the mesh, add the modifier, `surfacedeform_bind` + `view_layer.update()`.
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

import bpy
import numpy as np

from addon.deform.face_binding import FADE_BELOW
from addon.deform.planar_bones import bind, evaluate
from addon.mpeg4.control_mesh import TRIANGLE_MASKS
from scripts.bench.evaluate import (
    COVERS,
    DEFAULT_FACE,
    SampleFace,
    cover_vertices,
    load_face,
    read_vertices,
    surface_deform_control,
    vertex_masks,
)
from scripts.bench.surface_deform import SurfaceDeform, copy_object, write_positions

WARM_UP = 2  # frames run but not timed


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


class PlanarBonesRun:
    """Planar Bones bound on `obj` with one coverage choice; a frame writes the mesh `obj` shows."""

    def __init__(self, face: SampleFace, obj: bpy.types.Object, rest: np.ndarray, cover: str):
        self.cover = cover
        self.mesh = obj.data
        masks = vertex_masks(obj)
        start = time.perf_counter()
        covered = cover_vertices(cover, rest, face)
        self.binding = bind(
            rest,
            face.control_rest,
            face.triangles,
            vertex_masks=masks,
            triangle_masks=list(TRIANGLE_MASKS),
            cover=covered,
            fade_below=FADE_BELOW if cover == "face" else 0.0,
        )
        self.bind_s = time.perf_counter() - start
        self.buffer = np.empty((len(rest), 3), np.float32)

    def frame(self, control: np.ndarray, depsgraph: bpy.types.Depsgraph) -> tuple[float, float]:
        """Seconds for evaluate + write-back, and for the depsgraph update that follows."""
        start = time.perf_counter()
        evaluate(self.binding, control, out=self.buffer)
        write_positions(self.mesh, self.buffer)
        written = time.perf_counter()
        depsgraph.update()
        return written - start, time.perf_counter() - written


class SurfaceDeformRun:
    """Surface Deform on a copy of `obj`, bound to its own copy of the control mesh."""

    def __init__(self, face: SampleFace, obj: bpy.types.Object, level: int):
        control = surface_deform_control(face, f"Control level {level}")
        start = time.perf_counter()
        self.deform = SurfaceDeform.bind(obj, control, f"Surface Deform level {level}")
        self.bind_s = time.perf_counter() - start
        self.buffer = np.empty((len(obj.data.vertices), 3), np.float32)

    def frame(self, control: np.ndarray, depsgraph: bpy.types.Depsgraph) -> float:
        start = time.perf_counter()
        self.deform.move_control(control)
        depsgraph.update()
        self.deform.read_deformed(depsgraph, self.buffer)
        return time.perf_counter() - start

    def hide(self) -> None:
        """Keep this level's objects out of the later levels' depsgraph updates."""
        self.deform.obj.hide_viewport = True
        self.deform.control.hide_viewport = True


def bench_level(face: SampleFace, level: int, covers: list[str], positions: np.ndarray) -> list[dict]:
    """Bind everything on one subdivision level, then time the deformers frame by frame in turn, so a
    load change on the machine affects all of them alike."""
    obj = subdivided(face, level)
    rest = read_vertices(obj.data).astype(np.float64)
    surface = SurfaceDeformRun(face, obj, level)
    runs = [PlanarBonesRun(face, obj, rest, cover) for cover in covers]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    times = {run.cover: [] for run in runs}
    surface_times = []
    for index, control in enumerate(positions):
        for run in runs:
            times[run.cover].append(run.frame(control, depsgraph))
        surface_times.append(surface.frame(control, depsgraph))
        if index < WARM_UP:
            times = {cover: [] for cover in times}
            surface_times = []
    surface.hide()
    obj.hide_viewport = True
    sd_ms = 1e3 * float(np.median(surface_times))
    rows = []
    for run in runs:
        written, updated = np.array(times[run.cover]).T
        rows.append(
            {
                "level": level,
                "vertices": len(rest),
                "cover": run.cover,
                "pairs": run.binding.n_pairs,
                "pb_bind_s": run.bind_s,
                "sd_bind_s": surface.bind_s,
                "sd_jittered": surface.deform.jittered,
                "pb_ms": 1e3 * float(np.median(written)),
                "pb_evaluated_ms": 1e3 * float(np.median(written + updated)),
                "sd_ms": sd_ms,
            }
        )
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--face", default=str(DEFAULT_FACE))
    parser.add_argument("--frames", type=int, default=60, help="timed frames (at least 50)")
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--cover", nargs="+", default=["face", "all"], choices=COVERS)
    args = parser.parse_args()
    if args.frames < 50:
        parser.error("--frames must be at least 50")
    face = load_face(Path(args.face))
    positions = animation(face.control_rest, args.frames + WARM_UP)
    rows = [row for level in args.levels for row in bench_level(face, level, args.cover, positions)]

    print(f"`.venv/bin/python -m scripts.bench.bench {' '.join(sys.argv[1:])}`".replace(" `", "`"))
    print()
    print(
        f"Median over {args.frames} frames; control mesh {len(face.control_rest)} FPs, "
        f"{len(face.triangles)} triangles; numpy {np.__version__}, Blender {bpy.app.version_string}."
    )
    print()
    print(
        "| level | vertices | cover | PB pairs | PB bind (s) | SD bind (s) | PB frame (ms) "
        "| PB frame + depsgraph (ms) | SD frame (ms) | PB/SD | (PB + depsgraph)/SD |"
    )
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        jitter = " (jittered)" if r["sd_jittered"] else ""
        print(
            f"| {r['level']} | {r['vertices']} | {r['cover']} | {r['pairs']} | {r['pb_bind_s']:.3f} "
            f"| {r['sd_bind_s']:.3f}{jitter} | {r['pb_ms']:.2f} | {r['pb_evaluated_ms']:.2f} | {r['sd_ms']:.2f} "
            f"| {r['pb_ms'] / r['sd_ms']:.2f} | {r['pb_evaluated_ms'] / r['sd_ms']:.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
