"""PC2 point caches: the layout Blender reads, streamed one sample at a time, and never half-written."""

import tracemalloc

import numpy as np
import pytest

from addon.formats.pc2 import HEADER, TEMP_SUFFIX, PointCacheError, PointCacheWriter, read_pc2, write_pc2


def _samples(count: int, points: int = 5) -> np.ndarray:
    return np.random.default_rng(count).normal(size=(count, points, 3)).astype(np.float32)


def test_write_and_read_back(tmp_path):
    path = tmp_path / "a.pc2"
    frames = _samples(4)
    write_pc2(str(path), frames, start=20.0, rate=0.5)
    data, start, rate = read_pc2(str(path))
    np.testing.assert_array_equal(data, frames)
    assert (start, rate) == (20.0, 0.5)
    header = np.frombuffer(path.read_bytes()[: HEADER.itemsize], dtype=HEADER)[0]
    assert (header["signature"], header["version"], header["points"], header["samples"]) == (b"POINTCACHE2", 1, 5, 4)
    assert path.stat().st_size == HEADER.itemsize + frames.nbytes
    assert [p.name for p in tmp_path.iterdir()] == ["a.pc2"]


def test_samples_are_streamed_and_the_file_appears_only_when_complete(tmp_path):
    path = tmp_path / "a.pc2"
    frames = _samples(3)
    writer = PointCacheWriter(str(path), points=5, samples=3, start=1.0)
    for sample in frames:
        writer.write(sample)
        assert not path.exists()
        [temp] = tmp_path.iterdir()  # next to the target (so the rename is one step), hidden
        assert temp.name.startswith(".a.pc2.") and temp.name.endswith(TEMP_SUFFIX)
    writer.commit()
    assert [p.name for p in tmp_path.iterdir()] == ["a.pc2"]
    np.testing.assert_array_equal(read_pc2(str(path))[0], frames)


def test_an_error_while_writing_leaves_no_file_and_keeps_the_old_cache(tmp_path):
    path = tmp_path / "a.pc2"
    path.write_bytes(b"old cache")
    with pytest.raises(KeyboardInterrupt), PointCacheWriter(str(path), points=5, samples=3, start=1.0) as writer:
        writer.write(_samples(1)[0])
        raise KeyboardInterrupt  # Esc, a failed frame, anything
    assert [p.name for p in tmp_path.iterdir()] == ["a.pc2"]
    assert path.read_bytes() == b"old cache"


def test_a_cache_missing_samples_is_not_put_in_place(tmp_path):
    path = tmp_path / "a.pc2"
    with pytest.raises(PointCacheError, match="only 2 of 3 samples"):
        with PointCacheWriter(str(path), points=5, samples=3, start=1.0) as writer:
            for sample in _samples(2):
                writer.write(sample)
    assert list(tmp_path.iterdir()) == []


def test_samples_of_the_wrong_shape_or_too_many_are_refused(tmp_path):
    writer = PointCacheWriter(str(tmp_path / "a.pc2"), points=5, samples=1, start=1.0)
    with pytest.raises(PointCacheError, match=r"\(5, 3\)"):
        writer.write(np.zeros((4, 3)))
    writer.write(np.zeros((5, 3)))
    with pytest.raises(PointCacheError, match="already written"):
        writer.write(np.zeros((5, 3)))
    writer.discard()
    writer.discard()  # twice is harmless (a cancel after a failure)
    assert list(tmp_path.iterdir()) == []


def test_a_missing_folder_is_a_point_cache_error(tmp_path):
    with pytest.raises(PointCacheError, match="cannot write"):
        PointCacheWriter(str(tmp_path / "gone" / "a.pc2"), points=5, samples=1, start=1.0)


def test_a_truncated_cache_is_refused(tmp_path):
    path = tmp_path / "a.pc2"
    write_pc2(str(path), _samples(2), start=1.0)
    path.write_bytes(path.read_bytes()[:-4])
    with pytest.raises(PointCacheError, match="size does not match"):
        read_pc2(str(path))


def test_memory_does_not_grow_with_the_sample_count(tmp_path):
    sample = np.ones((4278, 3), dtype=np.float32)  # the sample head: 51 kB a sample
    peaks = {}
    for count in (20, 2000):
        tracemalloc.start()
        try:
            with PointCacheWriter(str(tmp_path / f"{count}.pc2"), len(sample), count, start=1.0) as writer:
                for _ in range(count):
                    writer.write(sample)
            peaks[count] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert peaks[2000] < 4 * sample.nbytes and peaks[2000] < peaks[20] + sample.nbytes
