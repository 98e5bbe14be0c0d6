"""Close-ups of Elastic Bones before and after the jaw joined step 5's smoothing (docs/elastic_jaw_smoothing.png).

    .venv/bin/python -m scripts.docs.render_elastic_jaw_smoothing [--out docs/elastic_jaw_smoothing.png]

Rows: the sculpt; Elastic Bones as before (`skinning.SMOOTHED_WITH_LIPS` empty: step 5 on the lips alone, and
`LINING_REACH` 0.5); as shipped (the jaw in step 5, LINING_REACH 0.75). Both engine rows use the shipped trained
parameters, driven by the unit's FP motion as
`scripts.bench.evaluate --method elastic_bones` drives it. Columns: mouth-open at 1.5 times its FP motion from
three-quarters, from below and from the side (faces turned over red); a brow lowering (eyebrows-left-down) at
1.5 times, coloured by motion (dark blue still, red at the sculpt's largest motion) and plain. Workbench, 300 px tiles.
"""

from __future__ import annotations

import sys
from pathlib import Path

from scripts.docs.render_elastic_weights import before_after_main

ROOT = Path(__file__).resolve().parents[2]
# (unit, FP motion times, coloured by motion, FP the camera looks at, yaw, pitch, ortho scale)
SHOTS = (
    ("mouth-open", 1.5, False, "2.10", -45.0, 0.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -30.0, -50.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -90.0, 0.0, 0.12),
    ("eyebrows-left-down", 1.5, True, "4.3", 0.0, 0.0, 0.08),
    ("eyebrows-left-down", 1.5, False, "4.3", -20.0, 0.0, 0.08),
)


def main(argv=None) -> int:
    settings = (("before", {"SMOOTHED_WITH_LIPS": (), "LINING_REACH": 0.5}), ("after", {}))
    return before_after_main(__doc__, ROOT / "docs" / "elastic_jaw_smoothing.png", SHOTS, settings, argv)


if __name__ == "__main__":
    sys.exit(main())
