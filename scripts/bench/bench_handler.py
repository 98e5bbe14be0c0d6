"""Per-frame cost of the live effect on the sample head at subdivision levels 0, 1 and 2.

    .venv/bin/python -m scripts.bench.bench_handler [--frames 100]

For each level: subdivide the head (Catmull-Clark, applied), set it up, import the demo stream, then
step through the frames and time (a) the extension's frame handler alone (read the control empties,
evaluate Planar Bones, write float32 positions) and (b) the whole `scene.frame_set` (Blender's own
animation and depsgraph evaluation included). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import live
from addon.mpeg4.fap_file import FapStream, write_fap
from scripts.sample.make_demo_fap import demo_stream

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
DEMO = ROOT / "sample_blends" / "demo.fap"


def prepare(level: int):
    bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
    head = bpy.data.objects["Head"]
    bpy.context.view_layer.objects.active = head
    head.select_set(True)
    bpy.ops.mpeg4.remove_face()
    if level:
        mod = head.modifiers.new("subdivide", "SUBSURF")
        mod.levels = level
        bpy.ops.object.modifier_apply(modifier=mod.name)
    start = time.perf_counter()
    bpy.ops.mpeg4.setup_face()
    setup = time.perf_counter() - start
    bpy.context.scene.render.fps = 25
    bpy.ops.mpeg4.import_fap(filepath=str(DEMO))
    return head, setup


def measure(head, frames: int) -> tuple[float, float]:
    scene = bpy.context.scene
    handler, total = [], []
    original = live.on_frame_change

    def timed(scene, depsgraph=None):
        t = time.perf_counter()
        original(scene, depsgraph)
        handler.append(time.perf_counter() - t)

    handlers = bpy.app.handlers.frame_change_post
    index = handlers.index(original)
    handlers[index] = timed
    try:
        for frame in range(1, frames + 1):
            t = time.perf_counter()
            scene.frame_set(frame)
            total.append(time.perf_counter() - t)
    finally:
        handlers[handlers.index(timed)] = original
    return float(np.median(handler)), float(np.median(total))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100)
    args = parser.parse_args(argv)
    addon.register()
    print(f"`.venv/bin/python -m scripts.bench.bench_handler --frames {args.frames}` (median over frames)\n")
    print("| level | vertices | set-up (s) | handler per frame (ms) | handler fps | frame_set per frame (ms) |")
    print("|---|---|---|---|---|---|")
    for level in (0, 1, 2):
        head, setup = prepare(level)
        handler, total = measure(head, args.frames)
        print(
            f"| {level} | {len(head.data.vertices)} | {setup:.2f} | {handler * 1e3:.2f} | {1 / handler:.0f} | "
            f"{total * 1e3:.2f} |",
            flush=True,
        )
    print()
    print(import_export_timing())
    return 0


def import_export_timing(frames: int = 10_000) -> str:
    """Import and export of a long stream (the demo repeated) on the sample head."""
    demo = demo_stream()
    repeat = np.resize(np.arange(len(demo.values)), frames)
    stream = FapStream(
        "2.1",
        "long",
        demo.fps,
        np.arange(frames),
        demo.mask[repeat],
        demo.values[repeat],
        np.zeros((frames, 4)),
        np.zeros((frames, 6)),
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.fap"
        write_fap(stream, path)
        bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
        bpy.context.view_layer.objects.active = bpy.data.objects["Head"]
        bpy.context.scene.render.fps = 25
        start = time.perf_counter()
        bpy.ops.mpeg4.import_fap(filepath=str(path))
        imported = time.perf_counter() - start
        start = time.perf_counter()
        bpy.ops.mpeg4.export_fap(filepath=str(Path(tmp) / "out.fap"), frame_start=1, frame_end=frames)
        exported = time.perf_counter() - start
    return f"{frames}-frame stream: import (keys 84 empties + head) {imported:.2f} s, export {exported:.2f} s"


if __name__ == "__main__":
    sys.exit(main())
