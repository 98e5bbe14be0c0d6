"""Micro benchmark of the bpy-free deformers: bind time and per-frame evaluate time (median of 50).

Synthetic test: a bumpy sphere of radius 0.1 m sampled at ~3.7k / 14k / 57k vertices (Fibonacci
points), driven by a jittered UV-sphere control mesh of 79 points and 154 triangles, comparable in size
to the MPEG-4 feature-point control mesh. Every vertex lies in the control mesh's reach, which is the
worst case for the deformers (on a head, only the face region is bound).

Run: .venv/bin/python scripts/bench_core.py [--methods planar_bones soffd rbf fp_weighted]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from addon.deform import METHODS
from addon.deform.planar_bones import PlanarBonesDeformer

SIZES = (3_700, 14_000, 57_000)
RADIUS = 0.1


def control_mesh(rings: int = 7, segments: int = 11, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere: two poles plus rings × segments points, (2 + r·s, 3) points and 2·s·r triangles."""
    rng = np.random.default_rng(seed)
    polar = np.linspace(0.0, np.pi, rings + 2)[1:-1]
    azimuth = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    p, a = np.meshgrid(polar, azimuth, indexing="ij")
    ring_points = np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], axis=-1).reshape(-1, 3)
    points = np.concatenate([[[0.0, 0.0, 1.0]], ring_points, [[0.0, 0.0, -1.0]]])
    points = RADIUS * points * (1.0 + 0.03 * rng.standard_normal((len(points), 1)))
    ring = lambda r, s: 1 + r * segments + s % segments  # noqa: E731
    triangles = [[0, ring(0, s), ring(0, s + 1)] for s in range(segments)]
    for r in range(rings - 1):
        for s in range(segments):
            triangles += [
                [ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)],
                [ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)],
            ]
    south = len(points) - 1
    triangles += [[south, ring(rings - 1, s + 1), ring(rings - 1, s)] for s in range(segments)]
    return points, np.array(triangles)


def bumpy_sphere(n: int) -> np.ndarray:
    """n Fibonacci-sphere points with a few millimetres of bumps."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    azimuth = np.pi * (1.0 + 5.0**0.5) * k
    unit = np.stack([np.sqrt(1.0 - z * z) * np.cos(azimuth), np.sqrt(1.0 - z * z) * np.sin(azimuth), z], axis=1)
    bumps = 1.0 + 0.04 * np.sin(7.0 * unit[:, 0]) * np.cos(5.0 * unit[:, 1]) * np.sin(3.0 * unit[:, 2] + 1.0)
    return RADIUS * unit * bumps[:, None]


def animated(control: np.ndarray, frame: int) -> np.ndarray:
    """A smooth non-rigid control motion: a few millimetres, different each frame."""
    phase = 0.1 * frame
    return control + 0.005 * np.sin(40.0 * control + phase)


def evaluate_ms(deformer, control: np.ndarray, repeats: int, out: np.ndarray | None = None) -> float:
    """Median per-frame evaluate time over `repeats` frames, after one warm-up frame."""
    deformer.evaluate(animated(control, 0), out=out)
    times = []
    for frame in range(1, repeats + 1):
        positions = animated(control, frame)
        start = time.perf_counter()
        deformer.evaluate(positions, out=out)
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["planar_bones", "soffd"], choices=sorted(METHODS))
    parser.add_argument("--repeats", type=int, default=50)
    args = parser.parse_args()
    control, triangles = control_mesh()
    print(f"control mesh: {len(control)} points, {len(triangles)} triangles")
    print(f"{'method':<13}{'vertices':>9}{'pairs':>9}{'bind ms':>10}{'eval ms':>10}{'eval f32 ms':>13}")
    for n in SIZES:
        rest = bumpy_sphere(n)
        for name in args.methods:
            start = time.perf_counter()
            deformer = METHODS[name](rest, control, triangles)
            bind_ms = 1e3 * (time.perf_counter() - start)
            eval_ms = evaluate_ms(deformer, control, args.repeats)
            pairs, single_ms = "", ""
            if isinstance(deformer, PlanarBonesDeformer):
                pairs = str(deformer.binding.n_pairs)
                buffer = np.empty((n, 3), np.float32)
                single_ms = f"{evaluate_ms(deformer, control, args.repeats, buffer):.2f}"
            print(f"{name:<13}{n:>9}{pairs:>9}{bind_ms:>10.1f}{eval_ms:>10.2f}{single_ms:>13}")


if __name__ == "__main__":
    main()
