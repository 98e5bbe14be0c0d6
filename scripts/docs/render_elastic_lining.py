"""Close-ups of Elastic Bones with the mouth's lining following the jaw (docs/elastic_lining.png).

    .venv/bin/python -m scripts.docs.render_elastic_lining [--out docs/elastic_lining.png]

Rows: the sculpt; Elastic Bones (shipped weights and trained parameters), driven by the unit's FP motion as
`scripts.bench.evaluate --method elastic_bones` drives it. Columns: mouth-open at its FP motion from the front
(into the mouth) and at 1.5 times from three-quarters, plain with the faces turned over painted red; a brow
lowering (eyebrows-left-down) coloured by motion (dark blue still, red at the sculpt's largest motion) and plain
at 1.5 times with its folds red; a brow raise (eyebrows-left-up) coloured by motion, for the region's outline.
Workbench, 300 px tiles. The same shots before this change: docs/elastic_weights_before_after.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

from scripts.docs.render_elastic_weights import sculpt_and_engine_main

ROOT = Path(__file__).resolve().parents[2]
# (unit, FP motion times, coloured by motion, FP the camera looks at, yaw, pitch, ortho scale)
SHOTS = (
    ("mouth-open", 1.0, False, "2.3", 0.0, 10.0, 0.08),
    ("mouth-open", 1.5, False, "2.10", -45.0, 0.0, 0.1),
    ("eyebrows-left-down", 1.0, True, "4.3", 0.0, 0.0, 0.08),
    ("eyebrows-left-down", 1.5, False, "4.3", -30.0, 0.0, 0.08),
    ("eyebrows-left-up", 1.0, True, "4.3", 0.0, 0.0, 0.08),
)


def main(argv=None) -> int:
    return sculpt_and_engine_main(__doc__, ROOT / "docs" / "elastic_lining.png", SHOTS, argv)


if __name__ == "__main__":
    sys.exit(main())
