"""The README's web player pictures: `docs/web_player_neutral.png` and `docs/web_player_open.png`.

    .venv/bin/python -m scripts.docs.render_web_player [--glb FILE.glb --neutral 0 --open 0.96] [--out docs/]

Screenshots of the web player (`web/`) in headless Chromium with software WebGL, paused at a neutral and an
open-mouth time; without --glb it plays the sample exported by `convert.py --glb`
(`scripts/web/sample_glb.py`). The browser test takes the same shots. Needs what that test needs (scripts/setup_web.sh).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from scripts.web import sample_glb
from scripts.web.browser import shoot

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--glb", type=Path, help="the file to play (default: the sample, exported afresh)")
    parser.add_argument("--neutral", type=float, default=0.0, help="seconds: the mouth closed")
    parser.add_argument("--open", type=float, default=sample_glb.OPEN_SECONDS, help="seconds: the mouth open")
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    pngs = [(args.neutral, args.out / "web_player_neutral.png"), (args.open, args.out / "web_player_open.png")]
    with tempfile.TemporaryDirectory() as folder:
        glb = args.glb
        if glb is None:
            glb = sample_glb.export(Path(folder))
        report = shoot(glb, pngs)
    for shot in report["shots"]:
        print(f"{shot['out']}: {shot['seconds']:g} s ({shot['renderer']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
