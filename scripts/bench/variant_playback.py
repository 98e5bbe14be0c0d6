"""Set up faces as users bring them and play streams on them: what set-up said, frame cost, folds, skin crossings,
lid edges.

    .venv/bin/python -m scripts.bench.variant_playback FACE.blend|DIR ... [--streams S.fap ...] [--every K]
        [--profile N]

Each face file (or every .blend in a folder, e.g. what `scripts.bench.variants OUT` wrote) is opened, its face
(the object named Head, else the active mesh) set up with Set Up Face, and each stream imported with the default
options and played frame by frame through `scene.frame_set`, as a user plays it. Per face and stream it prints:
the frames; the median and the largest frame time, and how many frames took more than 3x the median (over all
frames, and over the frames in which the face moved), and the largest over the moving median; the same from the
process's CPU time per frame (`time.process_time`: what the frame itself cost, which other jobs on the machine
do not lengthen, as they do the wall-clock time by taking the cores away); the most faces turned
over in a frame (`folds`); the most crossing triangle pairs in a frame (`overlaps.crossings`, every K-th frame;
pairs that cross at rest already are not counted, their number in brackets); how far the upper lids' edges (the
vertices along their FPs, `lid_edges`; and the margins the eyes' centres see on the skin, `lid_margins`) lie off
a smooth curve through their neighbours, at rest and at most; how far the parts inside the face (eyeballs, teeth,
tongue) are from rigid (the most any distance between a part's vertices and its anchors changed, mm; "-" where the
face has none); and the status message that turned deformation off, if one did (playback of that stream stops there).
`--profile N` then plays each of the N slowest frames again (from the frame before it) under cProfile and prints
its time again and the functions it spent most in: a frame slow in the timed pass but not again was slowed by
other jobs.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import eyelid_rig, face_data, inner_parts, rest_shape
from addon.deform.eyelids import EYE_FPS, seen_margin_points
from addon.deform.folds import count_inverted
from addon.deform.overlaps import crossing_pairs, crossings, edge_chain, edge_roughness
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


LID_SAMPLES = 24  # points along each upper lid's FP line whose nearest vertices make its edge


def lid_edges(face, rest: np.ndarray, skin: np.ndarray) -> list[np.ndarray]:
    """Each upper lid's edge at rest: the `skin` (N,) vertices nearest LID_SAMPLES points along the line through its
    FPs (inner corner, middle of the upper lid, outer corner: 3.11-3.1-3.7 and 3.8-3.2-3.12), each once, in order."""
    neutral = face_data.neutral_positions(face_data.fp_empties(face))
    chains = []
    for ids in (("3.11", "3.1", "3.7"), ("3.8", "3.2", "3.12")):
        line = np.array([neutral[fp_index(k)] for k in ids])
        if not np.isfinite(line).all():
            continue
        chain = edge_chain(rest, np.flatnonzero(skin), line, LID_SAMPLES)
        if len(chain) >= 5:
            chains.append(chain)
    return chains


def lid_margins(face, rest: np.ndarray, skin: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each upper lid's margin at rest as the eye's centre sees it (`eyelids.seen_margin_points` on the `skin` (T, 3)
    triangles, the rig's eyeball: its centre, its radius to the pupil FP): (P, 3) corners and (P, 3) barycentric
    weights of points on the skin, evenly along the eye; `lid_edges`' vertices nearest the FP line are not the
    margin where it curves away from that line (the sample's inner corners)."""
    rig = eyelid_rig.current(face)
    if rig is None:  # no lids' turn (an eye's FPs missing)
        return []
    neutral = face_data.neutral_positions(face_data.fp_empties(face)) @ rig.axes.T
    local = np.asarray(rest, dtype=np.float64) @ rig.axes.T
    margins = []
    for eye, (_up, _low, inner, outer, pupil) in enumerate(EYE_FPS):
        ends = neutral[[fp_index(inner), fp_index(outer), fp_index(pupil)]] - rig.centres[eye]
        if not np.isfinite(ends).all():
            continue
        corners, weights = seen_margin_points(local - rig.centres[eye], skin, np.linalg.norm(ends[2]), ends[:2])
        if len(corners[0]) >= 5:
            margins.append((corners[0], weights[0]))
    return margins


def margin_roughness(points: np.ndarray, margin: tuple[np.ndarray, np.ndarray]) -> float:
    """The largest distance of a point of the lid `margin` (`lid_margins`) at `points` off the smooth curve through
    its neighbours (`overlaps.edge_roughness`)."""
    corners, weights = margin
    on_skin = np.einsum("pk,pkc->pc", weights, np.asarray(points, dtype=np.float64)[corners])
    return float(edge_roughness(on_skin, np.arange(len(on_skin)), closed=False).max())


def played_positions(mesh, buffer: np.ndarray | None = None) -> np.ndarray:
    """(N, 3) float64: the face's positions as the frame left them (a mesh with shape keys is played in the add-on's
    own key, `rest_shape.deform_target`)."""
    target = rest_shape.deform_target(mesh)
    buffer = np.empty(len(mesh.vertices) * 3, np.float32) if buffer is None else buffer
    if target is None:
        mesh.attributes["position"].data.foreach_get("vector", buffer)
    else:
        target.data.foreach_get("co", buffer)
    return buffer.reshape(-1, 3).astype(np.float64)


def play(face, stream: Path, every: int) -> dict:
    assert bpy.ops.mpeg4.import_fap(filepath=str(stream)) == {"FINISHED"}
    scene, mesh = bpy.context.scene, face.data
    rest = rest_shape.reference_positions(mesh).astype(np.float64)
    fans = face_data.mesh_fans(mesh)
    parts = np.zeros(len(rest), bool)  # the eyeballs, teeth and tongue inside the face: not skin
    for members in inner_parts.group_members(face).values():
        parts[members] = True
    skin = fans[0][~parts[fans[0]].any(axis=1)]
    lids = lid_edges(face, rest, ~parts)
    seen_rough = []
    at_rest = crossing_pairs(rest, skin)  # the surface's own crossings before anything moves are not counted
    anchored = [part_anchors(rest, members) for members in inner_parts.group_members(face).values() if len(members)]
    buffer = np.empty(len(mesh.vertices) * 3, np.float32)
    times, cpu, moved, folds, crossed, rough, bent = [], [], [], [], [], [], [0.0]
    scene.frame_set(scene.frame_start)
    margins = lid_margins(face, rest, skin)  # the lids' rig is made at the first frame played
    last = rest
    for frame in range(scene.frame_start + 1, int(np.ceil(scene.frame_end)) + 1):
        start, start_cpu = time.perf_counter(), time.process_time()
        scene.frame_set(frame)
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
        now = played_positions(mesh, buffer)
        moved.append(not np.array_equal(now, last))
        last = now
        folds.append(count_inverted(rest, now, *fans))
        if frame % every == 0:
            crossed.append(crossings(now, skin, np.any(now != rest, axis=1), at_rest))
        rough.append(max((edge_roughness(now, loop, closed=False).max() for loop in lids), default=0.0))
        seen_rough.append(max((margin_roughness(now, m) for m in margins), default=0.0))
        bent += [distance_change(rest, now, *anchors) for anchors in anchored]
        if face.mpeg4_face.status:
            status = f"frame {frame}: {face.mpeg4_face.status}"
            break
    else:
        status = ""
    rest_rough = max((edge_roughness(rest, loop, closed=False).max() for loop in lids), default=0.0)
    got = {"times": np.array(times), "cpu": np.array(cpu), "moved": np.array(moved), "folds": folds}
    got |= {"crossed": crossed, "status": status}
    got["rigid"] = max(bent) if anchored else None
    got["at_rest"] = len(at_rest)
    got["margin"] = (max(margin_roughness(rest, m) for m in margins), max(seen_rough, default=0.0)) if margins else None
    return got, rough, rest_rough


def part_anchors(rest: np.ndarray, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A part's vertices and 4 anchors among them (its first vertex, then each the farthest from those chosen): a
    rigid motion keeps every distance between them."""
    anchors = [int(members[0])]
    for _ in range(3):
        gaps = np.min([np.linalg.norm(rest[members] - rest[a], axis=1) for a in anchors], axis=0)
        anchors.append(int(members[np.argmax(gaps)]))
    return members, np.array(anchors)


def distance_change(rest: np.ndarray, now: np.ndarray, members: np.ndarray, anchors: np.ndarray) -> float:
    """The most any distance between a part's vertices and its anchors changed from rest."""
    at_rest = np.linalg.norm(rest[members][:, None] - rest[anchors][None], axis=2)
    return float(np.abs(np.linalg.norm(now[members][:, None] - now[anchors][None], axis=2) - at_rest).max())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="+", type=Path, help=".blend files, or folders of them")
    parser.add_argument("--streams", nargs="*", type=Path, default=list(DEFAULT_STREAMS))
    parser.add_argument("--every", type=int, default=1, help="measure crossings every K-th frame")
    parser.add_argument("--profile", type=int, default=0, help="profile the N slowest frames again")
    args = parser.parse_args(argv)
    files = [f for p in args.faces for f in (sorted(p.glob("*.blend")) if p.is_dir() else [p])]
    addon.register()
    columns = "frames | median ms (moving) | max ms | >3x median (moving) | max / moving median"
    columns += " | CPU: median ms (moving), max ms, max / moving median | folds"
    columns += " | crossings (at rest)"
    columns += " | lid edge mm, rest → most (FP line's vertices; seen margin) | parts rigid mm | deformation turned off"
    print(f"| face | stream | {columns} |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for path in files:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        face = _face()
        try:
            bpy.ops.mpeg4.setup_face()
        except RuntimeError as exc:
            print(f"| {path.stem} | set-up refused: {str(exc).splitlines()[0]} |||||||")
            continue
        saved = Path(tempfile.mkdtemp()) / "set_up.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(saved), copy=True)
        for stream in args.streams:
            bpy.ops.wm.open_mainfile(filepath=str(saved))
            face = _face()
            got, rough, rest_rough = play(face, stream, args.every)
            t, moving, c = got["times"] * 1000, got["moved"], got["cpu"] * 1000
            median, moving_median = np.median(t), np.median(t[moving]) if moving.any() else np.nan
            cpu_moving = np.median(c[moving]) if moving.any() else np.nan
            rigid = "-" if got["rigid"] is None else f"{got['rigid'] * 1000:.4f}"
            print(
                f"| {path.stem} | {stream.name} | {len(t)} | {median:.1f} ({moving_median:.1f}) | {t.max():.1f} | "
                f"{int((t > 3 * median).sum())} ({int((t[moving] > 3 * moving_median).sum())}) | "
                f"{t.max() / moving_median:.1f} | "
                f"{np.median(c):.1f} ({cpu_moving:.1f}), {c.max():.1f}, {c.max() / cpu_moving:.1f} | "
                f"{max(got['folds'], default=0)} | "
                f"{max(got['crossed'], default=0)} ({got['at_rest']}) | "
                f"{rest_rough * 1000:.2f} → {max(rough, default=0.0) * 1000:.2f}; "
                f"{'-' if got['margin'] is None else ' → '.join(f'{m * 1000:.2f}' for m in got['margin'])} | "
                f"{rigid} | {got['status'] or 'no'} |"
            )
            if args.profile:
                profile_slowest(got["times"], args.profile)
        saved.unlink()
        saved.parent.rmdir()
    return 0


def profile_slowest(times: np.ndarray, count: int, rows: int = 6) -> None:
    """Play each of the `count` slowest of the frames timed in `times` (from the scene's second frame on) again,
    from the frame before it, under cProfile; print its time then and the `rows` functions it spent most in."""
    scene = bpy.context.scene
    for k in np.argsort(-times)[:count]:
        frame = scene.frame_start + 1 + int(k)
        scene.frame_set(frame - 1)
        profile = cProfile.Profile()
        start = time.perf_counter()
        profile.runcall(scene.frame_set, frame)
        again = time.perf_counter() - start
        text = io.StringIO()
        pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(rows)
        calls = [line for line in text.getvalue().splitlines() if line.strip()[:1].isdigit()][1:]
        print(f"frame {frame}: {times[k] * 1000:.1f} ms timed, {again * 1000:.1f} ms again under cProfile")
        print("\n".join(calls))


if __name__ == "__main__":
    sys.exit(main())
