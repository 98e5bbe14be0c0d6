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
completed by `complete_feature_points`, §3.1.1). Errors are over all vertices of the head mesh, which is
skin only (eyes, teeth and tongue are objects of their own; the bald mesh has no hair): the mean and the
95th-percentile vertex error in mm, pooled over all faces, and the relative error = mean error / mean true
displacement (1.0 = no better than not fitting), pooled and as the median over the faces. A face whose
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


def evaluate(faces: list[TrueFace], binding: DffdBinding, generic_fps: dict[str, np.ndarray], seed: int) -> dict:
    """Per case: the FPs given, per face its true displacement and per method its vertex errors, and failures."""
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
            scored[face.name] = (face.group, displacement, errors)
        results[case] = {"given": subset, "scored": scored, "failed": failed}
    return results


def figures(scored: dict, method: str) -> dict[str, float]:
    """Pooled mean and p95 error (mm), pooled relative error, the median of the faces' relative errors and the
    number of faces it fits worse than not fitting at all (NaN and 0 when every face failed)."""
    if not scored:
        empty = dict.fromkeys(("mean_mm", "p95_mm", "relative", "relative_median"), float("nan"))
        return empty | {"worse_than_none": 0}
    errors = np.concatenate([e[method] for _, _, e in scored.values()])
    displacement = np.concatenate([d for _, d, _ in scored.values()])
    relative = np.array([e[method].mean() / d.mean() for _, d, e in scored.values()])
    return {
        "mean_mm": 1e3 * float(errors.mean()),
        "p95_mm": 1e3 * float(np.percentile(errors, 95)),
        "relative": float(errors.mean() / displacement.mean()),
        "relative_median": float(np.median(relative)),
        "worse_than_none": int(np.count_nonzero(relative > 1.0)),
    }


def markdown(results: dict, command: str, n_faces: int) -> str:
    lines = [
        f"`{command}`",
        "",
        f"{n_faces} faces (those failed, below, left out); error over the head's skin vertices; relative = mean"
        " error / mean true displacement,"
        " pooled (the median over the faces in brackets); worse = faces fitted worse than not fitting.",
        "",
        "| method | "
        + " | ".join(f"{label}: mean (mm) | p95 (mm) | relative | worse" for label in CASES.values())
        + " |",
        "|---|" + "---:|---:|---:|---:|" * len(CASES),
    ]
    for method in METHODS:
        cells = []
        for case in CASES:
            f = figures(results[case]["scored"], method)
            cells.append(
                f"{f['mean_mm']:.2f} | {f['p95_mm']:.2f} | {f['relative']:.2f} ({f['relative_median']:.2f})"
                f" | {f['worse_than_none']}"
            )
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    groups = sorted({group for _, (group, _, _) in results["all_fps"]["scored"].items()})
    lines += [
        "",
        "Median relative error per folder (all FPs / half the FPs):",
        "",
        "| folder | faces | true displacement (mm) | " + " | ".join(METHODS[:-1]) + " |",
        "|---|---:|---:|" + "---:|" * (len(METHODS) - 1),
    ]
    for group in groups:
        per_case = {case: {name: s for name, s in results[case]["scored"].items() if s[0] == group} for case in CASES}
        shown = per_case["all_fps"]
        moved = 1e3 * np.mean([d.mean() for _, d, _ in shown.values()])
        cells = [
            " / ".join(f"{figures(per_case[case], method)['relative_median']:.2f}" for case in CASES)
            for method in METHODS[:-1]
        ]
        lines.append(f"| {group} | {len(shown)} | {moved:.2f} | " + " | ".join(cells) + " |")
    for case, label in CASES.items():
        for name, message in results[case]["failed"].items():
            lines.append(f"\nFailed ({label}): {name}: {message}")
    lines.append(f"\nHalf the FPs (seed): {', '.join(results['half_fps']['given'])}")
    return "\n".join(lines)


def to_json(results: dict, command: str, n_faces: int) -> dict:
    return {
        "command": command,
        "methods": {method: {case: figures(results[case]["scored"], method) for case in CASES} for method in METHODS},
        "targets": n_faces,
        "failed": {case: results[case]["failed"] for case in CASES},
        "half_fps": list(results["half_fps"]["given"]),
        "per_target": {
            case: {
                name: {
                    "group": group,
                    "displacement_mm": 1e3 * float(d.mean()),
                    **{method: float(e[method].mean() / d.mean()) for method in METHODS},
                }
                for name, (group, d, e) in results[case]["scored"].items()
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
    results = evaluate(faces, binding, generic_fps, args.seed)
    print(markdown(results, command, len(faces)))
    if args.json:
        Path(args.json).write_text(json.dumps(to_json(results, command, len(faces)), indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
