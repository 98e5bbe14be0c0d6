"""What the development units allow a deformer driven only by FP motion: a data-fitted linear bound.

    .venv/bin/python -m scripts.bench.fp_motion_bound --targets DIR [--face sample_blends/makehuman_head.blend]

Every deformer in `scripts.bench.evaluate` sees only the control FPs' motion. Two facts bound what any of
them can score on the development units (E as there: Σ‖deformed − sculpted‖ / Σ‖sculpted − neutral‖):

1. A unit whose control FPs do not move at all (nose-compression: its sculpt moves the nostrils, none of
   the FPs' base-mesh vertices) leaves every such deformer at rest, as the face must be when its FPs are at
   rest, so its E is exactly 1 whatever the method.
2. An oracle fitted on the units themselves: each head vertex's offset as a weighted sum of the control FPs'
   offsets, d_v = Σ_f w_vf d_f, with weights w_vf fitted by ridge least squares over the units (x, y and z
   rows; one weight matrix for all vertices, solved at once). Every deformer that moves a vertex by a blend
   of the FPs' offsets (RBF interpolation of each coordinate, feature-point weighting, skinning with bones that
   only translate) is one choice of w; the oracle is the best choice for the data, so it is optimistic. Planar
   Bones and Elastic Bones are not of this kind (their frames turn, so a vertex off a control triangle's plane
   moves across the FPs' directions); the bound is a yardstick for them, not a limit:
   - *in-sample*: fitted on all units, scored on the same units (a floor for such deformers);
   - *leave-one-out*: fitted without the unit scored;
   - *leave-pair-out*: fitted without the unit and its left/right mirror twin (an unseen expression).
   The ridge weight is the one with the lowest pooled leave-pair-out E on this very data (optimistic again).

It prints one row per unit, the pooled E, the region E (`evaluate.REGIONS`) and, per regime, the largest E
among the brow units, the eye units and all units (the targets issue 13 set: brows and eyes ≤ 0.7, no unit
above 0.9, pooled ≤ 0.5).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from scripts.bench import evaluate

RIDGE = (1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4)  # m² added to the normal equations' diagonal
REGIMES = ("in-sample", "leave-one-out", "leave-pair-out")


def load_units(face: evaluate.SampleFace, folder: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Unit names, (U, N, 3) sculpted vertex offsets and (U, M, 3) control FP offsets, metres."""
    names, vertex, fp = [], [], []
    for path in evaluate.target_files(folder):
        offsets, fp_offsets = evaluate.target_motion(path, face)
        if np.any(offsets):
            names.append(evaluate.target_name(path))
            vertex.append(offsets)
            fp.append(fp_offsets)
    return names, np.array(vertex), np.array(fp)


def mirror_twin(name: str, names: list[str]) -> int | None:
    """Index of the unit that mirrors `name` (left <-> right), if there is one."""
    for a, b in (("-left-", "-right-"), ("-right-", "-left-")):
        if a in name:
            twin = name.replace(a, b)
            return names.index(twin) if twin in names else None
    return None


def predictions(vertex: np.ndarray, fp: np.ndarray, left_out: list[list[int]], ridge: float) -> np.ndarray:
    """(U, N, 3) the oracle's offsets for each unit, fitted without the units `left_out[u]`."""
    units, count, _ = vertex.shape
    controls = fp.shape[1]
    a = fp.transpose(0, 2, 1).reshape(units, 3, controls)  # rows (unit, axis) over the control FPs
    b = vertex.transpose(0, 2, 1).reshape(units, 3, count)
    gram = np.einsum("uci,ucj->uij", a, a)  # each unit's share of AᵀA
    moment = np.einsum("uci,ucn->uin", a, b)  # each unit's share of AᵀB
    result = np.empty_like(vertex)
    for unit in range(units):
        keep = np.setdiff1d(np.arange(units), left_out[unit])
        weights = np.linalg.solve(gram[keep].sum(0) + ridge * np.eye(controls), moment[keep].sum(0))
        result[unit] = (a[unit] @ weights).T
    return result


def scores(vertex: np.ndarray, predicted: np.ndarray, region: np.ndarray) -> dict:
    errors = np.linalg.norm(predicted - vertex, axis=2)  # (U, N)
    motion = np.linalg.norm(vertex, axis=2)
    regions = {}
    for index, name in enumerate(evaluate.REGION_NAMES):
        moved = motion[:, region == index].sum()
        regions[name] = float(errors[:, region == index].sum() / moved) if moved else float("nan")
    return {
        "per_unit": errors.sum(1) / motion.sum(1),
        "pooled": float(errors.sum() / motion.sum()),
        "regions": regions,
    }


def run(face_path: Path, folder: Path) -> dict:
    face = evaluate.load_face(face_path)
    names, vertex, fp = load_units(face, folder)
    still = [name for name, offsets in zip(names, fp, strict=True) if not np.any(offsets)]
    plans = {
        "in-sample": [[] for _ in names],
        "leave-one-out": [[u] for u in range(len(names))],
        "leave-pair-out": [[u] + [t for t in [mirror_twin(n, names)] if t is not None] for u, n in enumerate(names)],
    }
    by_ridge = {r: scores(vertex, predictions(vertex, fp, plans["leave-pair-out"], r), face.region) for r in RIDGE}
    ridge = min(RIDGE, key=lambda r: by_ridge[r]["pooled"])
    results = {
        regime: scores(vertex, predictions(vertex, fp, plan, ridge), face.region)
        for regime, plan in plans.items()
        if regime != "leave-pair-out"
    }
    results["leave-pair-out"] = by_ridge[ridge]  # already scored while choosing the ridge
    return {"names": names, "still": still, "ridge": ridge, "by_ridge": by_ridge, "results": results}


def markdown(run_result: dict, command: str) -> str:
    names, results = run_result["names"], run_result["results"]
    lines = [
        f"`{command}`",
        "",
        f"Units whose control FPs do not move (E = 1 for every FP-driven deformer): {', '.join(run_result['still'])}",
        "",
        f"Ridge {run_result['ridge']:g} m² (pooled leave-pair-out E by ridge: "
        + ", ".join(f"{r:g} {s['pooled']:.3f}" for r, s in run_result["by_ridge"].items())
        + ")",
        "",
        "| unit | " + " | ".join(REGIMES) + " |",
        "|---|" + "---:|" * len(REGIMES),
    ]
    for index, name in enumerate(names):
        lines.append(f"| {name} | " + " | ".join(f"{results[r]['per_unit'][index]:.3f}" for r in REGIMES) + " |")

    def row(label: str, value) -> str:
        return f"| {label} | " + " | ".join(f"{value(results[r]):.3f}" for r in REGIMES) + " |"

    lines.append(row("**pooled**", lambda s: s["pooled"]))
    for region in evaluate.REGION_NAMES:
        lines.append(row(f"region: {region}", lambda s, region=region: s["regions"][region]))
    for label, prefix in {"brow units": "eyebrows-", "eye units": "eye-", "all units": ""}.items():
        chosen = [i for i, n in enumerate(names) if n.startswith(prefix)]
        lines.append(row(f"largest E, {label}", lambda s, chosen=chosen: s["per_unit"][chosen].max()))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", required=True, help="folder of MakeHuman .target(.gz) files")
    parser.add_argument("--face", default=str(evaluate.DEFAULT_FACE), help="sample .blend with the Head")
    args = parser.parse_args(argv)
    command = ".venv/bin/python -m scripts.bench.fp_motion_bound " + " ".join(sys.argv[1:] if argv is None else argv)
    print(markdown(run(Path(args.face), Path(args.targets)), command))
    return 0


if __name__ == "__main__":
    sys.exit(main())
