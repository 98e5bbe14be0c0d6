"""Faces that Planar Bones turns over while playing .fap streams on the sample head, bound as the add-on binds.

    .venv/bin/python -m scripts.bench.evaluate_folds [STREAM.fap ...] [--clamp 500] [--face FACE.blend]

Default streams: the demo stream and every real `.fap` in `../shared/interop/fap/`. Each stream is decoded as
Import FAP Stream decodes it (FAP 1/2 through the face tables, masked-out FAPs held, then every low-level
FAP limited to ±CLAMP FAP units, `stream_timing.gain_and_clamp`; head rotation left out, as it turns the
whole object); every frame's FP motion deforms the head, and `addon.deform.folds` counts its faces whose
normal has turned against the rest normal, `addon.deform.overlaps.crossings` its pairs of faces that pass
through each other (skin that overlaps without turning over, which the fold count does not see; every K-th
frame with `--every K`). Prints, per stream, the frames, the largest count of each in a frame and the frames
with any; `--json OUT` writes the counts of every frame, per stream.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import bpy
import numpy as np

from addon.deform import METHODS
from addon.deform.folds import count_inverted
from addon.deform.overlaps import crossings
from addon.mpeg4.decode import fap_to_fp, hold_missing
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.fapu import compute_fapu
from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.mpeg4.stream_timing import gain_and_clamp
from addon.speech.high_level import apply_high_level
from scripts.bench import evaluate

ROOT = Path(__file__).resolve().parents[2]
INTEROP = ROOT.parent / "shared" / "interop" / "fap"
HEAD_FAPS = slice(47, 50)  # head pitch, yaw, roll


def default_streams() -> list[Path]:
    return [ROOT / "sample_blends" / "demo.fap", *sorted(INTEROP.glob("*/*.fap"))]


def stream_positions(path: Path, neutral: np.ndarray, fapu, clamp: float | None) -> np.ndarray:
    """(F, 84, 3) FP positions of every frame of the stream, in head coordinates."""
    stream = read_fap(path)
    mask, values = apply_high_level(
        stream.mask, stream.values, stream.viseme, stream.expression, frame_numbers=stream.frame_numbers
    )
    values = gain_and_clamp(hold_missing(mask, values), mask, 1.0, clamp)
    values[:, HEAD_FAPS] = 0.0
    return fap_to_fp(neutral, values, fapu)


COLUMNS = (
    "| stream | frames | most faces turned over in a frame | frames with any | most crossing pairs in a frame | "
    "frames with any |\n|---|---:|---:|---:|---:|---:|"
)


def frame_counts(rest: np.ndarray, deformed: np.ndarray, fans: tuple, measure_crossings: bool) -> dict:
    """A frame's faces turned over and (when `measure_crossings`) crossing pairs among the faces it moved."""
    counts = {"folds": count_inverted(rest, deformed, *fans)}
    if measure_crossings:
        counts["crossings"] = crossings(deformed, fans[0], np.any(deformed != rest, axis=1))
    return counts


def report(name: str, frames: list[dict], results: dict) -> None:
    """Print a stream's row (`COLUMNS`) and keep its frames' counts in `results` for the JSON."""
    folds = [f["folds"] for f in frames]
    crossed = [f["crossings"] for f in frames if "crossings" in f]
    print(
        f"| {name} | {len(frames)} | {max(folds)} | {sum(1 for c in folds if c)} | {max(crossed, default=0)} | "
        f"{sum(1 for c in crossed if c)} of {len(crossed)} |"
    )
    results[name] = {"folds": folds, "crossings": [f.get("crossings") for f in frames]}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("streams", nargs="*", type=Path, help="the .fap files (default: demo and interop)")
    parser.add_argument("--every", type=int, default=1, help="count crossing pairs every K-th frame")
    parser.add_argument("--json", type=Path, help="write every frame's counts here, per stream")


def write_json(path: Path | None, results: dict) -> None:
    if path is not None:
        path.write_text(json.dumps(results))
        print(f"wrote {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_arguments(parser)
    parser.add_argument("--clamp", type=float, default=500.0, help="largest |FAP value|, in FAP units (0: none)")
    parser.add_argument("--face", default=str(evaluate.DEFAULT_FACE), help="sample .blend with the Head")
    args = parser.parse_args()
    face = evaluate.load_face(Path(args.face))
    empties = {o["mpeg4_fp"]: o for o in bpy.data.collections[f"{evaluate.HEAD} FPs"].objects if "mpeg4_fp" in o}
    neutral = np.array([empties[fp_id].location for fp_id in FP_IDS], dtype=np.float64)
    fapu = compute_fapu({fp_id: np.array(o.location) for fp_id, o in empties.items()})
    rows = [fp_index(fp_id) for fp_id in face.fp_ids]
    params = face.bind_params("planar_bones", 1.0, 2.0, "face")
    deformer = METHODS["planar_bones"](face.rest, face.control_rest, face.triangles, **params)
    clamp = args.clamp or None
    print(f"clamp: {'none' if clamp is None else f'±{clamp:g} FAP units'}")
    print(COLUMNS)
    results = {}
    for path in args.streams or default_streams():
        points = stream_positions(path, neutral, fapu, clamp)[:, rows]
        frames = [
            frame_counts(face.rest, deformer.evaluate(frame), face.fans, k % args.every == 0)
            for k, frame in enumerate(points)
        ]
        report(stream_name(path), frames, results)
    write_json(args.json, results)
    return 0


def stream_name(path: Path) -> str:
    return path.name if path.parent.parent != INTEROP else f"{path.parent.name}/{path.name}"


if __name__ == "__main__":
    sys.exit(main())
