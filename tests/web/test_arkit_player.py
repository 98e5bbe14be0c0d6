"""The web player with the face exported with its ARKit shape keys (`scripts/convert.py --arkit-glb`): holding
jawOpen changes the pixels at the mouth only, eyeBlinkLeft at the face's own left eye only (the viewer's right)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scripts.web.browser import shoot

from .png import read_png
from .test_player import CHANGED, MISSING, MOUTH, _head_box, _region

pytest.importorskip("bpy")  # the .glb is made with Blender's exporter
pytestmark = pytest.mark.skipif(MISSING is not None, reason=MISSING or "")

ROOT = Path(__file__).resolve().parents[2]
FACE = ROOT / "sample_blends" / "makehuman_head.blend"


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> dict[str, np.ndarray]:
    out = tmp_path_factory.mktemp("arkit")
    command = [sys.executable, "-m", "scripts.convert", "--face", str(FACE), "--arkit-glb", "-o", str(out)]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    glb = out / "makehuman_head_arkit.glb"
    assert done.returncode == 0 and glb.is_file(), done.stdout + done.stderr
    pixels = {}
    for morph in ("", "jawOpen:1", "eyeBlinkLeft:1"):
        png = out / f"{morph.split(':')[0] or 'rest'}.png"
        shoot(glb, [(0.0, png)], morph=morph)
        pixels[morph.split(":")[0] or "rest"] = read_png(png)[..., :3].astype(int)
    return pixels


def _changed(shots, name) -> np.ndarray:
    return np.abs(shots[name] - shots["rest"]).max(axis=-1) > CHANGED


def test_jaw_open_changes_the_mouth_and_nothing_above_it(shots):
    box = _head_box(shots["rest"])
    changed = _changed(shots, "jawOpen")
    assert _region(changed, box, *MOUTH).mean() > 0.1
    top, bottom, _left, _right = box
    assert not changed[: (top + bottom) // 2].any()


def test_eye_blink_left_changes_the_faces_left_eye_only(shots):
    top, bottom, left, right = box = _head_box(shots["rest"])
    changed = _changed(shots, "eyeBlinkLeft")
    rows, columns = np.nonzero(changed)
    assert len(rows) > 50
    middle = (left + right) / 2
    assert columns.min() > middle  # the face's left is the viewer's right
    assert top + 0.25 * (bottom - top) < rows.mean() < top + 0.55 * (bottom - top)  # at eye height
    assert not _region(changed, box, *MOUTH).any()
