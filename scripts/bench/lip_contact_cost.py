"""What Keep Lips Apart's contact (`lips.press_apart`) costs a played frame, in CPU time: a face set up and a stream
played frame by frame twice in one process, with the contact and with it replaced by a no-op.

    .venv/bin/python -m scripts.bench.lip_contact_cost FACE.blend [--stream S.fap]

Prints, for each pass, the median and the largest frame (process time, ms) and their ratio, the slowest frames with
how many times the contact ran in each (without it: the no-op's calls), and the contact's own total. Other jobs on
the machine lengthen both passes alike; the two are compared, not taken as the face's cost alone.
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
from scripts.bench.variant_playback import DEFAULT_STREAMS, _face


def play(saved: Path, contact) -> tuple[np.ndarray, list[int], float]:
    """(frame CPU times in ms, the contact's calls per frame, its total ms) over the saved scene's frames."""
    calls = [0, 0.0]

    def counted(guard, out):
        start = time.process_time()
        moved = contact(guard, out)
        calls[0] += 1
        calls[1] += time.process_time() - start
        return moved

    live.press_apart = counted
    bpy.ops.wm.open_mainfile(filepath=str(saved))
    scene = bpy.context.scene
    scene.frame_set(scene.frame_start)
    times, per = [], []
    for frame in range(scene.frame_start + 1, int(np.ceil(scene.frame_end)) + 1):
        before, start = calls[0], time.process_time()
        scene.frame_set(frame)
        times.append(time.process_time() - start)
        per.append(calls[0] - before)
    return np.array(times) * 1000.0, per, calls[1] * 1000.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("face", type=Path)
    parser.add_argument("--stream", type=Path, default=DEFAULT_STREAMS[0])
    args = parser.parse_args(argv)
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=str(args.face))
    _face()
    bpy.ops.mpeg4.setup_face()
    assert bpy.ops.mpeg4.import_fap(filepath=str(args.stream)) == {"FINISHED"}
    saved = Path(tempfile.mkdtemp()) / "set_up.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved), copy=True)
    real = live.press_apart
    try:
        for name, contact in (("with the contact", real), ("without", lambda guard, out: False)):
            times, per, total = play(saved, contact)
            slowest = [(int(k) + 2, round(float(times[k]), 1), per[k]) for k in np.argsort(-times)[:4]]
            print(
                f"{args.face.stem}, {args.stream.name}, {name}: median {np.median(times):.1f} ms, largest "
                f"{times.max():.1f} ms ({times.max() / np.median(times):.1f}x); slowest (frame, ms, contact calls) "
                f"{slowest}; the contact {sum(per)} calls, {total:.0f} ms in all"
            )
    finally:
        live.press_apart = real
        saved.unlink()
        saved.parent.rmdir()
    return 0


if __name__ == "__main__":
    sys.exit(main())
