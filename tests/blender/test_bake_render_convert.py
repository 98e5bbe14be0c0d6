"""Baking, rendering and batch conversion of the sample head."""

import subprocess
import sys

import bpy
import numpy as np
import pytest

from addon.blender import rest_shape
from addon.formats.pc2 import read_pc2

from .helpers import DEMO_FAP, ROOT, evaluated_positions, positions, set_up_sample


def _import_demo():
    head = set_up_sample()
    scene = bpy.context.scene
    scene.render.fps = 25
    bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP))
    scene.frame_start, scene.frame_end = 20, 26  # the jaw opening
    return head, scene


def test_point_cache_bake_plays_the_same_without_the_live_effect(tmp_path):
    head, scene = _import_demo()
    live = {}
    for frame in (20, 23, 26):
        scene.frame_set(frame)
        live[frame] = positions(head.data).astype(np.float64)
    cache = tmp_path / "head.pc2"
    assert bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(cache)) == {"FINISHED"}
    assert not head.mpeg4_face.enabled
    np.testing.assert_array_equal(positions(head.data), rest_shape.stored_rest(head.data))  # base mesh at rest
    data, start, rate = read_pc2(str(cache))
    assert data.shape == (7, len(head.data.vertices), 3) and start == 20 and rate == 1
    assert head.modifiers[0].type == "MESH_CACHE"
    for frame, expected in live.items():
        scene.frame_set(frame)
        np.testing.assert_allclose(evaluated_positions(head), expected, atol=1e-6)


def test_shape_key_bake_plays_the_same_without_the_live_effect():
    head, scene = _import_demo()
    scene.frame_set(24)
    expected = positions(head.data).astype(np.float64)
    assert bpy.ops.mpeg4.bake(target="SHAPE_KEYS") == {"FINISHED"}
    keys = head.data.shape_keys.key_blocks
    assert [k.name for k in keys][:2] == ["Basis", "MPEG-4 frame 20"] and len(keys) == 8
    scene.frame_set(24)
    np.testing.assert_allclose(evaluated_positions(head), expected, atol=1e-6)


def test_workbench_render_shows_the_deformed_face(tmp_path):
    head, scene = _import_demo()
    sys.path.insert(0, str(ROOT / "scripts"))
    import convert

    convert.frame_face(scene, head, 64)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)

    def render(frame):
        return convert.render_frame(scene, frame, tmp_path / f"f{frame}.png")

    rest, open_jaw = render(0), render(25)
    changed = np.abs(rest - open_jaw).max(axis=2) > 0.02
    assert changed.sum() > 20  # the chin and lips moved in the picture
    head.mpeg4_face.enabled = False
    # with the effect off only the teeth behind the lips (driven by FP 9.11) can still differ
    off = np.abs(rest - render(25)).max(axis=2) > 0.02
    assert off.sum() < changed.sum() / 4


@pytest.mark.parametrize("mode", ["bpy-module"])
def test_convert_script_converts_good_streams_and_reports_bad_ones(tmp_path, mode):
    short = tmp_path / "short.fap"
    lines = DEMO_FAP.read_text().splitlines()
    header = lines[0].split()
    short.write_text(" ".join(header[:-1] + ["8"]) + "\n" + "\n".join(lines[1:17]) + "\n")
    bad = tmp_path / "broken.fap"
    bad.write_text("2.1 broken 25 1\n1 0 0\n")
    out = tmp_path / "out"
    face = ROOT / "sample_blends" / "makehuman_head.blend"
    command = [
        sys.executable,
        str(ROOT / "scripts" / "convert.py"),
        "--face",
        str(face),
        str(short),
        str(bad),
        "-o",
        str(out),
        "--resolution",
        "64",
        "--sheet",
        "4",
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "[1/2]" in result.stdout and "short.fap: ok" in result.stdout
    assert "[2/2]" in result.stdout and "broken.fap: FAILED" in result.stdout and "line 2" in result.stdout
    assert "1 converted, 1 failed" in result.stdout
    for name in ("short.abc", "short.mp4", "short_sheet.png", "short.pc2"):
        assert (out / name).stat().st_size > 0
    assert not (out / "broken.abc").exists()


def test_convert_reads_arguments_after_the_double_dash(monkeypatch):
    sys.path.insert(0, str(ROOT / "scripts"))
    import convert

    monkeypatch.setattr(
        sys, "argv", ["blender", "--background", "f.blend", "--python", "convert.py", "--", "a.fap", "-o", "out"]
    )
    args = convert.parse_args(convert.script_argv())
    assert [p.name for p in args.streams] == ["a.fap"] and args.out.name == "out" and args.face is None
