"""Author the bundled example stream `sample_blends/demo.fap` from low-level FAPs.

    .venv/bin/python -m scripts.sample.make_demo_fap [--out sample_blends/demo.fap]

Seven short scenes at 25 fps, each easing in and out (raised cosine): jaw, lips, lip corners (smile),
cheeks, brows, eyelids (blinks), eyeballs (look around), head turns. Values are in FAPU/AU as the
standard defines them, so the same stream plays on any face.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from addon.mpeg4.fap_file import FapStream, write_fap
from addon.mpeg4.faps import N_FAPS

ROOT = Path(__file__).resolve().parents[2]

FPS = 25
# (duration in seconds, {FAP number: peak value}); a scene's FAPs rise and fall together
SCENES = (
    (2.0, {3: 800, 5: -100, 52: -100}),  # open and close the jaw
    (2.0, {4: -150, 51: -150, 5: 250, 52: 250, 16: 400, 17: 400}),  # pout: lips pushed forward
    (2.0, {6: 200, 7: 200, 53: 200, 54: 200, 12: 200, 13: 200, 59: 200, 60: 200}),  # smile
    (2.0, {39: 120, 40: 120, 41: 250, 42: 250}),  # puff and lift the cheeks
    (2.0, {31: 220, 32: 220, 33: 250, 34: 250, 35: 180, 36: 180, 37: -100, 38: -100}),  # raise the brows
    (1.5, {19: 700, 20: 700, 21: 200, 22: 200}),  # half blink (one FP per lid: a full close bends the lid into a V)
    (2.0, {23: 25000, 24: 25000, 25: -12000, 26: -12000}),  # look up and to the left
    (3.0, {49: 30000, 48: 12000, 50: -8000}),  # turn, nod and tilt the head
)


def demo_stream() -> FapStream:
    blocks = []
    for seconds, peaks in SCENES:
        n = int(round(seconds * FPS))
        ease = 0.5 * (1.0 - np.cos(2.0 * np.pi * np.arange(n) / (n - 1)))
        block = np.zeros((n, N_FAPS))
        for number, peak in peaks.items():
            block[:, number - 1] = np.round(peak * ease)
        blocks.append(block)
    values = np.vstack(blocks)
    frames = len(values)
    mask = np.zeros((frames, N_FAPS), dtype=bool)
    used = sorted({number for _, peaks in SCENES for number in peaks})
    mask[:, [n - 1 for n in used]] = True
    return FapStream(
        version="2.1",
        name="mpeg4_face_demo",
        fps=float(FPS),
        frame_numbers=np.arange(frames, dtype=np.int64),
        mask=mask,
        values=values,
        viseme=np.zeros((frames, 4)),
        expression=np.zeros((frames, 6)),
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "sample_blends" / "demo.fap")
    args = parser.parse_args(argv)
    stream = demo_stream()
    write_fap(stream, args.out)
    used = (np.flatnonzero(stream.mask[0]) + 1).tolist()
    print(f"{args.out}: {len(stream.frame_numbers)} frames at {FPS} fps, FAPs {used}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
