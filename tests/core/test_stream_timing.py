"""Playability checks of a parsed stream, before anything is keyed."""

from pathlib import Path

import numpy as np
import pytest

from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.stream_timing import (
    MAX_FRAME,
    MAX_VALUE,
    StreamTimingError,
    check_values,
    gain_and_clamp,
    scene_frames,
)

REAL = Path("/work/shared/interop/fap")
SAMPLE = Path(__file__).resolve().parents[2] / "sample_blends" / "demo.fap"


def test_frames_keep_the_streams_timing_or_step_one_per_frame():
    numbers = np.array([0, 5, 10])
    np.testing.assert_array_equal(scene_frames(numbers, 25.0, 50.0, 1), [1.0, 11.0, 21.0])
    np.testing.assert_array_equal(scene_frames(numbers, 25.0, 50.0, 1, use_stream_fps=False), [1.0, 6.0, 11.0])


@pytest.mark.parametrize("fps", [1e-300, 0.0, -25.0, float("nan"), float("inf"), 1e6])
def test_an_unplayable_frame_rate_is_refused(fps):
    with pytest.raises(StreamTimingError, match=r"s.fap: the stream's frame rate .* is outside 0.001..10000"):
        scene_frames(np.array([0, 1]), fps, 24.0, 1, source="s.fap")


def test_a_frame_beyond_blenders_last_frame_is_named():
    with pytest.raises(StreamTimingError) as err:
        scene_frames(np.array([0, 2**53 - 1]), 25.0, 25.0, 1, source="s.fap")
    assert str(err.value).startswith(
        f"s.fap: frame {2**53 - 1} of the stream lands on scene frame {2**53:.0f}, beyond Blender's last frame "
        f"{MAX_FRAME}"
    )


def test_far_apart_frames_are_two_keys_not_a_million():
    frames = scene_frames(np.array([0, 1_000_000]), 1000.0, 24.0, 0)
    np.testing.assert_array_equal(frames, [0.0, 24_000.0])


def test_too_many_frames_are_refused_before_any_work(monkeypatch):
    import addon.mpeg4.stream_timing as timing

    monkeypatch.setattr(timing, "MAX_KEYS", 10)
    with pytest.raises(StreamTimingError, match="11 frames; at most 10"):
        scene_frames(np.arange(11), 25.0, 25.0, 1)


def test_gain_scales_and_clamp_limits_low_level_faps_only():
    values = np.zeros((1, 68))
    values[0, :4] = [7, 9, 300, -500]
    mask = np.ones((1, 68), bool)
    out = gain_and_clamp(values, mask, gain=2.0, clamp=800.0)
    np.testing.assert_array_equal(out[0, :4], [7, 9, 600, -800])
    assert values[0, 2] == 300  # the input is left alone
    for gain, clamp in ((-1.0, None), (float("nan"), None), (1.0, 0.0), (1.0, float("inf"))):
        with pytest.raises(StreamTimingError):
            gain_and_clamp(values, mask, gain=gain, clamp=clamp)


def test_absurd_values_are_named_with_frame_and_fap():
    values = np.zeros((3, 68))
    mask = np.zeros((3, 68), bool)
    mask[:, 2] = True
    values[2, 2] = 1e100
    with pytest.raises(StreamTimingError) as err:
        check_values(values, mask, source="huge.fap")
    assert str(err.value) == (
        "huge.fap: frame 2: FAP 3 (open_jaw) is 1e+100, beyond 1e+06: this is not a face motion; set the "
        "import's Clamp to limit the values"
    )
    values[2, 2] = np.nan
    with pytest.raises(StreamTimingError, match="is nan"):
        check_values(values, mask)
    mask[2, 2] = False  # an absent value is not checked
    check_values(values, mask)


def test_every_real_stream_is_within_the_value_limit():
    paths = sorted(REAL.glob("*/*.fap")) + [SAMPLE]
    if len(paths) == 1:
        pytest.skip("the real streams (/work/shared/interop/fap) are not on this machine")
    largest = 0.0
    for path in paths:
        stream = read_fap(path)
        check_values(stream.values, stream.mask, source=path.name)
        largest = max(largest, float(np.abs(np.where(stream.mask[:, 2:], stream.values[:, 2:], 0)).max()))
    assert largest < MAX_VALUE
