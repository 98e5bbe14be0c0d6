"""Baking and rendering the sample head (with the conversion script's camera and render helpers);
the conversion script itself is tested in `tests/scripts/test_convert.py`."""

import bpy
import numpy as np

from addon.blender import rest_shape
from addon.formats.pc2 import read_pc2
from scripts import convert

from .helpers import DEMO_FAP, evaluated_positions, positions, set_up_sample


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
