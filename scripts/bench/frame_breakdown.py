"""What one played frame of the add-on is made of, for docs/speed.md.

    .venv/bin/python -m scripts.bench.frame_breakdown [--levels 0 1] [--frames 60]

On the sample head set up as a user has it (the demo stream imported, `bench.prepare`), medians over the
frames of: the whole frame (`scene.frame_set` and the evaluated mesh read back); the same with Deform off
(Blender evaluating the keyed empties, the followers' drivers and the face); the add-on's frame handler
alone; and Blender's two depsgraph passes (the second runs because the handler changed a mesh), as
Blender's own `debug_depsgraph_time` prints them.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time

import bpy
import numpy as np

import addon
from addon.blender import live
from scripts.bench import bench


def _median_ms(samples) -> float:
    return round(1000 * float(np.median(samples)), 2)


def _frames(scene, head, depsgraph, frames: range, out: np.ndarray) -> list[float]:
    times = []
    for frame in frames:
        start = time.perf_counter()
        scene.frame_set(frame)
        bench._read(head, depsgraph, out)
        times.append(time.perf_counter() - start)
    return times


def _depsgraph_passes(scene, frames: range) -> tuple[float, float]:
    """Medians of the first and second depsgraph pass of each frame, read from Blender's own timing lines."""
    read, write = os.pipe()
    saved = os.dup(1)
    os.dup2(write, 1)  # Blender prints the timings from C, to file descriptor 1
    try:
        bpy.app.debug_depsgraph_time = True
        for frame in frames:
            scene.frame_set(frame)
    finally:
        bpy.app.debug_depsgraph_time = False
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(write)
    with os.fdopen(read) as pipe:
        seconds = [float(t) for t in re.findall(r"updated in ([0-9.]+) seconds", pipe.read())]
    return _median_ms(seconds[0::2]), _median_ms(seconds[1::2])


def measure(level: int, frames: int) -> dict:
    head, _ = bench.prepare(level, bench.DEMO)
    scene = bpy.context.scene
    depsgraph = scene.view_layers[0].depsgraph
    out = np.empty(len(head.data.vertices) * 3, np.float32)
    played = range(scene.frame_start + bench.WARM_UP, scene.frame_start + bench.WARM_UP + frames)
    whole = _frames(scene, head, depsgraph, played, out)
    handler = []
    apply_scene = live.apply_scene

    def timed(sc):
        start = time.perf_counter()
        apply_scene(sc)
        handler.append(time.perf_counter() - start)

    live.apply_scene = timed
    try:
        _frames(scene, head, depsgraph, played, out)
    finally:
        live.apply_scene = apply_scene
    first, second = _depsgraph_passes(scene, played)
    head.mpeg4_face.enabled = False
    still = _frames(scene, head, depsgraph, played, out)
    return {
        "vertices": len(head.data.vertices),
        "frame_ms": _median_ms(whole),
        "deform_off_frame_ms": _median_ms(still),
        "handler_ms": _median_ms(handler),
        "first_pass_ms": first,
        "second_pass_ms": second,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1], choices=[0, 1, 2])
    parser.add_argument("--frames", type=int, default=60)
    args = parser.parse_args(argv)
    addon.register()
    print("| vertices | frame (ms) | Deform off (ms) | handler (ms) | first pass (ms) | second pass (ms) |")
    print("|---:|---:|---:|---:|---:|---:|")
    for level in args.levels:
        r = measure(level, args.frames)
        print(
            f"| {r['vertices']} | {r['frame_ms']} | {r['deform_off_frame_ms']} | {r['handler_ms']} | "
            f"{r['first_pass_ms']} | {r['second_pass_ms']} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
