"""Choose Still Skin Around Eyes' radius fractions and smoothing width on the development units, leave-one-out.

    .venv/bin/python -m scripts.bench.still_skin_fractions --targets DIR [--json OUT]

For every point of a small grid of `face_binding.LOCAL_RADIUS_FRACTIONS` (eyes x brows x other upper face x mouth
and jaw) x `face_binding.FOLLOW_SMOOTHING_PER_ES0`, the add-on as `scripts.bench.evaluate --method add_on` plays it
(Set Up Face on the sample head with those values) is scored on every unit: E pooled over the units, the region E
and the faces turned over at 1.0 / 1.5 times the FP motion. Then leave-one-out: each unit, with its left/right twin,
is scored with the grid point that is best (pooled E) on the other units; the pooled E of those scores is the figure
for expressions the choice has not seen, and the grid points so chosen are counted. About 4 minutes.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path

import numpy as np

from addon.deform import face_binding
from addon.mpeg4.control_mesh import BROWS, EYES, MOUTH_AND_JAW, OTHER_UPPER
from scripts.bench import evaluate

# eyes, brows, other upper, mouth and jaw; smoothing width per ES0
GRID = ((0.05, 0.1), (0.3, 0.5), (0.5, 0.7), (1.5,), (0.27, 0.4, 0.55))
PARTS = (EYES, BROWS, OTHER_UPPER, MOUTH_AND_JAW)


def twin(name: str) -> str:
    """The unit's mirror image (left <-> right), or itself."""
    for side, other in (("left", "right"), ("right", "left")):
        if side in name:
            return name.replace(side, other)
    return name


def score_grid(targets: Path) -> dict[tuple[float, ...], dict[str, evaluate.Score]]:
    results = {}
    default = dict(face_binding.LOCAL_RADIUS_FRACTIONS), face_binding.FOLLOW_SMOOTHING_PER_ES0
    try:
        for point in itertools.product(*GRID):
            face_binding.LOCAL_RADIUS_FRACTIONS = dict(zip(PARTS, point, strict=False))
            face_binding.FOLLOW_SMOOTHING_PER_ES0 = point[-1]
            results[point] = score_units(targets)
    finally:
        face_binding.LOCAL_RADIUS_FRACTIONS, face_binding.FOLLOW_SMOOTHING_PER_ES0 = default
    return results


def score_units(targets: Path) -> tuple[dict[str, evaluate.Score], np.ndarray]:
    """The add-on as `evaluate --method add_on` plays it, with `face_binding`'s values as they are now, on every
    unit that moves the head: the scores by unit and the head's regions."""
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    method = evaluate.AddOnMethod(face)
    scores = {}
    for path in evaluate.target_files(targets):
        offsets, fp_offsets = evaluate.target_motion(path, face)
        if np.any(offsets):
            control = face.control_rest + fp_offsets
            deformed = method.evaluate(control)
            folds = evaluate.folds(method, face, control)
            scores[evaluate.target_name(path)] = evaluate.score(deformed, face.rest + offsets, face.rest, folds)
    return scores, face.region


def leave_one_out(results: dict) -> tuple[float, dict]:
    points = list(results)
    units = list(results[points[0]][0])
    errors = np.array([[results[p][0][u].error_sum for u in units] for p in points])
    motion = np.array([results[points[0]][0][u].motion_sum for u in units])
    held_out, chosen = 0.0, {}
    for k, unit in enumerate(units):
        others = np.array([u not in (unit, twin(unit)) for u in units])
        best = int(np.argmin(errors[:, others].sum(axis=1)))
        held_out += errors[best, k]
        chosen[points[best]] = chosen.get(points[best], 0) + 1
    return held_out / motion.sum(), chosen


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", required=True, help="folder of MakeHuman .target(.gz) files")
    parser.add_argument("--json", help="also write the grid's figures to this JSON file")
    args = parser.parse_args()
    results = score_grid(Path(args.targets))
    names = " | ".join(evaluate.REGION_NAMES)
    print(f"| eyes | brows | other upper | mouth and jaw | smoothing | pooled E | {names} | folds 1.0 / 1.5 |")
    print("|" + "---:|" * (7 + len(evaluate.REGION_NAMES)))
    table = {}
    for point, (scores, region) in sorted(results.items(), key=lambda item: evaluate.summary(*item[1])["e_pooled"]):
        s = evaluate.summary(scores, region)
        table[":".join(map(str, point))] = s | {"targets": {n: [x.error_sum, x.motion_sum] for n, x in scores.items()}}
        regions = " | ".join(f"{s['regions'][n]:.3f}" for n in evaluate.REGION_NAMES)
        print(
            f"| {' | '.join(map(str, point))} | {s['e_pooled']:.3f} | {regions} | {s['folds'][0]} / {s['folds'][1]} |"
        )
    pooled, chosen = leave_one_out(results)
    print(f"\nleave-one-unit-and-twin-out pooled E {pooled:.3f}; chosen: {chosen}")
    if args.json:
        Path(args.json).write_text(json.dumps({"grid": table, "leave_one_out": pooled}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
