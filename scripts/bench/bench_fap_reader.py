"""Time `read_fap` and `write_fap` on generated streams (100,000 and 10,000 frames).

Run from the repository root: `.venv/bin/python -m scripts.bench.bench_fap_reader [--faps 20] [--floats]`.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from addon.mpeg4.fap_file import N_FAPS, FapStream, read_fap, write_fap


def make_stream(n_frames: int, n_faps: int, floats: bool, rng: np.random.Generator) -> FapStream:
    """Low-level FAPs only, a few distinct masks (as real files have), values of real-file magnitude."""
    masks = np.zeros((4, N_FAPS), bool)
    for mask in masks:
        mask[2 + rng.choice(N_FAPS - 2, n_faps, replace=False)] = True
    mask = masks[rng.integers(0, len(masks), n_frames)]
    values = rng.normal(0.0, 200.0, (n_frames, N_FAPS))
    values = np.round(values, 3) if floats else np.rint(values)
    return FapStream(
        version="2.1",
        name="bench stream",
        fps=25.0,
        frame_numbers=np.arange(n_frames, dtype=np.int64),
        mask=mask,
        values=np.where(mask, values, 0.0),
        viseme=np.zeros((n_frames, 4)),
        expression=np.zeros((n_frames, 6)),
    )


def best_of(repeats: int, run) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--faps", type=int, default=20, help="masked-in FAPs per frame")
    parser.add_argument("--floats", action="store_true", help="values with 3 decimals instead of integers")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    kind = "float" if args.floats else "integer"
    with tempfile.TemporaryDirectory() as tmp:
        for n_frames in (100_000, 10_000):
            stream = make_stream(n_frames, args.faps, args.floats, rng)
            path = Path(tmp) / f"bench_{n_frames}.fap"
            write_time = best_of(args.repeats, lambda s=stream, p=path: write_fap(s, p))
            read_time = best_of(args.repeats, lambda p=path: read_fap(p))
            back = read_fap(path)
            assert np.array_equal(back.values, stream.values) and np.array_equal(back.mask, stream.mask)
            size = path.stat().st_size / 1e6
            label = f"{n_frames} frames ({args.faps} {kind} FAPs/frame, {size:.1f} MB)"
            print(f"read  {label}: {read_time:.3f} s")
            print(f"write {label}: {write_time:.3f} s")


if __name__ == "__main__":
    main()
