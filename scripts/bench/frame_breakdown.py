"""What one played frame of the add-on is made of, for docs/speed.md and docs/real_meshes.md.

    .venv/bin/python -m scripts.bench.frame_breakdown [--levels 0 1] [--frames 60]
    .venv/bin/python -m scripts.bench.frame_breakdown --face FACE.blend [--stream S.fap] [--slowest 5]

On the sample head set up as a user has it (the demo stream imported, `bench.prepare`), medians over the
frames of: the whole frame (`scene.frame_set` and the evaluated mesh read back); the same with Deform off
(Blender evaluating the keyed empties, the followers' drivers and the face); the add-on's frame handler
alone; and Blender's two depsgraph passes (the second runs because the handler changed a mesh), as
Blender's own `debug_depsgraph_time` prints them.

`--face`: a face as a user brings it (e.g. `scripts.bench.variants`' remesh_2mm) set up and playing the stream
frame by frame; the CPU time of each stage of every frame (`time.process_time`, which other jobs on the machine do
not lengthen): Planar Bones (`Playback.evaluate`), the lip guard (each call, the rounds inside Unfold Skin's
included), the lids' turn, Unfold Skin (its look at the groups, then `open_folds_guarded` with its guard rounds),
the positions written back, a head on a body's turn taken back from the body (`neck.turn_back`), the add-on's frame
handler as a whole (`live.apply_scene`), and the whole frame (`scene.frame_set`, Blender's own evaluation
included: the whole frame less the handler is Blender's). Printed:
the median of each over the frames in which the face moved, then the `--slowest` frames by CPU time, each stage's
time and the calls of the guard and of Unfold Skin's kernel.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import eyelid_rig, live, rest_shape
from addon.deform import fused, unfold
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


STAGES = (  # (name, module or class, attribute): what `--face` times in each frame
    ("Planar Bones", fused.Playback, "evaluate"),
    ("lip guard", live, "_keep_lips_apart"),
    ("lids' turn", eyelid_rig, "apply"),
    ("Unfold Skin's look", live, "_look"),
    ("Unfold Skin", unfold, "open_folds_guarded"),
    ("kernel unfold", fused, "unfold"),
    ("write back", rest_shape, "write_positions"),
    ("body turned back", live, "turn_back"),
    ("handler", live, "apply_scene"),
)


def stage_times(face_path: Path, stream: Path) -> tuple[list[int], np.ndarray, np.ndarray, list[str]]:
    """Set the face up, import `stream` and play it frame by frame with each of STAGES timed: the frames, (F, S)
    CPU seconds per stage (inclusive: the guard's rounds inside Unfold Skin count in both), (F, S) calls per stage,
    and the names of the stages, the whole frame last."""
    from scripts.bench.variant_playback import _face

    bpy.ops.wm.open_mainfile(filepath=str(face_path))
    _face()  # selected and active: what Set Up Face takes
    bpy.ops.mpeg4.setup_face()
    assert bpy.ops.mpeg4.import_fap(filepath=str(stream)) == {"FINISHED"}
    scene = bpy.context.scene
    spent = np.zeros(len(STAGES))
    calls = np.zeros(len(STAGES), np.int64)
    saved = [getattr(owner, name) for _, owner, name in STAGES]

    def timed(k, function):
        def call(*args, **kwargs):
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                spent[k] += time.process_time() - start
                calls[k] += 1

        return call

    for k, ((_, owner, name), function) in enumerate(zip(STAGES, saved, strict=True)):
        setattr(owner, name, timed(k, function))
    frames, times, counts = [], [], []
    try:
        scene.frame_set(scene.frame_start)
        for frame in range(scene.frame_start + 1, int(np.ceil(scene.frame_end)) + 1):
            spent[:], calls[:] = 0.0, 0
            start = time.process_time()
            scene.frame_set(frame)
            frames.append(frame)
            times.append([*spent, time.process_time() - start])
            counts.append([*calls, 1])
    finally:
        for (_, owner, name), function in zip(STAGES, saved, strict=True):
            setattr(owner, name, function)
    return frames, np.array(times), np.array(counts), [name for name, _, _ in STAGES] + ["whole frame"]


def print_stages(face_path: Path, stream: Path, slowest: int) -> None:
    frames, times, counts, names = stage_times(face_path, stream)
    ms = times * 1000
    moving = counts[:, names.index("write back")] > 0  # the positions were written back: the face moved
    median = np.median(ms[moving], axis=0)
    print(f"{face_path.stem}, {stream.name}: {len(frames)} frames, {int(moving.sum())} moving; CPU ms per stage")
    print("| frame | " + " | ".join(names) + " | whole / moving median |")
    print("|---" * (len(names) + 2) + "|")
    print("| median (moving) | " + " | ".join(f"{m:.2f}" for m in median) + " | 1.0 |")
    for k in np.argsort(-ms[:, -1])[:slowest]:
        cells = [f"{ms[k, s]:.2f} ({counts[k, s]})" if counts[k, s] else "-" for s in range(len(names) - 1)]
        print(f"| {frames[k]} | " + " | ".join(cells) + f" | {ms[k, -1]:.2f} | {ms[k, -1] / median[-1]:.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1], choices=[0, 1, 2])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--face", type=Path, help="a .blend with FPs placed: time each stage of its frames")
    parser.add_argument("--stream", type=Path, default=bench.DEMO)
    parser.add_argument("--slowest", type=int, default=5)
    args = parser.parse_args(argv)
    addon.register()
    if args.face is not None:
        print_stages(args.face, args.stream, args.slowest)
        return 0
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
