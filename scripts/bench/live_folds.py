"""Faces the live add-on turns over while playing .fap streams on the sample head: the whole per-frame path.

    .venv/bin/python -m scripts.bench.live_folds [STREAM.fap ...] [--no-lip-guard] [--no-unfold] [--level 0|1|2]

Unlike `evaluate_folds` (the deformer alone), this plays each stream as a user does: Set Up Face, Import FAP
Stream with the default options, then every frame of the scene through `scene.frame_set`, the handler's
output read back from the mesh; so the eyelids' turn over the eyeballs, Keep Lips Apart and Unfold Skin are
included.
`addon.deform.folds` counts the faces whose normal turned against the rest normal. Prints, per stream, the
frames, the most faces turned over in one frame and the frames with any.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_data, rest_shape
from addon.deform.folds import count_inverted
from scripts.bench import bench, evaluate_folds


def play(path: Path, lip_guard: bool, level: int = 0, unfold_skin: bool = True) -> list[int]:
    """Faces turned over in each frame of the stream `path`, played on the sample head (subdivided `level` times)."""
    head, _ = bench.set_up_sample(level)
    bench._operator(bpy.ops.mpeg4.import_fap, filepath=str(path), start_frame=1)
    head.mpeg4_face.keep_lips_apart = lip_guard
    head.mpeg4_face.unfold_skin = unfold_skin
    scene, mesh = bpy.context.scene, head.data
    fans = face_data.mesh_fans(mesh)
    rest = rest_shape.stored_rest(mesh).astype(np.float64)
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    counts = []
    last = int(np.ceil(scene.frame_end))
    for frame in range(scene.frame_start, last + 1):
        scene.frame_set(frame)
        mesh.attributes["position"].data.foreach_get("vector", positions)
        counts.append(count_inverted(rest, positions.reshape(-1, 3).astype(np.float64), *fans))
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("streams", nargs="*", type=Path, help="the .fap files (default: demo and interop)")
    parser.add_argument("--no-lip-guard", action="store_true", help="play with Keep Lips Apart off")
    parser.add_argument("--no-unfold", action="store_true", help="play with Unfold Skin off")
    parser.add_argument("--level", type=int, default=0, choices=[0, 1, 2], help="subdivide the sample head first")
    args = parser.parse_args(argv)
    addon.register()
    print("| stream | frames | most faces turned over in a frame | frames with any |")
    print("|---|---:|---:|---:|")
    for path in args.streams or evaluate_folds.default_streams():
        counts = play(path, lip_guard=not args.no_lip_guard, level=args.level, unfold_skin=not args.no_unfold)
        name = path.name if path.parent.parent != evaluate_folds.INTEROP else f"{path.parent.name}/{path.name}"
        print(f"| {name} | {len(counts)} | {max(counts)} | {sum(1 for c in counts if c)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
