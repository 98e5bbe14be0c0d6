"""Checks of a parsed stream against the scene (timing, values), made before anything is keyed."""

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from addon.errors import Mpeg4Error
from addon.mpeg4 import stream_timing
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.stream_timing import (
    MAX_KEYS,
    MAX_SPAN_FRAMES,
    MAXFRAME,
    MINFRAME,
    VALUE_LIMIT,
    StreamTimingError,
    StreamValueError,
    check_values,
    gain_and_clamp,
    scene_frames,
)

INTEROP = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap"
DEMO = Path(__file__).resolve().parents[2] / "sample_blends" / "demo.fap"


# --- scene_frames ---------------------------------------------------------------------------------------


def test_the_stream_keeps_its_timing_or_takes_one_scene_frame_per_frame():
    numbers = np.array([0, 5, 10], np.int64)
    np.testing.assert_array_equal(scene_frames(numbers, 25.0, 50.0, 1), [1.0, 11.0, 21.0])
    np.testing.assert_array_equal(scene_frames(numbers, 25.0, 50.0, 1, use_stream_fps=False), [1.0, 6.0, 11.0])
    np.testing.assert_allclose(scene_frames(numbers, 25.0, 24.0, 0), [0.0, 4.8, 9.6])
    assert scene_frames(numbers, 25.0, 24.0, 0).dtype == np.float64


def test_equal_rates_give_whole_frames_exactly():
    numbers = np.arange(100_000)
    np.testing.assert_array_equal(scene_frames(numbers, 29.97, 29.97, 1), numbers + 1.0)


def test_an_empty_stream_has_no_frames():
    assert scene_frames(np.zeros(0, np.int64), 25.0, 24.0, 1).shape == (0,)


@pytest.mark.parametrize("fps", [1e-300, 0.0, -25.0, 0.000999, 10000.5, 1e6, float("nan"), float("inf")])
def test_an_unplayable_stream_fps_is_refused_whatever_the_timing(fps):
    for use_stream_fps in (True, False):
        with pytest.raises(StreamTimingError) as info:
            scene_frames(np.array([0, 1]), fps, 24.0, 1, use_stream_fps=use_stream_fps, source="s.fap")
        assert str(info.value) == (
            f"s.fap: the stream's fps is {fps!r}; a playable stream has 0.001 to 10000 frames per second"
        )


@pytest.mark.parametrize("fps", [0.001, 10000.0])
def test_the_fps_bounds_themselves_play(fps):
    np.testing.assert_allclose(scene_frames(np.array([0, 1]), fps, 24.0, 0), [0.0, 24.0 / fps])


@pytest.mark.parametrize("scene_fps", [0.0, -24.0, float("nan"), float("inf")])
def test_an_impossible_scene_fps_is_refused(scene_fps):
    with pytest.raises(StreamTimingError, match=r"^s\.fap: the scene's fps must be a positive finite number"):
        scene_frames(np.array([0, 1]), 25.0, scene_fps, 1, source="s.fap")


def test_a_frame_beyond_blenders_last_frame_is_named():
    with pytest.raises(StreamTimingError) as info:
        scene_frames(np.array([0, 2**53 - 1]), 25.0, 25.0, 1, source="s.fap")
    assert str(info.value) == (
        "s.fap: frame 9007199254740991 of the stream lands on scene frame 9007199254740992, beyond Blender's "
        "last frame 1048574"
    )


def test_blenders_frame_limits_are_the_bounds():
    assert (MAXFRAME, MINFRAME) == (1_048_574, -1_048_574)
    np.testing.assert_array_equal(scene_frames(np.array([0]), 25.0, 25.0, MAXFRAME), [MAXFRAME])
    np.testing.assert_array_equal(scene_frames(np.array([0]), 25.0, 25.0, MINFRAME), [MINFRAME])
    with pytest.raises(StreamTimingError, match=r"^frame 1 of the stream lands on scene frame 1048575, beyond"):
        scene_frames(np.array([0, 1]), 25.0, 25.0, MAXFRAME)
    with pytest.raises(StreamTimingError) as info:
        scene_frames(np.array([0, 1]), 25.0, 25.0, MINFRAME - 1, source="s.fap")
    assert str(info.value) == (
        "s.fap: frame 0 of the stream lands on scene frame -1048575, before Blender's first frame -1048574"
    )


def test_a_resampled_frame_is_named_with_its_fraction():
    np.testing.assert_allclose(scene_frames(np.array([1_092_264]), 25.0, 24.0, 0), [1_048_573.44])
    with pytest.raises(StreamTimingError, match=r"frame 1092266 of the stream lands on scene frame 1048575.36, "):
        scene_frames(np.array([1_092_266]), 25.0, 24.0, 0)


def test_the_span_may_reach_the_limit_but_not_pass_it():
    assert MAX_SPAN_FRAMES == 1_048_574
    frames = scene_frames(np.array([0, MAX_SPAN_FRAMES]), 25.0, 25.0, -500_000)
    np.testing.assert_array_equal(frames, [-500_000, MAX_SPAN_FRAMES - 500_000])
    with pytest.raises(StreamTimingError) as info:
        scene_frames(np.array([0, MAX_SPAN_FRAMES + 1]), 25.0, 25.0, -500_000, source="s.fap")
    assert str(info.value) == (
        "s.fap: the stream spans 1048575 scene frames (from -500000 to 548575); one import may span at most 1048574"
    )


def test_far_apart_frames_are_two_frames_and_nothing_is_allocated_per_scene_frame():
    tracemalloc.start()
    try:
        frames = scene_frames(np.array([0, 1_000_000]), 1000.0, 24.0, 0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(frames, [0.0, 24_000.0])
    assert peak < 10_000


def test_more_frames_than_one_import_may_key_are_refused_first(monkeypatch):
    assert MAX_KEYS == 2_000_000
    monkeypatch.setattr(stream_timing, "MAX_KEYS", 10)
    np.testing.assert_array_equal(scene_frames(np.arange(10), 25.0, 25.0, 0), np.arange(10.0))
    with pytest.raises(StreamTimingError) as info:
        scene_frames(np.arange(11), 1e-300, 25.0, 0, source="s.fap")  # before the fps is even looked at
    assert str(info.value) == "s.fap: the stream has 11 frames; at most 10 can be imported at once: split the file"


def test_all_errors_are_user_errors():
    assert issubclass(StreamTimingError, Mpeg4Error) and issubclass(StreamValueError, Mpeg4Error)


# --- gain_and_clamp -------------------------------------------------------------------------------------


def test_gain_scales_and_clamp_limits_the_low_level_faps_only():
    values = np.zeros((2, 68))
    values[0, :5] = [7, 9, 300, -500, 0.5]
    values[1, 2] = 300  # masked out below: a held value, which must scale with the value it holds
    mask = np.zeros((2, 68), bool)
    mask[0, :5] = True
    out = gain_and_clamp(values, mask, gain=2.0, clamp=800.0)
    np.testing.assert_array_equal(out[0, :5], [7, 9, 600, -800, 1.0])
    assert out[1, 2] == 600
    assert values[0, 2] == 300 and out is not values  # a new array; the input is left alone
    np.testing.assert_array_equal(gain_and_clamp(values, mask), values)


def test_clamp_tames_values_that_overflow_under_the_gain():
    values = np.zeros((1, 68))
    values[0, 2] = 1e308
    out = gain_and_clamp(values, values != 0, gain=10.0, clamp=1000.0)
    assert out[0, 2] == 1000.0


@pytest.mark.parametrize(
    ("gain", "clamp", "message"),
    [
        (-1.0, None, "Gain must be a finite number of at least 0, found -1.0"),
        (float("nan"), None, "Gain must be a finite number of at least 0, found nan"),
        (float("inf"), None, "Gain must be a finite number of at least 0, found inf"),
        (1.0, 0.0, "Clamp must be a finite number above 0 (or no clamp), found 0.0"),
        (1.0, -5.0, "Clamp must be a finite number above 0 (or no clamp), found -5.0"),
        (1.0, float("inf"), "Clamp must be a finite number above 0 (or no clamp), found inf"),
    ],
)
def test_an_unusable_gain_or_clamp_is_refused(gain, clamp, message):
    with pytest.raises(StreamValueError) as info:
        gain_and_clamp(np.zeros((1, 68)), np.zeros((1, 68), bool), gain=gain, clamp=clamp)
    assert str(info.value) == message


def test_values_and_mask_must_agree():
    with pytest.raises(StreamValueError, match=r"must both be \(frames, 68\)"):
        gain_and_clamp(np.zeros((2, 68)), np.zeros((3, 68), bool))


# --- check_values ---------------------------------------------------------------------------------------


def test_an_absurd_value_is_named_with_its_frame_and_fap():
    values = np.zeros((3, 68))
    mask = np.zeros((3, 68), bool)
    mask[:, 2] = mask[2, 47] = True
    values[2, 47] = 1e100
    with pytest.raises(StreamValueError) as info:
        check_values(values, mask, source="huge.fap")
    assert str(info.value) == (
        "huge.fap: frame index 2: FAP 48 (head_pitch) is 1e+100, beyond the limit of 1e+07 FAP units; set the "
        "Clamp import option (or lower the Gain) to play this stream"
    )


def test_nan_and_infinities_are_refused_and_absent_values_are_not_checked():
    values = np.zeros((2, 68))
    mask = np.zeros((2, 68), bool)
    mask[1, 3] = True
    for bad in (np.nan, np.inf, -np.inf):
        values[1, 3] = bad
        with pytest.raises(StreamValueError, match=rf"frame index 1: FAP 4 \(lower_t_midlip\) is {bad}"):
            check_values(values, mask)
    mask[1, 3] = False
    values[0, :2] = 1e300  # FAP 1 and 2 are not FAP-unit values
    check_values(values, mask)


def test_the_limit_itself_passes():
    values = np.zeros((1, 68))
    values[0, 2:] = VALUE_LIMIT
    check_values(values, np.ones((1, 68), bool))
    values[0, 67] = -VALUE_LIMIT * (1 + 1e-15)
    with pytest.raises(StreamValueError, match=r"FAP 68 \(pull_r_ear\) is -1e\+07"):
        check_values(values, np.ones((1, 68), bool))
    check_values(values, np.ones((1, 68), bool), limit=2 * VALUE_LIMIT)


def real_streams() -> list[Path]:
    """The project's demo stream, and the real streams of other players when they are on this machine."""
    return sorted(INTEROP.glob("*/*.fap")) + [DEMO] if INTEROP.is_dir() else [DEMO]


@pytest.mark.parametrize("path", real_streams(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_real_streams_pass_the_value_check_even_at_twice_the_gain(path):
    stream = read_fap(path)
    check_values(gain_and_clamp(stream.values, stream.mask, gain=2.0), stream.mask, source=path.name)


@pytest.mark.skipif(not INTEROP.is_dir(), reason="the real streams (../shared/interop/fap) are not on this machine")
def test_the_limit_is_far_above_the_largest_real_value():
    largest = max(float(np.abs(np.where(s.mask, s.values, 0.0)).max()) for s in map(read_fap, real_streams()))
    assert largest == 600_000  # Crystal.TTVS interpolation_emot.fap, FAP 23 (yaw_l_eyeball)
    assert VALUE_LIMIT >= 10 * largest
