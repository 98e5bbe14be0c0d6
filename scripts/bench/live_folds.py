"""Faces the live add-on turns over while playing .fap streams on the sample head: the whole per-frame path.

    .venv/bin/python -m scripts.bench.live_folds [STREAM.fap ...] [--no-lip-guard] [--no-unfold] [--level 0|1|2]
        [--engine planar|elastic] [--every K] [--json OUT]

Unlike `evaluate_folds` (the deformer alone), this plays each stream as a user does: Set Up Face, Import FAP
Stream with the default options, then every frame of the scene through `scene.frame_set`, the handler's
output read back from the mesh; so the eyelids' turn over the eyeballs, Keep Lips Apart and Unfold Skin are
included. `--engine elastic` switches the face to Elastic Bones before the import and reads the evaluated mesh
(the Armature modifier's output, with Unfold Skin's corrections under it).
`addon.deform.folds` counts the faces whose normal turned against the rest normal and
`addon.deform.overlaps.crossings` the pairs of faces passing through each other (`evaluate_folds.frame_counts`).
Prints, per stream, the frames, the most of each in one frame and the frames with any; `--json OUT` writes
every frame's counts.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_data, rest_shape
from scripts.bench import bench, evaluate_folds


def play(
    path: Path, lip_guard: bool, level: int = 0, unfold_skin: bool = True, every: int = 0, elastic: bool = False
) -> list[dict]:
    """Each frame's counts (`evaluate_folds.frame_counts`: crossings every `every`-th frame, none for 0) of the
    stream `path`, played on the sample head (subdivided `level` times), on Elastic Bones if `elastic`."""
    head, _ = bench.set_up_sample(level)
    if elastic:
        bench._operator(bpy.ops.mpeg4.set_engine, engine="ELASTIC_BONES")
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
        shown = head.evaluated_get(bpy.context.evaluated_depsgraph_get()).data if elastic else mesh
        shown.attributes["position"].data.foreach_get("vector", positions)
        deformed = positions.reshape(-1, 3).astype(np.float64)
        counts.append(evaluate_folds.frame_counts(rest, deformed, fans, every > 0 and frame % every == 0))
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    evaluate_folds.add_arguments(parser)
    parser.add_argument("--no-lip-guard", action="store_true", help="play with Keep Lips Apart off")
    parser.add_argument("--no-unfold", action="store_true", help="play with Unfold Skin off")
    parser.add_argument("--level", type=int, default=0, choices=[0, 1, 2], help="subdivide the sample head first")
    parser.add_argument("--engine", choices=["planar", "elastic"], default="planar")
    args = parser.parse_args(argv)
    addon.register()
    print(evaluate_folds.COLUMNS)
    results = {}
    for path in args.streams or evaluate_folds.default_streams():
        options = {"level": args.level, "unfold_skin": not args.no_unfold, "every": args.every}
        options["elastic"] = args.engine == "elastic"
        counts = play(path, lip_guard=not args.no_lip_guard, **options)
        evaluate_folds.report(evaluate_folds.stream_name(path), counts, results)
    evaluate_folds.write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
