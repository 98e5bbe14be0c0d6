"""The compiled fast path on the sample faces' own bindings, and the add-on playing with it and without it."""

import bpy
import numpy as np
import pytest

from addon.blender import binding_store, live
from addon.deform import fused
from addon.deform.planar_bones import evaluate

from ..core.test_fused import MODES, assert_matches, motions, needs_kernel, reference
from .helpers import DEMO_FAP, ROOT, open_sample, positions, select

SAMPLES = ("makehuman_head.blend", "makehuman_head_b.blend")


def set_up(name: str = SAMPLES[0]):
    head = open_sample(ROOT / "sample_blends" / name)
    select(head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    return head


def play(head, frame: int) -> np.ndarray:
    bpy.context.scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    bpy.context.scene.frame_set(frame)
    return positions(head.data).copy()


def kernel_layouts(head) -> list:
    return [key for key in binding_store.load(head)._evaluation if isinstance(key, tuple) and key[0] == "fused"]


@needs_kernel
@pytest.mark.parametrize("sample", SAMPLES)
def test_fast_path_equals_the_numpy_reference_on_the_sample_faces(sample):
    binding = binding_store.load(set_up(sample))
    for mode in MODES:
        # the saved binding's float32 local coordinates rebuild the rest shape to within 1e-5 mm; the fast path
        # starts from the rest shape itself, so it may differ from the reference by that much more
        rest_offset = np.abs(reference(binding, binding.control_rest, mode) - binding.rest_vertices)
        assert rest_offset.max() < 1e-8
        for dtype in (np.float64, np.float32):
            for control in motions(binding).values():
                exact = reference(binding, control, mode)
                fast = evaluate(binding, control, mode, out=np.empty(exact.shape, dtype))
                error = assert_matches(fast, exact, rest_offset)
                assert error < 1e-8 or dtype == np.float32  # 1e-5 mm (float32: its own rounding, ~1e-8 m)


@needs_kernel
def test_the_add_on_plays_on_the_kernel_and_switched_off_shows_the_same_frame(monkeypatch):
    head = set_up()
    rest = positions(head.data).copy()
    with_kernel = play(head, 40)
    assert np.abs(with_kernel - rest).max() > 1e-3  # the face moves
    assert kernel_layouts(head) == [("fused", "planar_bones", "float32")]
    monkeypatch.setenv(fused.DISABLE, "1")
    assert live.apply_face(head, force=True)
    # the numpy float32 path rounds its products to about 1e-7 relative
    np.testing.assert_allclose(positions(head.data), with_kernel, rtol=0.0, atol=1e-6)


def test_the_add_on_plays_without_the_kernel(monkeypatch):
    monkeypatch.setenv(fused.DISABLE, "1")
    head = set_up()
    rest = positions(head.data).copy()
    assert np.abs(play(head, 40) - rest).max() > 1e-3
    assert kernel_layouts(head) == []


@needs_kernel
def test_played_frames_equal_frames_evaluated_whole(monkeypatch):
    """The face played frame after frame (the kernel sums only what moved, and the eyelids and lip guard write
    over it) shows, frame by frame, exactly what a whole evaluation of each frame gives; so do jumps back to
    rest, a mode switch and Keep Lips Apart turned off and on."""
    head = set_up()
    scene = bpy.context.scene
    play(head, 1)

    def run(toggle_guard: bool) -> list[np.ndarray]:
        shown = []
        for frame in [*range(30, 75), 1, 1, 200, 40, "soffd", 60, "guard", 61, "planar_bones", 62]:
            if frame in MODES:
                head.mpeg4_face.mode = frame.upper()
                continue
            if frame == "guard":
                if toggle_guard:
                    head.mpeg4_face.keep_lips_apart = False
                    head.mpeg4_face.keep_lips_apart = True
                continue
            scene.frame_set(frame)
            shown.append(positions(head.data).copy())
        return shown

    played = run(toggle_guard=True)
    assert live._states[head.session_uid].playback is not None
    monkeypatch.setattr(live, "playback", lambda *args: None)  # every frame evaluated whole
    live.forget(head)
    whole = run(toggle_guard=False)
    assert max(np.abs(p - played[0]).max() for p in played) > 1e-3
    for k, (a, b) in enumerate(zip(played, whole, strict=True)):
        np.testing.assert_array_equal(a, b, err_msg=f"played frame {k}")


@needs_kernel
def test_the_kernel_guards_the_lips_as_the_numpy_guard_does(monkeypatch):
    """Keep Lips Apart by the compiled kernel (the default) and by its numpy reference give the same played
    frames, to float32 rounding; the demo presses the lips together at frames 72-75."""
    head = set_up()
    scene = bpy.context.scene
    play(head, 1)
    frames = [*range(60, 90), 1, 75]
    calls = []
    guard_into = fused.guard_lips_into

    def counted(*args):
        calls.append(1)
        return guard_into(*args)

    monkeypatch.setattr(fused, "guard_lips_into", counted)
    kernel = []
    for frame in frames:
        scene.frame_set(frame)
        kernel.append(positions(head.data).copy())
    assert len(calls) >= 20  # the kernel's guard ran
    monkeypatch.setattr(fused, "guard_lips_into", lambda *args: None)  # the numpy guard instead
    live.forget(head)
    for frame, expected in zip(frames, kernel, strict=True):
        scene.frame_set(frame)
        np.testing.assert_allclose(positions(head.data), expected, rtol=0.0, atol=2e-7, err_msg=f"frame {frame}")
    head.mpeg4_face.keep_lips_apart = False
    scene.frame_set(75)
    assert np.abs(positions(head.data) - kernel[-1]).max() > 1e-4  # the guard did move the lips there
