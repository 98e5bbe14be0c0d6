"""Kernel micro-benchmark: `planar_bones.evaluate` into float32, the numpy path against the compiled kernel.

    .venv/bin/python -m scripts.bench.bench_kernel [--frames 30] [--rounds 9] [--levels 0 1 2]

For each size (the sample head, and its Catmull-Clark subdivisions at levels 1 and 2, applied), set the
head up with Set Up Face and take its binding. Then, in rounds, each variant evaluates the same frames
(FAP-sized random motions of the control points) into a float32 buffer, one variant after the other, so
that load from other processes hits every variant alike: numpy (``MPEG4_FACE_NO_KERNEL=1``), the kernel
on 1 thread and on 2 (``MPEG4_FACE_KERNEL_THREADS``), and the kernel as shipped (2 threads from 50,000
pairs up). A figure is the median over rounds of each round's median frame time; the speed-up is numpy
over the kernel as shipped. "Layout" is the kernel's one-off set-up on the first call
(`fused.build_layout`). Prints a Markdown table and the load average before and after, since timings on a
shared machine are noisy.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import addon
from addon.blender import binding_store
from addon.deform import fused
from addon.deform.planar_bones import evaluate
from scripts.bench.bench import set_up_sample

VARIANTS = {  # name: environment
    "numpy": {fused.DISABLE: "1"},
    "kernel, 1 thread": {fused.THREADS_VARIABLE: "1"},
    "kernel, 2 threads": {fused.THREADS_VARIABLE: "2"},
    "kernel as shipped": {},
}


def prepare(level: int):
    """The sample head subdivided at ``level`` and set up; its binding."""
    head, _bind_s = set_up_sample(level)
    return binding_store.load(head)


def run(variant: str, binding, frames: list[np.ndarray], out: np.ndarray) -> float:
    """Median seconds per frame of one variant over the frames."""
    for name in (fused.DISABLE, fused.THREADS_VARIABLE):
        os.environ.pop(name, None)
    os.environ.update(VARIANTS[variant])
    times = []
    for control in frames:
        start = time.perf_counter()
        evaluate(binding, control, out=out)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def measure(binding, n_frames: int, rounds: int) -> tuple[dict[str, float], float]:
    rng = np.random.default_rng(0)
    control = binding.control_rest
    frames = [control + rng.normal(0.0, 0.003, control.shape) for _ in range(n_frames)]
    out = np.empty((binding.n_vertices, 3), np.float32)
    binding._evaluation.clear()  # set-up built the layout already: build it again here, timed
    start = time.perf_counter()
    evaluate(binding, frames[0], out=out)  # builds the kernel's layout
    layout = time.perf_counter() - start
    per_round = {variant: [] for variant in VARIANTS}
    for _ in range(rounds):
        for variant in VARIANTS:
            per_round[variant].append(run(variant, binding, frames, out))
    for name in (fused.DISABLE, fused.THREADS_VARIABLE):
        os.environ.pop(name, None)
    return {variant: float(np.median(t)) for variant, t in per_round.items()}, layout


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args(argv)
    for name in (fused.DISABLE, fused.THREADS_VARIABLE):
        os.environ.pop(name, None)
    if not fused.available():
        raise SystemExit("no compiled kernel: run `.venv/bin/python -m scripts.build_kernel --install` first")
    addon.register()
    print(
        f"`.venv/bin/python -m scripts.bench.bench_kernel --frames {args.frames} --rounds {args.rounds}` "
        f"(medians; load average before: {os.getloadavg()[0]:.2f}, {os.cpu_count()} CPUs)\n"
    )
    columns = ("level", "vertices", "pairs", *(f"{v} (ms)" for v in VARIANTS), "speed-up", "layout (ms)")
    print("| " + " | ".join(columns) + " |")
    print("|" + "---:|" * len(columns))
    for level in args.levels:
        binding = prepare(level)
        ms, layout = measure(binding, args.frames, args.rounds)
        figures = " | ".join(f"{ms[v] * 1e3:.2f}" for v in VARIANTS)
        speed_up = ms["numpy"] / ms["kernel as shipped"]
        print(
            f"| {level} | {binding.n_vertices} | {binding.n_pairs} | {figures} | {speed_up:.1f} | {layout * 1e3:.0f} |",
            flush=True,
        )
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
