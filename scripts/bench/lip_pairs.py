"""Where a face's crossing pairs at the lips lie, frame by frame, and which step of the frame made them.

    .venv/bin/python -m scripts.bench.lip_pairs FACE.blend [--stream S.fap] [--every K] [--frames F ...]
        [--save OUT.npz]

The face (the object named Head, else the active mesh) is set up with Set Up Face and the stream (default: the demo)
played as a user plays it (`scene.frame_set`). Every K-th frame (or the `--frames` given) the skin's crossing
triangle pairs (`overlaps.crossing_pairs`, pairs crossing at rest left out) are counted three times: as Planar Bones
left the skin (before the lip guard), after the lip guard (`guard_lips`, then `press_apart`, in numpy on that copy),
and as the frame ended (after Unfold Skin). Each pair of the frame's end is printed with its triangles' corners
classed as the guard sees them (U / L: guarded upper / lower lip, u / l: of those, in the guard's contact, c: carried
beside the lips, . neither), the FP nearest its centre and its centre in the face frame (mm from FP 2.2: x to the
face's left, y up, z forward). `--save` writes the rest, the triangles, the guard's inputs and every measured frame's
three positions, for trying the guard on them without Blender (`load`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import binding_store, face_data, inner_parts, live, rest_shape
from addon.deform.lips import face_unit, guard_lips, press_apart
from addon.deform.overlaps import TOUCH, crossing_pairs
from addon.mpeg4.feature_points import FP_IDS, fp_index
from scripts.bench.variant_playback import DEFAULT_STREAMS, _face, played_positions


def new_pairs(points: np.ndarray, triangles: np.ndarray, rest: np.ndarray, at_rest: np.ndarray) -> np.ndarray:
    """(P, 2) `crossing_pairs` at `points` among triangles with a corner off `rest`, less those crossing at rest."""
    pairs = crossing_pairs(points, triangles, np.any(points != rest, axis=1))
    if not len(at_rest) or not len(pairs):
        return pairs
    span = int(max(pairs.max(), at_rest.max())) + 1
    return pairs[~np.isin(pairs[:, 0] * span + pairs[:, 1], at_rest[:, 0] * span + at_rest[:, 1])]


def classes(guard, n: int) -> np.ndarray:
    """(N,) one letter per vertex: U / L guarded upper / lower lip, u / l those in the contact, c carried, . neither."""
    label = np.full(n, ".", "<U1")
    label[guard.skin] = "c"
    label[guard.vertices[: guard.n_upper]] = "U"
    label[guard.vertices[guard.n_upper :]] = "L"
    if guard.contact is not None:
        on = guard.contact.vertices
        label[on] = np.where(label[on] == "U", "u", "l")
    return label


def touching(pairs: np.ndarray, triangles: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(P,) bool: the `pairs` whose triangles touch at rest (an edge on the other triangle, which `crossing_pairs`
    leaves out at rest): any move that does not keep the touch exactly puts them through each other or apart."""
    if not len(pairs):
        return np.zeros(0, bool)
    used = np.unique(pairs)
    met = crossing_pairs(rest, triangles[used], touch=-TOUCH)
    span = len(triangles)
    met = used[met]
    return np.isin(pairs[:, 0] * span + pairs[:, 1], np.sort(met, axis=1) @ [span, 1])


def describe(pairs, triangles, points, label, fps, axes, rest=None) -> list[str]:
    """One line per pair: its two triangles' corner classes, the nearest FP and the centre (mm, face frame), and
    whether the two touch at rest (with the `rest` positions)."""
    lines = []
    touch = touching(pairs, triangles, rest) if rest is not None else np.zeros(len(pairs), bool)
    origin = fps[fp_index("2.2")] @ axes.T
    finite = np.flatnonzero(np.isfinite(fps).all(axis=1))
    unit = 1000.0 / face_unit(fps[[fp_index("2.4"), fp_index("2.5")]], axes)  # mm of an adult's face
    for (a, b), met in zip(pairs, touch, strict=True):
        centre = points[triangles[[a, b]].ravel()].mean(axis=0)
        near = finite[np.argmin(np.linalg.norm(fps[finite] - centre, axis=1))]
        where = (centre @ axes.T - origin) * unit
        kinds = "".join(label[triangles[a]]) + "/" + "".join(label[triangles[b]])
        at = f"at ({where[0]:+.2f}, {where[1]:+.2f}, {where[2]:+.2f})"
        lines.append(f"    {kinds}  near {FP_IDS[near]:>5}  {at}" + ("  touching at rest" if met else ""))
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("face", type=Path)
    parser.add_argument("--stream", type=Path, default=DEFAULT_STREAMS[0])
    parser.add_argument("--every", type=int, default=4)
    parser.add_argument("--frames", nargs="*", type=int)
    parser.add_argument("--save", type=Path)
    parser.add_argument("--quiet", action="store_true", help="counts only, no line per pair")
    args = parser.parse_args(argv)
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=str(args.face))
    face = _face()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(args.stream)) == {"FINISHED"}
    scene, mesh = bpy.context.scene, face.data
    rest = rest_shape.reference_positions(mesh).astype(np.float64)
    parts = np.zeros(len(rest), bool)  # the eyeballs, teeth and tongue inside the face: not skin
    for members in inner_parts.group_members(face).values():
        parts[members] = True
    fans = face_data.mesh_fans(mesh)[0]
    triangles = fans[~parts[fans].any(axis=1)]  # the skin's, as `variant_playback` counts them
    at_rest = crossing_pairs(rest, triangles)
    fps = face_data.neutral_positions(face_data.fp_empties(face))
    axes = face_data.face_axes(face)
    caught: dict = {}
    keep = live._keep_lips_apart

    def spy(state, driving, off_rest):  # the skin as Planar Bones left it, before the guard
        if "planar" not in caught:  # the frame's first call; Unfold Skin's rounds call it again
            caught["planar"], caught["driving"], caught["state"] = state.out.copy(), driving.copy(), state
        return keep(state, driving, off_rest)

    live._keep_lips_apart = spy
    last = int(np.ceil(scene.frame_end))
    wanted = set(args.frames or (f for f in range(scene.frame_start, last + 1) if f % args.every == 0))
    saved = {"planar": [], "guarded": [], "final": [], "driving": [], "frames": []}
    print(f"{args.face.stem}, {args.stream.name}: frame, pairs planar / guarded / final")
    label = None
    for frame in range(scene.frame_start, last + 1):
        caught.clear()
        scene.frame_set(frame)
        if frame not in wanted or "planar" not in caught:
            continue
        guard = caught["state"].lip_guard
        label = classes(guard, len(rest)) if label is None else label
        planar = caught["planar"].astype(np.float64)
        guarded = caught["planar"].copy()
        guard_lips(guard, guarded, caught["driving"])
        press_apart(guard, guarded, native=False)
        final = played_positions(mesh)
        counts = [len(new_pairs(p, triangles, rest, at_rest)) for p in (planar, guarded.astype(np.float64))]
        pairs = new_pairs(final, triangles, rest, at_rest)
        print(f"  {frame}: {counts[0]} / {counts[1]} / {len(pairs)}")
        if not args.quiet:
            print("\n".join(describe(pairs, triangles, final, label, fps, axes, rest)))
        for key, value in (("planar", planar), ("guarded", guarded), ("final", final)):
            saved[key].append(value.astype(np.float32))
        saved["driving"].append(caught["driving"])
        saved["frames"].append(frame)
    if args.save and label is not None:
        state = caught.get("state") or live._states[face.session_uid]
        binding, masks = state.binding, binding_store.set_up_masks(face)
        np.savez_compressed(
            args.save,
            rest=rest,
            triangles=fans,
            skin=triangles,
            at_rest=at_rest,
            fps=fps,
            axes=axes,
            control_rest=binding.control_rest,
            control_ids=np.array(state.control_ids),
            rest_vertices=binding.rest_vertices,
            upper_mask=masks["upper_lip"],
            lower_mask=masks["lower_lip"],
            parts=np.zeros(0, np.intp) if state.parts is None else state.parts.all_vertices,
            **{k: np.array(v) for k, v in saved.items()},
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
