"""The sample as the web player plays it: the demo stream's first 31 frames on the sample head, exported by
`scripts/convert.py --engine-face elastic --glb` (Elastic Bones; Blender's own glTF exporter).

    .venv/bin/python -m scripts.web.sample_glb OUT_FOLDER        # writes OUT_FOLDER/demo.glb
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FACE = ROOT / "sample_blends" / "makehuman_head.blend"
STREAM = ROOT / "sample_blends" / "demo.fap"
FRAMES = "0:30"
NEUTRAL_SECONDS = 0.0
OPEN_SECONDS = 0.96  # demo.fap frame 24 at 25 fps: the jaw at its widest in these frames


def export(folder: Path) -> Path:
    """Export the sample into `folder`; returns the .glb. RuntimeError with convert.py's output if it fails."""
    command = [sys.executable, "-m", "scripts.convert", "--face", str(FACE), str(STREAM), "-o", str(folder)]
    command += ["--engine-face", "elastic", "--glb", "--no-video", "--sheet", "0", "--frames", FRAMES]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    glb = Path(folder) / f"{STREAM.stem}.glb"
    if done.returncode != 0 or not glb.is_file():
        raise RuntimeError(f"convert.py --glb failed:\n{done.stdout}{done.stderr}")
    return glb


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="where demo.glb goes")
    print(export(parser.parse_args(argv).folder))
    return 0


if __name__ == "__main__":
    sys.exit(main())
