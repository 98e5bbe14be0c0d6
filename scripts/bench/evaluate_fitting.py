"""Accuracy of fitting the generic head to a person's feature points (Escher et al. §3.1) on MakeHuman faces.

    .venv/bin/python -m scripts.bench.evaluate_fitting --targets DIR|FILE [--targets DIR|FILE ...]
        [--face sample_blends/makehuman_head.blend] [--seed 0] [--json OUT]

Every `.target` / `.target.gz` in DIR (or given as FILE) is one true face: the sample head plus that
MakeHuman offset at weight 1 (`evaluate.target_motion`: each head vertex by its `mh_index`, each FP by the
mean offset of its `FP_TABLE` vertices, so the FPs follow the same rules as the sample head's), placed the
way the sample builder places a face: head-local, its own 7.1 (the top of the spine) at the origin. The
generic head is fitted to the true face's FPs by

- dffd: `fit_to_feature_points` (missing FPs completed, then Dirichlet FFD);
- rbf: thin-plate RBF on the completed FPs' displacements (scipy's `RBFInterpolator`, degree 1);
- none: the generic head as it is,

once with all FPs and once with half of them (the same random half for every face, `--seed`; the rest
completed by `complete_feature_points`, §3.1.1). Errors are over two regions of the head mesh, which is
skin only (eyes, teeth and tongue are objects of their own; the bald mesh has no hair): the whole head,
and the part the FPs enclose (inside their convex hull: the face and the skin between FPs, where Dirichlet
FFD interpolates the FPs alone and the paper's method is all there is); the sides and back of the skull, the
neck and the underside of the chin bulge out of it, and there the auxiliary shell of `dffd` extrapolates.
Per region: the mean and the 95th-percentile vertex error in mm, pooled over all faces, and the relative
error = mean error / mean true displacement (1.0 = no better than not fitting), pooled and as the median
over the faces. Each face also
gets its FP share: the largest FP displacement over the largest vertex displacement. A shape narrower
than the FPs' spacing (a dimple between FPs) has a small share, and no fit to FPs can recover it; the
medians are also given for the faces whose FPs carry at least half of the largest motion. A face whose
fit raises an `Mpeg4Error` (a fold, say) is reported as failed and left out of every method's figures for
that FP set; a target that does not move the head is skipped.
"""

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import bpy
import numpy as np
from scipy.interpolate import RBFInterpolator
from scipy.spatial import Delaunay

from addon.blender.face_data import local_positions
from addon.errors import Mpeg4Error
from addon.fitting.dffd import DffdBinding, bind_dffd
from addon.fitting.fit import fit_to_feature_points
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.feature_points import FP_IDS
from scripts.bench.evaluate import DEFAULT_FACE, HEAD, SampleFace, load_face, target_files, target_motion
from scripts.sample.makehuman.targets import target_name

METHODS = ("dffd", "rbf", "none")
CASES = {"all_fps": "all FPs", "half_fps": "half the FPs"}
ORIGIN_FP = "7.1"  # the sample builder puts each face's own 7.1 at the head's origin
REGIONS = {"head": "whole head", "enclosed": "part the FPs enclose"}
SEEN_SHARE = 0.5  # faces whose FPs carry at least this share of the largest vertex displacement


@dataclasses.dataclass(frozen=True)
class TrueFace:
    name: str
    group: str  # the folder the target came from
    vertices: np.ndarray  # (N, 3) head-local metres
    fps: dict[str, np.ndarray]


def true_faces(paths: list[Path], face: SampleFace, generic_fps: dict[str, np.ndarray]) -> list[TrueFace]:
    every_fp = dataclasses.replace(face, fp_ids=tuple(generic_fps))
    faces = []
    for path in paths:
        vertex_offsets, fp_offsets = target_motion(path, every_fp)
        if not np.any(vertex_offsets):
            print(f"skipped {target_name(path)}: it does not move the head")
            continue
        shift = fp_offsets[list(generic_fps).index(ORIGIN_FP)]
        fps = {fp_id: p + d - shift for (fp_id, p), d in zip(generic_fps.items(), fp_offsets, strict=True)}
        faces.append(TrueFace(target_name(path), path.parent.name, face.rest + vertex_offsets - shift, fps))
    return faces


def target_paths(options: list[str]) -> list[Path]:
    paths = []
    for option in options:
        path = Path(option)
        paths += target_files(path) if path.is_dir() else [path]
    return paths


def half_of(fp_ids: tuple[str, ...], seed: int) -> tuple[str, ...]:
    chosen = np.random.default_rng(seed).choice(len(fp_ids), len(fp_ids) // 2, replace=False)
    return tuple(fp_ids[k] for k in sorted(chosen))


def rbf_fit(binding: DffdBinding, fps: dict[str, np.ndarray]) -> np.ndarray:
    """Thin-plate RBF of the FPs' displacements, one control point per DFFD site (coincident FPs are one)."""
    motion = np.array([fps[fp_id] for fp_id in binding.fp_ids]) - binding.rest_fps
    field = RBFInterpolator(binding.rest_fps, motion, kernel="thin_plate_spline", degree=1)
    return binding.rest_vertices + field(binding.rest_vertices)


def fit_all(
    binding: DffdBinding, generic_fps: dict[str, np.ndarray], given: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Method -> fitted head; raises `Mpeg4Error` when the FPs cannot be fitted."""
    fit = fit_to_feature_points(binding, generic_fps, given, BLENDER_FACE_AXES)
    return {
        "dffd": fit.vertices,
        "rbf": rbf_fit(binding, fit.completion.positions),
        "none": binding.rest_vertices,
    }


@dataclasses.dataclass(frozen=True)
class Scored:
    group: str
    displacement: np.ndarray  # (N,) true displacement of each vertex (m)
    errors: dict[str, np.ndarray]  # method -> (N,) vertex errors (m)
    fp_share: float  # largest FP displacement / largest vertex displacement


def evaluate(faces: list[TrueFace], binding: DffdBinding, generic_fps: dict[str, np.ndarray], seed: int) -> dict:
    """Per case: the FPs given, per face its `Scored`, and failures."""
    subsets = {"all_fps": tuple(generic_fps), "half_fps": half_of(tuple(generic_fps), seed)}
    results = {}
    for case, subset in subsets.items():
        scored, failed = {}, {}
        for face in faces:
            try:
                fitted = fit_all(binding, generic_fps, {fp_id: face.fps[fp_id] for fp_id in subset})
            except Mpeg4Error as error:
                failed[face.name] = str(error)
                continue
            displacement = np.linalg.norm(face.vertices - binding.rest_vertices, axis=1)
            errors = {method: np.linalg.norm(fitted[method] - face.vertices, axis=1) for method in METHODS}
            fp_motion = max(np.linalg.norm(face.fps[fp_id] - generic_fps[fp_id]) for fp_id in generic_fps)
            scored[face.name] = Scored(face.group, displacement, errors, float(fp_motion / displacement.max()))
        results[case] = {"given": subset, "scored": scored, "failed": failed}
    return results


def figures(scored: dict[str, Scored], method: str, region: np.ndarray | None = None) -> dict[str, float]:
    """Over the vertices in `region` (all if None): pooled mean and p95 error (mm), pooled relative error, the
    median of the faces' relative errors and the number of faces it fits worse than not fitting at all (NaN and
    0 when every face failed; a face that does not move the region counts as neither better nor worse)."""
    if not scored:
        empty = dict.fromkeys(("mean_mm", "p95_mm", "relative", "relative_median"), float("nan"))
        return empty | {"worse_than_none": 0}
    keep = slice(None) if region is None else region
    errors = np.concatenate([s.errors[method][keep] for s in scored.values()])
    displacement = np.concatenate([s.displacement[keep] for s in scored.values()])
    relative = np.array([relative_error(s, method, keep) for s in scored.values()])
    return {
        "mean_mm": 1e3 * float(errors.mean()),
        "p95_mm": 1e3 * float(np.percentile(errors, 95)),
        "relative": float(errors.mean() / displacement.mean()),
        "relative_median": float(np.median(relative)),
        "worse_than_none": int(np.count_nonzero(relative > 1.0)),
    }


def relative_error(scored: Scored, method: str, keep=slice(None)) -> float:
    """Mean error / mean true displacement over `keep`; 1.0 where the true face does not move there."""
    moved = scored.displacement[keep].mean()
    return float(scored.errors[method][keep].mean() / moved) if moved > 0.0 else 1.0


def region_figures(scored: dict[str, Scored], method: str, enclosed: np.ndarray) -> dict:
    """`figures` over the whole head, with those over the part the FPs enclose under "enclosed"."""
    return figures(scored, method) | {"enclosed": figures(scored, method, enclosed)}


def markdown(results: dict, command: str, n_faces: int, enclosed: np.ndarray) -> str:
    lines = [
        f"`{command}`",
        "",
        f"{n_faces} faces (those failed, below, left out); relative = mean error / mean true displacement, pooled"
        " (the median over the faces in brackets); worse = faces fitted worse than not fitting.",
    ]
    for region, label in REGIONS.items():
        keep = enclosed if region == "enclosed" else None
        count = len(enclosed) if keep is None else int(np.count_nonzero(enclosed))
        lines += [
            "",
            f"Error over the {label} ({count} vertices):",
            "",
            "| method | "
            + " | ".join(f"{case}: mean (mm) | p95 (mm) | relative | worse" for case in CASES.values())
            + " |",
            "|---|" + "---:|---:|---:|---:|" * len(CASES),
        ]
        for method in METHODS:
            cells = []
            for case in CASES:
                f = figures(results[case]["scored"], method, keep)
                cells.append(
                    f"{f['mean_mm']:.2f} | {f['p95_mm']:.2f} | {f['relative']:.2f} ({f['relative_median']:.2f})"
                    f" | {f['worse_than_none']}"
                )
            lines.append(f"| {method} | " + " | ".join(cells) + " |")
    groups = sorted({s.group for s in results["all_fps"]["scored"].values()})
    lines += [
        "",
        "Median relative error over the whole head / the part the FPs enclose, all FPs given, by folder and FP share:",
        "",
        "| faces | count | true displacement (mm) | " + " | ".join(METHODS[:-1]) + " |",
        "|---|---:|---:|" + "---:|" * (len(METHODS) - 1),
    ]
    every = results["all_fps"]["scored"]
    subsets = [(group, {n: s for n, s in every.items() if s.group == group}) for group in groups]
    subsets += [
        (f"FP share >= {SEEN_SHARE}", {n: s for n, s in every.items() if s.fp_share >= SEEN_SHARE}),
        (f"FP share < {SEEN_SHARE}", {n: s for n, s in every.items() if s.fp_share < SEEN_SHARE}),
    ]
    for label, shown in subsets:
        moved = 1e3 * np.mean([s.displacement.mean() for s in shown.values()])
        medians = [(figures(shown, m), figures(shown, m, enclosed)) for m in METHODS[:-1]]
        cells = [f"{head['relative_median']:.2f} / {inside['relative_median']:.2f}" for head, inside in medians]
        lines.append(f"| {label} | {len(shown)} | {moved:.2f} | " + " | ".join(cells) + " |")
    for case, label in CASES.items():
        for name, message in results[case]["failed"].items():
            lines.append(f"\nFailed ({label}): {name}: {message}")
    lines.append(f"\nHalf the FPs (seed): {', '.join(results['half_fps']['given'])}")
    return "\n".join(lines)


def to_json(results: dict, command: str, n_faces: int, enclosed: np.ndarray) -> dict:
    return {
        "command": command,
        "methods": {m: {case: region_figures(results[case]["scored"], m, enclosed) for case in CASES} for m in METHODS},
        "targets": n_faces,
        "enclosed_vertices": int(np.count_nonzero(enclosed)),
        "failed": {case: results[case]["failed"] for case in CASES},
        "half_fps": list(results["half_fps"]["given"]),
        "per_target": {
            case: {
                name: {
                    "group": s.group,
                    "displacement_mm": 1e3 * float(s.displacement.mean()),
                    "fp_share": s.fp_share,
                    **{method: relative_error(s, method) for method in METHODS},
                    "enclosed": {method: relative_error(s, method, enclosed) for method in METHODS},
                }
                for name, s in results[case]["scored"].items()
            }
            for case in CASES
        },
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--targets", required=True, action="append", nargs="+", help="folders of MakeHuman .target(.gz) files, or files"
    )
    parser.add_argument("--face", default=str(DEFAULT_FACE), help="sample .blend with the Head")
    parser.add_argument("--seed", type=int, default=0, help="picks the half of the FPs given in the second case")
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()
    command = ".venv/bin/python -m scripts.bench.evaluate_fitting " + " ".join(sys.argv[1:])
    face = load_face(Path(args.face))
    collection = bpy.data.collections[f"{HEAD} FPs"]
    empties = {ob["mpeg4_fp"]: ob for ob in collection.objects if ob.type == "EMPTY" and "mpeg4_fp" in ob}
    positions = local_positions(face.head, empties)
    generic_fps = {fp_id: positions[fp_id] for fp_id in FP_IDS}
    binding = bind_dffd(face.rest, generic_fps)
    faces = true_faces(target_paths([p for group in args.targets for p in group]), face, generic_fps)
    enclosed = Delaunay(np.array(list(generic_fps.values()))).find_simplex(face.rest) >= 0
    results = evaluate(faces, binding, generic_fps, args.seed)
    print(markdown(results, command, len(faces), enclosed))
    if args.json:
        Path(args.json).write_text(json.dumps(to_json(results, command, len(faces), enclosed), indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
