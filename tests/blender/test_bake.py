"""Streaming bakes: memory that does not grow with the frame count, no half-written files, frame ranges,
Alembic after a point cache, and the stepping (and cancelling) the bake operator's timer does."""

import resource
import tracemalloc

import bpy
import numpy as np
import pytest

from addon.blender import bake, ops, rest_shape
from addon.errors import Mpeg4Error
from addon.formats.pc2 import HEADER, read_pc2

from .helpers import DEMO_FAP, ModalWindow, evaluated_positions, event, positions, set_up_sample


def _demo(first=20, last=26):
    head = set_up_sample()
    scene = bpy.context.scene
    scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    scene.frame_start, scene.frame_end = first, last
    return head, scene


def _repeat_motion():
    """Make every imported F-curve repeat, so a bake of any length deforms on every frame."""
    for action in bpy.data.actions:
        for layer in action.layers:
            for strip in layer.strips:
                for bag in strip.channelbags:
                    for fcurve in bag.fcurves:
                        fcurve.modifiers.new("CYCLES")
        action.update_tag()  # the depsgraph evaluates a copy of the action


def _live(head, scene, frames) -> dict[int, np.ndarray]:
    out = {}
    for frame in frames:
        scene.frame_set(frame)
        out[frame] = positions(head.data).copy()
    return out


def _failing_at(monkeypatch, call: int):
    """Make reading the deformed positions fail on its `call`-th use (a bake's frame that goes wrong)."""
    calls = {"n": 0}
    read = bake.deformed_positions

    def deformed_positions(mesh):
        calls["n"] += 1
        if calls["n"] == call:
            raise Mpeg4Error("the disk caught fire")
        return read(mesh)

    monkeypatch.setattr(bake, "deformed_positions", deformed_positions)


# ----------------------------------------------------------------------------- point cache


def test_memory_of_a_point_cache_bake_does_not_grow_with_the_frame_count(tmp_path):
    head, scene = _demo()
    _repeat_motion()
    live = _live(head, scene, (24, 1260, 1685))  # the stream's keys span 412 frames: later frames repeat them
    rest = rest_shape.stored_rest(head.data)
    assert not any(np.array_equal(pose, rest) for pose in live.values())
    peaks, resident = {}, {}
    for count in (200, 10_000):  # the 10k frames: a 513 MB cache at the sample's 4,278 vertices
        head.mpeg4_face.enabled = True
        path = tmp_path / f"head{count}.pc2"
        tracemalloc.start()
        try:
            bake.bake_point_cache(bpy.context, head, range(1, count + 1), str(path))
            peaks[count] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        resident[count] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # the process's peak, Blender's too
        assert path.stat().st_size == HEADER.itemsize + count * len(head.data.vertices) * 12
    print(f"peak resident memory grew by {(resident[10_000] - resident[200]) / 2**20:.1f} MiB over the 10,000 frames")
    assert resident[10_000] - resident[200] < 64 * 2**20  # Blender's own memory did not take the frames either
    one_frame = len(head.data.vertices) * 3 * 4  # 51 kB at the sample's 4,278 vertices
    print(f"peak Python memory: 200 frames {peaks[200] / 2**20:.2f} MiB, 10,000 frames {peaks[10_000] / 2**20:.2f} MiB")
    assert peaks[10_000] < peaks[200] + 10 * one_frame  # not 9,800 more frames (503 MB)
    assert peaks[10_000] < 150 * one_frame  # less than even the 200-frame bake's positions would take
    cache = np.memmap(tmp_path / "head10000.pc2", dtype="<f4", mode="r", offset=HEADER.itemsize).reshape(10_000, -1, 3)
    for frame, expected in live.items():
        np.testing.assert_array_equal(cache[frame - 1], expected)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head10000.pc2", "head200.pc2"]


def test_a_bake_failing_midway_leaves_no_file_and_keeps_the_existing_cache(tmp_path, monkeypatch):
    head, scene = _demo()
    path = tmp_path / "head.pc2"
    path.write_bytes(b"the cache from yesterday")
    scene.frame_set(22)
    _failing_at(monkeypatch, call=4)
    with pytest.raises(RuntimeError, match="the disk caught fire"):
        bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(path))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head.pc2"]
    assert path.read_bytes() == b"the cache from yesterday"
    assert head.mpeg4_face.enabled and bake.CACHE_MODIFIER not in head.modifiers
    assert scene.frame_current == 22


def test_a_new_bake_replaces_the_cache_in_one_step(tmp_path):
    head, _scene = _demo()
    path = tmp_path / "head.pc2"
    path.write_bytes(b"the cache from yesterday")
    assert bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(path)) == {"FINISHED"}
    data, start, _rate = read_pc2(str(path))
    assert data.shape == (7, len(head.data.vertices), 3) and start == 20
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head.pc2"]


# ----------------------------------------------------------------------------- Alembic


def test_alembic_after_a_point_cache_plays_the_baked_face(tmp_path):
    head, scene = _demo()
    live = _live(head, scene, (20, 24))
    cache = tmp_path / "head.pc2"
    assert bpy.ops.mpeg4.bake(target="ALEMBIC", filepath=str(cache)) == {"FINISHED"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head.abc", "head.pc2"]
    assert head.modifiers[0].filepath == str(cache)  # the modifier reads the cache where it ended up
    assert head.select_get() and bpy.context.view_layer.objects.active == head  # selection as it was
    before = set(bpy.data.objects)
    assert bpy.ops.wm.alembic_import(filepath=str(tmp_path / "head.abc")) == {"FINISHED"}
    imported = {ob.name: ob for ob in set(bpy.data.objects) - before}
    assert {"Eye_L", "Eye_R", "Teeth_Lower", "Tongue"} < {name.rpartition(".")[0] or name for name in imported}
    face = next(ob for ob in imported.values() if ob.type == "MESH" and len(ob.data.vertices) == len(live[20]))
    for frame, expected in live.items():
        scene.frame_set(frame)
        np.testing.assert_allclose(evaluated_positions(face), expected, atol=1e-5)


def test_a_failed_alembic_export_takes_the_whole_bake_back(tmp_path, monkeypatch):
    head, _scene = _demo()
    (tmp_path / "head.pc2").write_bytes(b"old cache")
    (tmp_path / "head.abc").write_bytes(b"old alembic")
    assert bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(tmp_path / "old.pc2")) == {"FINISHED"}
    head.mpeg4_face.enabled = True
    old_modifier = (head.modifiers[0].name, head.modifiers[0].filepath)

    def export(face, frames, filepath):
        with open(filepath, "wb") as fh:
            fh.write(b"half an Alembic file")
        raise Mpeg4Error("Alembic export failed: out of disk space")

    monkeypatch.setattr(bake, "_export_alembic", export)
    with pytest.raises(RuntimeError, match="out of disk space"):
        bpy.ops.mpeg4.bake(target="ALEMBIC", filepath=str(tmp_path / "head.pc2"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["head.abc", "head.pc2", "old.pc2"]
    assert (tmp_path / "head.pc2").read_bytes() == b"old cache"
    assert (tmp_path / "head.abc").read_bytes() == b"old alembic"
    assert (head.modifiers[0].name, head.modifiers[0].filepath) == old_modifier
    assert head.mpeg4_face.enabled


# ----------------------------------------------------------------------------- shape keys


def test_shape_key_bake_over_a_chosen_frame_range():
    head, scene = _demo(first=1, last=100)
    live = _live(head, scene, range(21, 25))
    scene.frame_set(50)
    assert bpy.ops.mpeg4.bake(target="SHAPE_KEYS", frame_start=21, frame_end=24) == {"FINISHED"}
    keys = head.data.shape_keys.key_blocks
    assert [k.name for k in keys] == ["Basis"] + [f"{bake.BAKED_KEY_PREFIX}{f}" for f in range(21, 25)]
    for frame, expected in live.items():
        np.testing.assert_array_equal(rest_shape.read_key(keys[f"{bake.BAKED_KEY_PREFIX}{frame}"]), expected)
        scene.frame_set(frame)
        np.testing.assert_allclose(evaluated_positions(head), expected, atol=1e-6)
    assert (scene.frame_start, scene.frame_end) == (1, 100)
    np.testing.assert_array_equal(positions(head.data), rest_shape.stored_rest(head.data))


def test_shape_key_bake_failing_midway_takes_its_keys_back(monkeypatch):
    head, scene = _demo()
    scene.frame_set(23)
    posed = positions(head.data).copy()
    _failing_at(monkeypatch, call=5)
    with pytest.raises(RuntimeError, match="the disk caught fire"):
        bpy.ops.mpeg4.bake(target="SHAPE_KEYS")
    assert head.data.shape_keys is None and bake.CREATED_BASIS_PROP not in head.data
    assert not any("MPEG-4 bake" in action.name for action in bpy.data.actions)
    assert head.mpeg4_face.enabled and scene.frame_current == 23
    np.testing.assert_array_equal(positions(head.data), posed)  # the live effect goes on as before


def test_a_second_shape_key_bake_cancelled_keeps_the_first():
    head, scene = _demo()
    assert bpy.ops.mpeg4.bake(target="SHAPE_KEYS", frame_start=20, frame_end=22) == {"FINISHED"}
    names = [k.name for k in head.data.shape_keys.key_blocks]
    action = head.data.shape_keys.animation_data.action
    head.mpeg4_face.enabled = True
    job = bake.ShapeKeyBake(bpy.context, head, range(23, 27))
    job.step(3)
    assert len(head.data.shape_keys.key_blocks) == len(names) + 4  # three frames and the effect's own key
    job.cancel()
    assert [k.name for k in head.data.shape_keys.key_blocks] == [*names, rest_shape.SHAPE_KEY_NAME]
    assert head.data.shape_keys.animation_data.action == action
    baked = [f'key_blocks["{name}"].value' for name in names[1:]]
    assert [fc.data_path for fc in action.layers[0].strips[0].channelbags[0].fcurves] == baked


# ----------------------------------------------------------------------------- the modal bake's steps


@pytest.mark.parametrize("target", ["SHAPE_KEYS", "POINT_CACHE"])
def test_stepping_chunk_by_chunk_then_cancelling_takes_everything_back(tmp_path, target):
    head, scene = _demo()
    scene.frame_set(3)
    if target == "SHAPE_KEYS":
        job = bake.ShapeKeyBake(bpy.context, head, range(20, 27))
    else:
        job = bake.PointCacheBake(bpy.context, head, range(20, 27), str(tmp_path / "head.pc2"))
    for chunk, baked in ((3, 3), (2, 5)):
        job.step(chunk)
        assert job.baked == baked and not job.done
    job.cancel()
    assert list(tmp_path.iterdir()) == []
    assert head.data.shape_keys is None and not bpy.data.actions.get("Head MPEG-4 bake")
    assert head.mpeg4_face.enabled and scene.frame_current == 3


def test_stepping_to_the_end_gives_what_a_bake_in_one_go_gives(tmp_path):
    head, scene = _demo()
    live = _live(head, scene, range(20, 27))
    job = bake.PointCacheBake(bpy.context, head, range(20, 27), str(tmp_path / "head.pc2"))
    while not job.done:
        assert list(tmp_path.iterdir()) == [] or all(p.name.endswith(".part") for p in tmp_path.iterdir())
        job.step(2)
    assert job.baked == 7
    job.finish()
    data, _start, _rate = read_pc2(str(tmp_path / "head.pc2"))
    np.testing.assert_array_equal(data, np.stack(list(live.values())))
    assert not head.mpeg4_face.enabled and head.modifiers[0].name == bake.CACHE_MODIFIER


def _window(job):
    return ModalWindow(ops.MPEG4_OT_bake, job)


def test_the_timer_steps_the_bake_and_finishes_it(tmp_path):
    head, _scene = _demo()
    window = _window(bake.PointCacheBake(bpy.context, head, range(20, 27), str(tmp_path / "head.pc2")))
    results = [window.modal(bpy.context, event(kind)) for kind in ["TIMER", "LEFTMOUSE", "MOUSEMOVE"] + ["TIMER"] * 7]
    assert results == [{"RUNNING_MODAL"}, {"RUNNING_MODAL"}, {"PASS_THROUGH"}] + [{"RUNNING_MODAL"}] * 6 + [
        {"FINISHED"}
    ]
    assert window.progress == [1, 2, 3, 4, 5, 6, 7]
    assert window.texts[0] == "Baking Head: frame 1 of 7   Esc: cancel"
    assert window.texts[-2:] == ["Baking Head: storing the result", None]
    assert window.reports[0][0] == "INFO" and "baked 7 frames" in window.reports[0][1]
    assert [p.name for p in tmp_path.iterdir()] == ["head.pc2"] and not head.mpeg4_face.enabled


def test_esc_cancels_the_bake(tmp_path):
    head, scene = _demo()
    scene.frame_set(5)
    window = _window(bake.ShapeKeyBake(bpy.context, head, range(20, 27)))
    assert window.modal(bpy.context, event("TIMER")) == {"RUNNING_MODAL"}
    assert window.modal(bpy.context, event("ESC")) == {"CANCELLED"}
    assert window.reports == [("WARNING", "Bake cancelled")] and window.texts[-1] is None
    assert head.data.shape_keys is None and not bpy.data.actions.get("Head MPEG-4 bake")
    assert head.mpeg4_face.enabled and scene.frame_current == 5


def test_an_error_in_a_tick_becomes_a_report(tmp_path, monkeypatch):
    head, _scene = _demo()
    window = _window(bake.PointCacheBake(bpy.context, head, range(20, 27), str(tmp_path / "head.pc2")))
    _failing_at(monkeypatch, call=2)
    assert window.modal(bpy.context, event("TIMER")) == {"RUNNING_MODAL"}
    assert window.modal(bpy.context, event("TIMER")) == {"CANCELLED"}
    assert head.mpeg4_face.status == "the disk caught fire"  # shown in the panel
    assert list(tmp_path.iterdir()) == [] and window.texts[-1] is None


def test_without_a_window_the_bake_runs_at_once(tmp_path):
    head, _scene = _demo()
    result = bpy.ops.mpeg4.bake("INVOKE_DEFAULT", target="POINT_CACHE", filepath=str(tmp_path / "head.pc2"))
    assert result == {"FINISHED"}  # not RUNNING_MODAL: there is no window to run a timer in
    assert [p.name for p in tmp_path.iterdir()] == ["head.pc2"] and not head.mpeg4_face.enabled
