"""Set up faces as users bring them and play streams on them: what set-up said, frame cost, folds, skin crossings,
lid edges.

    .venv/bin/python -m scripts.bench.variant_playback FACE.blend|DIR ... [--streams S.fap ...] [--every K]

Each face file (or every .blend in a folder, e.g. what `scripts.bench.variants OUT` wrote) is opened, its face
(the object named Head, else the active mesh) set up with Set Up Face, and each stream imported with the default
options and played frame by frame through `scene.frame_set`, as a user plays it. Per face and stream it prints:
the frames; the median and the largest frame time, and how many frames took more than 3x the median (over all
frames, and over the frames in which the face moved); the most faces turned over in a frame (`folds`); the most
crossing triangle pairs in a frame (`overlaps.crossings`, every K-th frame); and how far the lids' edges (the open
boundary loops nearest the pupils) lie off a smooth curve through their neighbours, at rest and at most.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_data, rest_shape
from addon.deform.folds import count_inverted
from addon.deform.overlaps import crossings, edge_roughness
from addon.mpeg4.feature_points import fp_index
from scripts.bench import evaluate_folds

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_STREAMS = (ROOT / "sample_blends" / "demo.fap", evaluate_folds.INTEROP / "copperdong_Xface" / "joy.fap")


def _face():
    face = bpy.data.objects.get("Head") or bpy.context.view_layer.objects.active
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob == face)
    bpy.context.view_layer.objects.active = face
    return face


def boundary_loops(triangles: np.ndarray) -> list[np.ndarray]:
    """The open boundaries of a triangle mesh, each an ordered loop of vertex indices."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    following: dict[int, list[int]] = {}
    for a, b in unique[counts == 1].tolist():
        following.setdefault(a, []).append(b)
        following.setdefault(b, []).append(a)
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, previous, here = [start], None, start
        seen.add(start)
        while True:
            ahead = [v for v in following[here] if v != previous and v not in seen]
            if not ahead:
                break
            previous, here = here, ahead[0]
            seen.add(here)
            loop.append(here)
        loops.append(np.array(loop))
    return loops


def lid_edges(face, rest: np.ndarray, triangles: np.ndarray) -> list[np.ndarray]:
    """The boundary loop nearest each pupil FP (3.5, 3.6) whose centre lies within an eye's width of it."""
    neutral = face_data.neutral_positions(face_data.fp_empties(face))
    loops = boundary_loops(triangles)
    chosen = []
    for pupil, corners in (("3.5", ("3.7", "3.11")), ("3.6", ("3.8", "3.12"))):
        at = neutral[fp_index(pupil)]
        a, b = (neutral[fp_index(c)] for c in corners)
        width = float(np.linalg.norm(a - b))
        near = [loop for loop in loops if np.linalg.norm(rest[loop].mean(axis=0) - at) < width]
        if near and np.isfinite(width):
            chosen.append(min(near, key=lambda loop: np.linalg.norm(rest[loop].mean(axis=0) - at)))
    return chosen


def play(face, stream: Path, every: int) -> dict:
    assert bpy.ops.mpeg4.import_fap(filepath=str(stream)) == {"FINISHED"}
    scene, mesh = bpy.context.scene, face.data
    rest = rest_shape.stored_rest(mesh).astype(np.float64)
    fans = face_data.mesh_fans(mesh)
    lids = lid_edges(face, rest, fans[0])
    buffer = np.empty(len(mesh.vertices) * 3, np.float32)
    times, moved, folds, crossed, rough = [], [], [], [], []
    scene.frame_set(scene.frame_start)
    last = rest
    for frame in range(scene.frame_start + 1, int(np.ceil(scene.frame_end)) + 1):
        start = time.perf_counter()
        scene.frame_set(frame)
        times.append(time.perf_counter() - start)
        mesh.attributes["position"].data.foreach_get("vector", buffer)
        now = buffer.reshape(-1, 3).astype(np.float64)
        moved.append(not np.array_equal(now, last))
        last = now
        folds.append(count_inverted(rest, now, *fans))
        if frame % every == 0:
            crossed.append(crossings(now, fans[0], np.any(now != rest, axis=1)))
        rough.append(max((edge_roughness(now, loop).max() for loop in lids), default=0.0))
        if face.mpeg4_face.status:
            raise SystemExit(f"{stream.name} frame {frame}: {face.mpeg4_face.status}")
    rest_rough = max((edge_roughness(rest, loop).max() for loop in lids), default=0.0)
    return {"times": np.array(times), "moved": np.array(moved), "folds": folds, "crossed": crossed}, rough, rest_rough


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="+", type=Path, help=".blend files, or folders of them")
    parser.add_argument("--streams", nargs="*", type=Path, default=list(DEFAULT_STREAMS))
    parser.add_argument("--every", type=int, default=1, help="measure crossings every K-th frame")
    args = parser.parse_args(argv)
    files = [f for p in args.faces for f in (sorted(p.glob("*.blend")) if p.is_dir() else [p])]
    addon.register()
    columns = "frames | median ms (moving) | max ms | >3x median (moving) | folds | crossings | lid edge mm"
    print(f"| face | stream | {columns} |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for path in files:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        face = _face()
        try:
            bpy.ops.mpeg4.setup_face()
        except RuntimeError as exc:
            print(f"| {path.stem} | set-up refused: {str(exc).splitlines()[0]} |||||||")
            continue
        saved = ROOT / ".variant_playback.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(saved), copy=True)
        for stream in args.streams:
            bpy.ops.wm.open_mainfile(filepath=str(saved))
            face = _face()
            got, rough, rest_rough = play(face, stream, args.every)
            t, moving = got["times"] * 1000, got["moved"]
            median, moving_median = np.median(t), np.median(t[moving]) if moving.any() else np.nan
            print(
                f"| {path.stem} | {stream.name} | {len(t)} | {median:.1f} ({moving_median:.1f}) | {t.max():.1f} | "
                f"{int((t > 3 * median).sum())} ({int((t[moving] > 3 * moving_median).sum())}) | "
                f"{max(got['folds'])} | {max(got['crossed'], default=0)} | {rest_rough * 1000:.2f} → "
                f"{max(rough, default=0.0) * 1000:.2f} |"
            )
        saved.unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
