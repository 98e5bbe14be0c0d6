"""Shared steps for the scripts' tests: short streams cut from the demo stream, running convert.py."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FACE = ROOT / "sample_blends" / "makehuman_head.blend"
DEMO_FAP = ROOT / "sample_blends" / "demo.fap"


def cut_stream(path: Path, frames: int = 8, numbers=None, fps: str | None = None) -> Path:
    """The demo stream's first `frames` frames, renumbered to `numbers` and at `fps` if given."""
    lines = DEMO_FAP.read_text().splitlines()
    header = lines[0].split()
    header[-2:] = [fps or header[-2], str(frames)]
    body = lines[1 : 1 + 2 * frames]
    if numbers is not None:
        for k, number in enumerate(numbers):
            values = body[2 * k + 1].split()
            body[2 * k + 1] = " ".join([str(number), *values[1:]])
    path.write_text(" ".join(header) + "\n" + "\n".join(body) + "\n")
    return path


def run_convert(*args, timeout: int = 600) -> subprocess.CompletedProcess:
    """`python -m scripts.convert ARGS` from the repository root, through the bpy module."""
    command = [sys.executable, "-m", "scripts.convert", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
