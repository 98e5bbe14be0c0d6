"""The two third-party heads with their feature points placed automatically, saved as .blend files for
`scripts.bench.variant_playback` (Set Up Face and the demo streams after automatic placement).

    .venv/bin/python -m scripts.bench.auto_placed_heads OUT_DIR [--heads ../shared/heads] [--ict FaceXModel]
    .venv/bin/python -m scripts.bench.variant_playback OUT_DIR

Each head is imported and placed as `scripts.docs.render_auto_placement` does (a skinned character at rest),
its face renamed Head, and the file saved in OUT_DIR (outside the repository: the heads are not ours to ship).
`--ict DIR`: ICT FaceKit's head too (a check set), built as `scripts.bench.arkit_ict` builds it and placed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy

import addon
from scripts.bench.arkit_ict import build_head
from scripts.docs.render_auto_placement import HEADS, ROOT, place


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--heads", type=Path, default=ROOT.parent / "shared" / "heads")
    parser.add_argument("--ict", type=Path, help="ICT FaceKit's FaceXModel folder: its head as ict.blend too")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    addon.register()
    try:
        for name, (file, face_name, parts) in HEADS.items():
            face, _low, _seconds = place(args.heads / file, face_name, parts)
            if face is None:
                continue
            face.name = "Head"
            bpy.ops.wm.save_as_mainfile(filepath=str(args.out / f"{name}.blend"))
        if args.ict is not None:
            build_head(args.ict)
            if bpy.ops.mpeg4.auto_place_feature_points() == {"FINISHED"}:
                bpy.ops.wm.save_as_mainfile(filepath=str(args.out / "ict.blend"))
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
