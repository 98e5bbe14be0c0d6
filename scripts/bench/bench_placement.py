"""Time automatic feature point placement end to end at about 20k and 100k vertices.

    .venv/bin/python -m scripts.bench.bench_placement [--sizes 0.003 0.0014]

The sample head voxel-remeshed (`variants.voxel_remesh`) at each size, then Place Feature Points Automatically
run as a user runs it (the operator: meshes read, placement, 84 empties made). Prints the vertex count and
the seconds, best of `--repeat` runs, and that run's CPU seconds (`time.process_time`: on a shared machine the
wall time grows with the other jobs' load, the CPU time much less). Targets (issue 24): 5 s at 20k vertices,
15 s at 100k.
"""

from __future__ import annotations

import argparse
import sys
import time

import bpy

import addon
from addon.blender import face_data
from scripts.bench import variants


def time_one(size: float, repeat: int) -> tuple[int, float, float]:
    face = variants.open_unset(variants.SAMPLE)
    for ob in list(face_data.fp_empties(face).values()):
        bpy.data.objects.remove(ob)
    variants.voxel_remesh(face, size)
    best = (float("inf"), float("inf"))
    for _run in range(repeat):
        for ob in list(face_data.fp_empties(face).values()):
            bpy.data.objects.remove(ob)
        bpy.context.view_layer.update()
        face.select_set(True)
        bpy.context.view_layer.objects.active = face
        start, cpu = time.perf_counter(), time.process_time()
        bpy.ops.mpeg4.auto_place_feature_points()
        best = min(best, (time.perf_counter() - start, time.process_time() - cpu))
    return len(face.data.vertices), *best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.003, 0.0014], help="voxel sizes (m)")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    addon.register()
    try:
        for size in args.sizes:
            vertices, seconds, cpu = time_one(size, args.repeat)
            print(f"voxel {1000 * size:.1f} mm: {vertices} vertices, {seconds:.2f} s (CPU {cpu:.2f} s)")
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
