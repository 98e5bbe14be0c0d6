"""Close-ups of Elastic Bones with and without Unfold Skin after the skinning (docs/elastic_unfold.png).

    .venv/bin/python -m scripts.docs.render_elastic_unfold [--out docs/elastic_unfold.png]

Rows: the sculpt; Elastic Bones' skinning alone (the paper's engine); as the add-on plays it, Unfold Skin's
membrane after the skinning (`addon.elastic.membrane`). Both engine rows use the shipped weights and trained
parameters, driven by the unit's FP motion as `scripts.bench.evaluate --method elastic_bones` drives it. Columns:
mouth-open at 1.0 times its FP motion from three-quarters, at 1.5 times from three-quarters, from below and from
the side, and a smile (mouth-corner-puller) at 1.5 times from three-quarters (faces turned over red). Workbench,
300 px tiles.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from scripts.bench.elastic_bones import ElasticBonesMethod
from scripts.docs.render_elastic_weights import prepare_shots, render_row, save_rows

ROOT = Path(__file__).resolve().parents[2]
# (unit, FP motion times, coloured by motion, FP the camera looks at, yaw, pitch, ortho scale)
SHOTS = (
    ("mouth-open", 1.0, False, "2.10", -45.0, 0.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -45.0, 0.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -30.0, -50.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -90.0, 0.0, 0.12),
    ("mouth-corner-puller", 1.5, False, "2.10", -45.0, 0.0, 0.1),
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "elastic_unfold.png")
    out = parser.parse_args(argv).out
    face, motion, camera = prepare_shots(SHOTS)
    methods = (
        ("the sculpt", None),
        ("skinning alone", ElasticBonesMethod(face, unfold_skin=False)),
        ("with Unfold Skin", ElasticBonesMethod(face)),
    )
    with tempfile.TemporaryDirectory() as tmp:
        rows = [render_row(face, method, SHOTS, motion, camera, label, Path(tmp)) for label, method in methods]
    save_rows(rows, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
