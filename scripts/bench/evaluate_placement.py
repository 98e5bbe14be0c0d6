"""Accuracy of automatic feature point placement against known FPs.

    .venv/bin/python -m scripts.bench.evaluate_placement --heads DIR [--json OUT] [--template NPZ] [--dump DIR]

Every .blend in DIR holds a face mesh named Head whose 84 FP empties are the truth (the development heads
of `scripts.bench.placement_heads`). Its meshes are read as the operator reads them, placement runs on them
(the empties themselves are not read), and each FP's error is its distance to the truth in millimetres of
the head as made (a head scaled by `placement_heads.BENCH_SCALE` is measured back at its own size). 7.1,
the top of the spine, is scored against its definition (`landmarks.spine_top`: the midpoint of the truth's
ear lobes), not against MakeHuman's head joint marker, which the sample places elsewhere. The skull points
11.1-11.6 are scored against their definitions read off the truth's own mesh (`defined_truth`), as placement
reads them. `--template` places
with another template file (one built with `build_placement_template --leave-out`, docs/auto_placement.md);
`--dump DIR` saves each head's mesh, truth and placement for `scripts.bench.placement_readings`.
Prints the mean, 95th percentile and maximum error per FP and overall, the time each head took, which FPs
hold the errors above the overall 95th percentile (what the p95 is made of), and each FP's mean signed error
along the face's own left, up and forward axes (a slide shows as one large component on every head).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import auto_placement
from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.placement import template
from addon.placement.landmarks import spine_top
from addon.placement.pipeline import place_feature_points
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.skull import read_skull
from addon.placement.symmetry import mid_plane
from scripts.bench.placement_heads import BENCH_SCALE

HEAD = "Head"
LARGE_ERROR = 3.0  # mm: the 95th percentile target; a point this far off should be listed


def measure(path: Path, dump: Path | None = None) -> dict:
    bpy.ops.wm.open_mainfile(filepath=str(path))
    face = bpy.data.objects[HEAD]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    truth_empties = {ob["mpeg4_fp"]: ob for ob in bpy.data.objects if ob.type == "EMPTY" and "mpeg4_fp" in ob}
    truth = np.array([truth_empties[fp_id].matrix_world.translation for fp_id in FP_IDS])
    truth[fp_index("7.1")] = spine_top(truth)
    hidden = [ob for ob in truth_empties.values()]
    objects = [ob for ob in auto_placement.head_objects(bpy.context, face) if ob not in hidden]
    vertices, triangles = auto_placement.world_arrays(objects)
    truth = defined_truth(vertices, triangles, truth)
    start = time.perf_counter()
    placement = place_feature_points(vertices, triangles)
    seconds = time.perf_counter() - start
    factor = float(face.get(BENCH_SCALE, 1.0))
    errors = np.linalg.norm(placement.positions - truth, axis=1) * 1000.0 / factor
    offsets = (placement.positions - truth) @ placement.axes.T * 1000.0 / factor
    if dump is not None:  # what `placement_readings` reads the skin's features off
        dump.mkdir(parents=True, exist_ok=True)
        np.savez(
            dump / f"{path.stem}.npz",
            vertices=vertices,
            triangles=triangles,
            truth=truth,
            placed=placement.positions,
            axes=placement.axes,
            factor=factor,
        )
    return {
        "head": path.name,
        "vertices": int(len(vertices)),
        "seconds": seconds,
        "errors_mm": errors.tolist(),
        "offsets_mm": offsets.tolist(),
        "low_confidence": placement.low_confidence(),
        "estimated": list(placement.estimated),
    }


def defined_truth(vertices: np.ndarray, triangles: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """The truth (84, 3) with the skull points 11.1-11.6 put where their definitions say on the truth's own
    mesh (`skull.read_skull`, in the frame of the truth's own points), as placement reads them: on a bald
    head they are rules, and the FP table's vertices carried by the shape targets no longer satisfy them."""
    plane = mid_plane(truth, np.arange(len(truth)))
    up_hint = truth[fp_index("11.4")] - truth[fp_index("2.1")]
    reference = template.load_template().fp_positions
    return read_skull(vertices, triangles, truth, plane.normal, up_hint, reference, TEMPLATE_AXES)


def summary(errors: np.ndarray) -> dict:
    return {"mean": float(errors.mean()), "p95": float(np.percentile(errors, 95)), "max": float(errors.max())}


def above_p95(errors: np.ndarray) -> dict[str, int]:
    """For `errors` (heads, 84): how many of each FP's errors lie above the overall 95th percentile, largest
    share first (the FPs the p95 is made of)."""
    over = (errors > np.percentile(errors, 95)).sum(axis=0)
    order = np.argsort(-over, kind="stable")
    return {FP_IDS[i]: int(over[i]) for i in order if over[i]}


def listed_against_errors(errors: np.ndarray, listed: list[list[str]], limit: float = LARGE_ERROR) -> dict[str, int]:
    """Whether the low-confidence lists (one per head) name the points that are off: of the errors (heads,
    84) over `limit` mm how many are listed, and how many listed points are within it."""
    named = np.array([[fp_id in set(head) for fp_id in FP_IDS] for head in listed], dtype=bool).reshape(errors.shape)
    large = errors > limit
    return {
        "over": int(large.sum()),
        "over_listed": int((large & named).sum()),
        "listed": int(named.sum()),
        "listed_within": int((named & ~large).sum()),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--heads", type=Path, required=True, help="folder of .blend heads with truth FPs")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--template", type=Path, help="place with this template .npz instead of the shipped one")
    parser.add_argument("--dump", type=Path, help="save each head's mesh, truth and placement here (.npz)")
    args = parser.parse_args()
    if args.template is not None:
        template.TEMPLATE_FILE = args.template
        template.load_template.cache_clear()
    paths = sorted(args.heads.glob("*.blend"))
    if not paths:
        print(f"evaluate_placement: no .blend files in {args.heads}", file=sys.stderr)
        return 1
    addon.register()
    try:
        heads = [measure(path, args.dump) for path in paths]
    finally:
        addon.unregister()
    errors = np.array([head["errors_mm"] for head in heads])  # (heads, 84)
    per_fp = {fp_id: summary(errors[:, i]) for i, fp_id in enumerate(FP_IDS)}
    per_group = {
        group: summary(errors[:, [i for i, fp_id in enumerate(FP_IDS) if fp_id.split(".")[0] == group]].ravel())
        for group in dict.fromkeys(fp_id.split(".")[0] for fp_id in FP_IDS)
    }
    overall = summary(errors.ravel())
    offsets = np.array([head["offsets_mm"] for head in heads]).mean(axis=0)  # (84, 3)
    over = above_p95(errors)
    listing = listed_against_errors(errors, [head["low_confidence"] for head in heads])
    print(f"{'head':32s} {'verts':>7s} {'s':>6s} {'mean':>6s} {'p95':>6s} {'max':>6s}  low confidence")
    for head in heads:
        s = summary(np.array(head["errors_mm"]))
        print(
            f"{head['head']:32s} {head['vertices']:7d} {head['seconds']:6.2f} {s['mean']:6.2f} {s['p95']:6.2f} "
            f"{s['max']:6.2f}  {', '.join(head['low_confidence'])}"
        )
    print(f"\n{'FP':6s} {'mean':>6s} {'p95':>6s} {'max':>6s} {'left':>6s} {'up':>6s} {'fwd':>6s}", end="")
    print(f"   (mm over {len(heads)} heads; left/up/fwd: mean signed error in the face's axes)")
    for (fp_id, s), offset in zip(per_fp.items(), offsets, strict=True):
        print(f"{fp_id:6s} {s['mean']:6.2f} {s['p95']:6.2f} {s['max']:6.2f} " + " ".join(f"{o:6.2f}" for o in offset))
    print(f"\nerrors above the overall p95 ({overall['p95']:.2f} mm), per FP: ", end="")
    print(", ".join(f"{fp_id} {n}" for fp_id, n in over.items()))
    print(
        f"low-confidence lists: {listing['over_listed']} of the {listing['over']} errors over {LARGE_ERROR:g} mm "
        f"listed; {listing['listed_within']} of the {listing['listed']} listed points within it"
    )
    print(f"\n{'group':6s} {'mean':>6s} {'p95':>6s} {'max':>6s}")
    for group, s in per_group.items():
        print(f"{group:6s} {s['mean']:6.2f} {s['p95']:6.2f} {s['max']:6.2f}")
    print(f"{'all':6s} {overall['mean']:6.2f} {overall['p95']:6.2f} {overall['max']:6.2f}")
    if args.json:
        args.json.write_text(
            json.dumps(
                {
                    "overall": overall,
                    "per_group": per_group,
                    "per_fp": per_fp,
                    "above_p95": over,
                    "listing": listing,
                    "heads": heads,
                },
                indent=1,
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
