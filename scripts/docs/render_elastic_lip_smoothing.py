"""Close-ups of Elastic Bones at 1.5 times the mouth units' FP motion, faces turned over red
(docs/elastic_lip_smoothing.png: rows the sculpt, before and after the lips' last smoothing, issue 27).

    .venv/bin/python -m scripts.docs.render_elastic_lip_smoothing [--out OUT.png]

Rows: the sculpt; Elastic Bones (shipped weights and trained parameters), driven by the unit's FP motion as
`scripts.bench.evaluate --method elastic_bones` drives it. Columns: mouth-open from three-quarters, from below
and from the front, mouth-corner-puller at the corner, mouth-part-later from the front. The picture's middle
row is this script's bottom row run at commit 4160d65 (before step 5 of `elastic.skinning`). Workbench, 300 px tiles.
"""

from __future__ import annotations

import sys
from pathlib import Path

from scripts.docs.render_elastic_weights import sculpt_and_engine_main

ROOT = Path(__file__).resolve().parents[2]
# (unit, FP motion times, coloured by motion, FP the camera looks at, yaw, pitch, ortho scale)
SHOTS = (
    ("mouth-open", 1.5, False, "2.10", -45.0, 0.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -30.0, -50.0, 0.1),
    ("mouth-open", 1.5, False, "2.3", 0.0, 10.0, 0.08),
    ("mouth-corner-puller", 1.5, False, "2.4", -30.0, 0.0, 0.06),
    ("mouth-part-later", 1.5, False, "2.3", -20.0, 0.0, 0.06),
)


def main(argv=None) -> int:
    return sculpt_and_engine_main(__doc__, ROOT / "docs" / "elastic_lip_smoothing.png", SHOTS, argv)


if __name__ == "__main__":
    sys.exit(main())
