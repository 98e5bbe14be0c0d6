"""How far the lips pass through each other on the sample head, over many lip-FAP combinations within range.

    .venv/bin/python -m scripts.bench.lip_crossing [--random 1000] [--seed 0] [--dense] [--level 1]

Combinations: every viseme with every expression at half and full intensity (head rotation left out), and
`--random` seeded random frames in which each lip FAP (`fap_groups.GROUPS["lips"]`) is set with
probability 1/2 to a value drawn uniformly from its whole range, and open_jaw (3) with probability 0.3
from its range (`--dense`: every lip FAP set, no jaw). Each frame is decoded (`decode.fap_to_fp`) and
deforms the head as the add-on binds it (Planar Bones, `face_binding`, as in `evaluate_folds`), then
`addon.deform.lips` measures how deep each lip's vertices lie inside the other lip, without and with the
lip guard (`guard_lips`). Prints, per set: the combinations, how many cross (deeper than 0.01 mm), the
worst depth, how far the guard moved any vertex, and the worst combination's FAP values.

`--level L` also times `guard_lips` on the head subdivided L times (Catmull-Clark, applied: level 1 is the
17k-vertex head), float32 positions as the add-on keeps them, median of 2000 calls: at rest (nothing moves)
and with the upper lip moved 1 mm down into the lower one (Blender z is the face's up).
"""

from __future__ import annotations

import argparse
import sys
import time

import bpy
import numpy as np

from addon.blender.face_data import group_weights, mesh_fans
from addon.deform import METHODS
from addon.deform.lips import bind_lip_guard, guard_lips, lip_penetration, mouth_sides
from addon.mpeg4.control_mesh import MASK_NAMES, control_fp_ids
from addon.mpeg4.decode import fap_to_fp
from addon.mpeg4.fap_groups import GROUPS, LOWER, UPPER
from addon.mpeg4.faps import N_FAPS
from addon.mpeg4.fapu import compute_fapu
from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.speech.tables import load_expressions, load_visemes
from scripts.bench import evaluate

LIP_FAPS = tuple(n for numbers in GROUPS["lips"] for n in numbers)
OPEN_JAW = 3
CROSSING = 1e-5  # m: deeper than this counts as crossing (0.01 mm)


def viseme_expression_frames() -> np.ndarray:
    visemes, expressions = load_visemes(), load_expressions()
    frames = np.array([v + k * x for v in visemes.targets for x in expressions.targets for k in (0.5, 1.0)])
    frames[:, 47:50] = 0.0  # head rotation turns the whole object
    return frames


def random_frames(n: int, seed: int, dense: bool = False) -> np.ndarray:
    """(n, 68) seeded random lip-FAP frames within range (module docstring)."""
    rng = np.random.default_rng(seed)
    frames = np.zeros((n, N_FAPS))
    for number in LIP_FAPS:
        value = rng.uniform(LOWER[number - 1], UPPER[number - 1], n)
        frames[:, number - 1] = value if dense else np.where(rng.random(n) < 0.5, value, 0.0)
    if not dense:
        jaw = rng.uniform(LOWER[OPEN_JAW - 1], UPPER[OPEN_JAW - 1], n)
        frames[:, OPEN_JAW - 1] = np.where(rng.random(n) < 0.3, jaw, 0.0)
    return frames


def sample_lips(face: evaluate.SampleFace, neutral: np.ndarray):
    """(lip triangles, upper, lower, guard) of the sample head."""
    triangles = face.fans[0]
    masks = face.vertex_masks
    upper, lower = mouth_sides(face.rest, masks["upper_lip"], masks["lower_lip"], neutral, triangles=triangles)
    return triangles, upper, lower, bind_lip_guard(face.rest, face.control_rest, face.fp_ids, triangles, upper, lower)


def measure(face, deformer, neutral, fapu, lips, frames: np.ndarray) -> dict:
    """Worst depth without and with the guard over `frames`, and how many cross."""
    triangles, upper, lower, guard = lips
    rows = [fp_index(fp_id) for fp_id in face.fp_ids]
    depth = {"without": [], "with": []}
    moved = []
    for points in fap_to_fp(neutral, frames, fapu)[:, rows]:
        deformed = deformer.evaluate(points)
        guarded = deformed.copy()
        guard_lips(guard, guarded, points)
        moved.append(np.linalg.norm(guarded - deformed, axis=1).max())
        for name, positions in (("without", deformed), ("with", guarded)):
            into_lower, into_upper = lip_penetration(positions, triangles, upper, lower)
            depth[name].append(max(np.nanmax(into_lower), np.nanmax(into_upper)))
    return {name: np.array(values) for name, values in depth.items()} | {"moved": np.array(moved)}


def report(name: str, frames: np.ndarray, result: dict) -> None:
    print(f"\n{name}: {len(frames)} combinations")
    print("| lip guard | crossing (> 0.01 mm) | worst depth (mm) |")
    print("|---|---:|---:|")
    for guard in ("without", "with"):
        depth = result[guard]
        print(f"| {guard} | {int(np.sum(depth > CROSSING))} | {1e3 * depth.max():.3f} |")
    print(
        f"guard moved a vertex by at most {1e3 * result['moved'].max():.2f} mm (mean over frames of the most: "
        f"{1e3 * result['moved'].mean():.2f} mm)"
    )
    for guard in ("without", "with"):
        k = int(np.argmax(result[guard]))
        values = {n + 1: round(float(v)) for n, v in enumerate(frames[k]) if v}
        print(f"worst {guard} the guard (combination {k}): {values}")


def time_guard(level: int, neutral: np.ndarray) -> None:
    """Median time of `guard_lips` on the sample head subdivided `level` times."""
    bpy.ops.wm.open_mainfile(filepath=str(evaluate.DEFAULT_FACE))
    head = bpy.data.objects[evaluate.HEAD]
    if level:
        modifier = head.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = level
        bpy.context.view_layer.objects.active = head
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    rest = evaluate.read_vertices(head.data).astype(np.float64)
    masks = group_weights(head, MASK_NAMES)
    triangles = mesh_fans(head.data)[0]
    upper, lower = mouth_sides(rest, masks["upper_lip"], masks["lower_lip"], neutral, triangles=triangles)
    ids = control_fp_ids(FP_IDS)
    control = neutral[[fp_index(fp_id) for fp_id in ids]]
    guard = bind_lip_guard(rest, control, ids, triangles, upper, lower)
    pressed = rest.astype(np.float32)
    pressed[upper] -= np.float32(1e-3) * np.array([0.0, 0.0, 1.0], np.float32)  # the upper lip 1 mm down
    for name, positions in (("at rest", rest.astype(np.float32)), ("upper lip pressed 1 mm down", pressed)):
        times = []
        for _ in range(2000):
            out = positions.copy()
            start = time.perf_counter()
            guard_lips(guard, out, control)
            times.append(time.perf_counter() - start)
        moved = int(np.sum(np.any(out != positions, axis=1)))
        print(
            f"guard_lips at {len(rest)} vertices ({len(guard.vertices)} guarded), {name} ({moved} moved): "
            f"median {1e3 * np.median(times):.4f} ms"
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=1000, help="random combinations")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dense", action="store_true", help="set every lip FAP in every random frame")
    parser.add_argument("--level", type=int, default=None, help="also time the guard at this subdivision level")
    args = parser.parse_args()
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    empties = {o["mpeg4_fp"]: o for o in bpy.data.collections[f"{evaluate.HEAD} FPs"].objects if "mpeg4_fp" in o}
    neutral = np.array([empties[fp_id].location for fp_id in FP_IDS], dtype=np.float64)
    fapu = compute_fapu({fp_id: np.array(o.location) for fp_id, o in empties.items()})
    params = face.bind_params("planar_bones", 1.0, 2.0, "face")
    deformer = METHODS["planar_bones"](face.rest, face.control_rest, face.triangles, **params)
    lips = sample_lips(face, neutral)
    print(f"lips: {int(lips[1].sum())} upper and {int(lips[2].sum())} lower vertices in the mouth box")
    for name, frames in (
        ("visemes x expressions (0.5, 1)", viseme_expression_frames()),
        (f"random lip FAPs ({'dense' if args.dense else 'sparse, with open_jaw'}, seed {args.seed})",
         random_frames(args.random, args.seed, args.dense)),
    ):  # fmt: skip
        report(name, frames, measure(face, deformer, neutral, fapu, lips, frames))
    if args.level is not None:
        time_guard(args.level, neutral)
    return 0


if __name__ == "__main__":
    sys.exit(main())
