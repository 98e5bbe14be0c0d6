"""Choose the reach of the mouth's falloff over the cheek on the development units, leave-one-out.

    .venv/bin/python -m scripts.bench.mouth_reach --targets DIR [--reaches 0.8 0.9 1.0 1.1 1.2]

For each reach R / ES0 (`face_binding.MOUTH_REACH_PER_ES0`), the add-on as `scripts.bench.evaluate --method add_on`
plays it is scored on every unit: E pooled over the units, the region E and the faces turned over at 1.0 / 1.5 times
the FP motion. Then leave-one-out, as `still_skin_fractions` does: each unit, with its left/right twin, is scored
with the reach that is best (pooled E) on the other units; the pooled E of those scores is the figure for
expressions the choice has not seen, and the reaches so chosen are counted. About 2 minutes a reach.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from addon.deform import face_binding
from scripts.bench import evaluate
from scripts.bench.still_skin_fractions import leave_one_out, score_units


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", required=True, help="folder of MakeHuman .target(.gz) files")
    parser.add_argument("--reaches", type=float, nargs="+", default=[0.8, 0.9, 1.0, 1.1, 1.2])
    args = parser.parse_args()
    shipped, results = face_binding.MOUTH_REACH_PER_ES0, {}
    try:
        for reach in args.reaches:
            face_binding.MOUTH_REACH_PER_ES0 = reach
            results[reach] = score_units(Path(args.targets))
    finally:
        face_binding.MOUTH_REACH_PER_ES0 = shipped
    names = " | ".join(evaluate.REGION_NAMES)
    print(f"| R / ES0 | pooled E | {names} | folds 1.0 / 1.5 |")
    print("|" + "---:|" * (3 + len(evaluate.REGION_NAMES)))
    for reach, (scores, region) in results.items():
        s = evaluate.summary(scores, region)
        regions = " | ".join(f"{s['regions'][n]:.3f}" for n in evaluate.REGION_NAMES)
        print(f"| {reach:g} | {s['e_pooled']:.3f} | {regions} | {s['folds'][0]} / {s['folds'][1]} |")
    pooled, chosen = leave_one_out(results)
    print(f"\nleave-one-unit-and-twin-out pooled E {pooled:.3f}; chosen: {chosen}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
