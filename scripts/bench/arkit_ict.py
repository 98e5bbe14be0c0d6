"""The add-on's ARKit shape keys against ICT FaceKit's sculpted ARKit expressions: a check set from elsewhere
(another face, another topology, other sculptors), never tuned to.

    .venv/bin/python -m scripts.bench.arkit_ict --ict DIR [--engine planar|elastic] [--json OUT] [--blend OUT.blend]
        [--held-fps]
    .venv/bin/python -m scripts.bench.arkit_ict --ict DIR --fp-motion [--engine planar|elastic] [--json OUT]

DIR is ICT FaceKit's `FaceXModel` folder (github.com/ICT-VGL/ICT-FaceKit, MIT licence; read in place, nothing of
it ships). Its generic neutral head (OBJ, centimetres, Y up) becomes a Blender head as a user would bring it: the
face, head and neck, mouth and eye sockets (its vertices 0-14061, one piece) as one mesh, each eyeball a mesh of
its own parented to it, turned Z up and scaled to metres. Then, as a user does: Place Feature Points
Automatically, Set Up Face (Elastic Bones with `--engine elastic`), Make ARKit Shape Keys. Each ICT expression
named like an ARKit shape (`browDown_L` is browDownLeft: ICT's L is the face's own left, the side its vertices
move on, as ARKit's is; ARKit's single browInnerUp and cheekPuff are the sums of ICT's left and right ones) is
compared with our key: E = Σ‖generated − sculpted‖ / Σ‖sculpted − neutral‖ over ICT's face area (vertices
0-9408, its "full face area"), at weight 1 and at the one weight (0..2) that fits best. ICT has no tongueOut and
adds cheekRaiser and the pupils' dilation, which are not ARKit's: those are listed and left out. mouthClose is
compared like the others (in both it is the lips' closing made to be added to jawOpen; alone it presses the lips
through each other). Under the table, where the pooled error lies (`reach_breakdown`): on skin no key moves, on
skin the key under-reaches (and how far that skin lies from the nearest control FP the key moves), on eyeLookIn /
Out, and the pooled E each shape would have at its own best weight; with `--held-fps`, per shape the control FPs
the sculpt moves over 1.5 mm and the key less than 40 % as far (`held_fps`; always in the JSON).

`--fp-motion` drives the face by each expression's own motion at the feature points instead (each FP empty moved
as ICT's vertex nearest it moves, eyeballs included; as `scripts.bench.evaluate` drives the add-on by a sculpt's
FP motion), so it measures the engine, not the recipes, on another sculptor's expressions (issue 27): E, and the
spill (the share of the error on skin the sculpt moves less than 0.1 mm), per expression and pooled over the
upper face's (eye*, brow*, cheekSquint).
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.arkit.recipes import ARKIT_INDEX, ARKIT_NAMES
from addon.blender import face_data
from addon.mpeg4.control_mesh import control_fp_ids
from addon.mpeg4.feature_points import FP_IDS

SKIN = range(
    0, 14062
)  # face, head and neck, mouth socket, eye sockets (one piece: the sockets hold the lips' and lids' inner sides)
EYES = {"Eye L": range(21451, 23021), "Eye R": range(23021, 24591)}  # ICT's left eye is at +x, the face's left
FACE_AREA = 9409  # ICT's "full face area": vertices 0-9408
SCALE = 0.01  # centimetres to metres
BEST_WEIGHTS = np.linspace(0.0, 2.0, 41)
# ICT names that are not ARKit's 52, or not comparable alone
LEFT_OUT = {"cheekRaiser_L", "cheekRaiser_R", "PupilDilate_L", "PupilDilate_R"}
BOTH_SIDES = {"browInnerUp", "cheekPuff"}  # one ARKit shape, two ICT expressions


def read_obj(path: Path, faces: bool = False):
    """(N, 3) vertices of an OBJ, in Blender's axes (Z up, the face looking down -Y) and metres; with `faces`, also
    its polygons as lists of 0-based vertex indices."""
    vertices, polygons = [], []
    with path.open() as f:
        for line in f:
            if line.startswith("v "):
                vertices.append(line.split()[1:4])
            elif faces and line.startswith("f "):
                polygons.append([int(corner.split("/")[0]) - 1 for corner in line.split()[1:]])
    v = np.array(vertices, dtype=np.float64)
    v = np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1) * SCALE  # (x, y, z) Y up -> (x, -z, y) Z up
    return (v, polygons) if faces else v


def _mesh_object(name: str, vertices: np.ndarray, polygons: list, rows: range) -> bpy.types.Object:
    keep = set(rows)
    local = {v: i for i, v in enumerate(rows)}
    faces = [[local[v] for v in p] for p in polygons if all(v in keep for v in p)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices[rows.start : rows.stop].tolist(), [], faces)
    mesh.validate()
    ob = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def build_head(folder: Path) -> tuple[bpy.types.Object, np.ndarray]:
    """The ICT neutral head in an empty scene: (the head object, all ICT vertices in Blender's axes)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    vertices, polygons = read_obj(folder / "generic_neutral_mesh.obj", faces=True)
    head = _mesh_object("Head", vertices, polygons, SKIN)
    for name, rows in EYES.items():
        eye = _mesh_object(name, vertices, polygons, rows)
        eye.parent = head
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob == head)
    bpy.context.view_layer.objects.active = head
    return head, vertices


def arkit_name(ict: str) -> str | None:
    if ict in LEFT_OUT:
        return None
    if ict[:-2] in BOTH_SIDES:
        return ict[:-2]
    if ict.endswith("_L"):
        return ict[:-2] + "Left"
    if ict.endswith("_R"):
        return ict[:-2] + "Right"
    return ict


def _key(block) -> np.ndarray:
    co = np.empty(3 * len(block.data), dtype=np.float32)
    block.data.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def e_of(generated: np.ndarray, sculpted: np.ndarray) -> tuple[float, float, float]:
    """(E, Σ‖generated − sculpted‖, Σ‖sculpted‖) for (V, 3) offsets from the neutral."""
    error = float(np.linalg.norm(generated - sculpted, axis=1).sum())
    motion = float(np.linalg.norm(sculpted, axis=1).sum())
    return error / motion, error, motion


STILL_KEY_M = 5e-5  # a vertex no key moves more than this (metres) is beyond the engine's reach
UNDER_SCULPT_M, UNDER_SHARE = 1e-3, 0.3  # skin the sculpt moves over 1 mm and the key less than 30 % as far
MOVED_FP_M = 1e-3  # an FP the key moves: the vertex nearest it moves more than this
UNDER_BANDS_M = (0.01, 0.02, 0.03)  # the under-reached skin's distance from the nearest FP the key moves


def reach_breakdown(pairs: dict[str, tuple[np.ndarray, np.ndarray]], rest=None, fps=None) -> dict:
    """Where the pooled error of (generated, sculpted) (V, 3) offset pairs by name lies, as shares of it: on skin no
    key moves at all (beyond the engine's reach: the cover and the fades), on skin the sculpt moves over 1 mm and
    the key less than 30 % as far (the key under-reaching), on the four eyeLookIn / Out; and the pooled E with each
    shape at its own best weight (0..2), what sizes alone could reach. With the (V, 3) `rest` vertices and the
    (M, 3) rest FP positions `fps`, the under-reached share is also split by each vertex's distance from the
    nearest FP the key moves (its nearest vertex more than 1 mm): under 10 mm, 10-20, 20-30, beyond (or none
    moved): skin beside a moving FP the engine's falloff leaves behind, against skin no moving FP is near."""
    reach = np.max([np.linalg.norm(g, axis=1) for g, _ in pairs.values()], axis=0)
    still = reach < STILL_KEY_M
    error = motion = on_still = under = gaze = best = 0.0
    bands = np.zeros(len(UNDER_BANDS_M) + 1)
    if fps is not None:
        fps = np.asarray(fps, dtype=np.float64)
        fps = fps[np.all(np.isfinite(fps), axis=1)]
        to_fp = np.linalg.norm(np.asarray(rest)[:, None] - fps[None], axis=2)  # (V, M)
        at_fp = to_fp.argmin(axis=0)
    for name, (generated, sculpted) in pairs.items():
        errors = np.linalg.norm(generated - sculpted, axis=1)
        moved, sculpt = np.linalg.norm(generated, axis=1), np.linalg.norm(sculpted, axis=1)
        error, motion = error + errors.sum(), motion + sculpt.sum()
        on_still += errors[still].sum()
        short = (sculpt > UNDER_SCULPT_M) & (moved < UNDER_SHARE * sculpt)
        under += errors[short].sum()
        if fps is not None:
            moving = moved[at_fp] > MOVED_FP_M
            distance = to_fp[:, moving].min(axis=1) if moving.any() else np.full(len(errors), np.inf)
            band = np.searchsorted(UNDER_BANDS_M, distance, side="right")
            bands += np.bincount(band[short], errors[short], minlength=len(bands))
        gaze += errors.sum() if name.startswith(("eyeLookIn", "eyeLookOut")) else 0.0
        best += min(np.linalg.norm(w * generated - sculpted, axis=1).sum() for w in BEST_WEIGHTS)
    return {
        "vertices_no_key_moves": int(still.sum()),
        "share_on_skin_no_key_moves": on_still / error,
        "share_under_reached": under / error,
        "share_eye_look_in_out": gaze / error,
        "e_pooled_at_best_weights": best / motion,
        **({"share_under_reached_by_distance_from_a_moved_fp": (bands / error).tolist()} if fps is not None else {}),
    }


HELD_SCULPT_M, HELD_SHARE = 1.5e-3, 0.4  # an FP the sculpt moves over 1.5 mm and the key less than 40 % as far


def held_fps(pairs: dict[str, tuple[np.ndarray, np.ndarray]], rest, fps, fp_ids) -> dict[str, list]:
    """For each name, the FPs (ids `fp_ids`, rest positions (M, 3) `fps`) whose nearest of the (V, 3) `rest`
    vertices the sculpt moves over 1.5 mm and the key less than 40 % as far: [fp id, the sculpt's motion there
    (x, y, z mm, the mesh's axes), the key's (mm)], largest first. Feature points no FAP moves stay in the keys
    (Planar Bones holds a control FP still), and these are the ones the sculpt moves."""
    rest, fps = np.asarray(rest, dtype=np.float64), np.asarray(fps, dtype=np.float64)
    known = np.all(np.isfinite(fps), axis=1)
    at = np.linalg.norm(rest[:, None] - fps[known][None], axis=2).argmin(axis=0)
    ids = [fp_id for fp_id, ok in zip(fp_ids, known, strict=True) if ok]
    out = {}
    for name, (generated, sculpted) in pairs.items():
        sculpt, key = sculpted[at], np.linalg.norm(generated[at], axis=1)
        size = np.linalg.norm(sculpt, axis=1)
        held = np.flatnonzero((size > HELD_SCULPT_M) & (key < HELD_SHARE * size))
        out[name] = [
            [ids[k], np.round(1000 * sculpt[k], 1).tolist(), round(1000 * float(key[k]), 1)]
            for k in held[np.argsort(-size[held])]
        ]
    return out


def print_held_fps(held: dict[str, list]) -> None:
    print("\nFPs the sculpt moves over 1.5 mm and the key less than 40 % as far (sculpt x, y, z mm / key mm):")
    for name, rows in held.items():
        if rows:
            listed = (f"{fp_id} ({', '.join(f'{c:+.1f}' for c in v)}) / {k:.1f}" for fp_id, v, k in rows)
            print(f"- {name}: " + ", ".join(listed))


def print_breakdown(breakdown: dict) -> None:
    print(
        f"error on skin no key moves ({breakdown['vertices_no_key_moves']} vertices) "
        f"{100 * breakdown['share_on_skin_no_key_moves']:.1f} %, on skin the sculpt moves over 1 mm and the key less "
        f"than 30 % as far {100 * breakdown['share_under_reached']:.1f} %, on eyeLookIn / Out "
        f"{100 * breakdown['share_eye_look_in_out']:.1f} %; pooled E at each shape's best weight "
        f"{breakdown['e_pooled_at_best_weights']:.3f}"
    )
    bands = breakdown.get("share_under_reached_by_distance_from_a_moved_fp")
    if bands is not None:
        edges = [f"{1000 * a:.0f}" for a in UNDER_BANDS_M]
        between = [f"{a}-{b} mm" for a, b in itertools.pairwise(edges)]
        names = [f"under {edges[0]} mm", *between, "further (or none moved)"]
        shares = ", ".join(f"{name} {100 * share:.1f} %" for name, share in zip(names, bands, strict=True))
        print(f"the under-reached share by distance from the nearest FP the key moves: {shares}")


def evaluate(folder: Path, engine: str, blend: Path | None = None) -> dict:
    head, neutral = build_head(folder)
    steps = [
        ("Place Feature Points Automatically", bpy.ops.mpeg4.auto_place_feature_points),
        ("Set Up Face", bpy.ops.mpeg4.setup_face),
    ]
    for label, op in steps:
        if op() != {"FINISHED"}:
            raise SystemExit(f"{label} failed on the ICT head")
    if engine == "elastic" and bpy.ops.mpeg4.set_engine(engine="ELASTIC_BONES") != {"FINISHED"}:
        raise SystemExit("Set Engine failed on the ICT head")
    if bpy.ops.mpeg4.make_arkit_shape_keys() != {"FINISHED"}:
        raise SystemExit("Make ARKit Shape Keys failed on the ICT head")
    if blend is not None:
        bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    blocks = head.data.shape_keys.key_blocks
    base = _key(head.data.shape_keys.reference_key)
    face = slice(0, FACE_AREA)
    empties = face_data.fp_empties(head)  # the control mesh's FPs (the head stands at the origin, in world axes)
    fp_ids = [fp_id for fp_id in control_fp_ids(FP_IDS) if fp_id in empties]
    fp_rest = [empties[fp_id].matrix_world.translation for fp_id in fp_ids]
    sculpts, skipped = {}, []
    for path in sorted(folder.glob("*.obj")):
        name = arkit_name(path.stem)
        if path.stem in ("generic_neutral_mesh",) or path.stem.startswith("identity"):
            continue
        if name is None or name not in ARKIT_INDEX:
            skipped.append(path.stem)
            continue
        ict, offsets = sculpts.get(name, ((), 0.0))
        sculpts[name] = ((*ict, path.stem), offsets + (read_obj(path) - neutral)[face])
    rows, pairs = {}, {}
    for name, (ict, sculpted) in sculpts.items():
        generated = (_key(blocks[name]) - base)[face]
        pairs[name] = (generated, sculpted)
        e, error, motion = e_of(generated, sculpted)
        weighted = [e_of(w * generated, sculpted)[0] for w in BEST_WEIGHTS]
        best = int(np.argmin(weighted))
        rows[name] = {
            "ict": "+".join(ict),
            "e": e,
            "error": error,
            "motion": motion,
            "sculpt_max_mm": 1000 * float(np.linalg.norm(sculpted, axis=1).max()),
            "ours_max_mm": 1000 * float(np.linalg.norm(generated, axis=1).max()),
            "best_weight": float(BEST_WEIGHTS[best]),
            "e_best": weighted[best],
        }
    error = sum(r["error"] for r in rows.values())
    return {
        "engine": engine,
        "e_pooled": error / sum(r["motion"] for r in rows.values()),
        "below_1": sum(round(r["e"], 3) < 1.0 for r in rows.values()),  # (eyeLookIn/Out: 0.9998, still skin)
        "count": len(rows),
        "missing": [n for n in ARKIT_NAMES if n not in rows],
        "skipped": skipped,
        "per_shape": rows,
        "breakdown": reach_breakdown(pairs, neutral[face], fp_rest),
        "held_fps": held_fps(pairs, neutral[face], fp_rest, fp_ids),
    }


UPPER_FACE = ("eye", "brow", "cheekSquint")
STILL_MM = 0.1


def fp_motion(folder: Path, engine: str) -> dict:
    """E and spill of the engine driven by each ICT expression's own FP motion (`--fp-motion`)."""
    from addon.blender import live

    head, neutral = build_head(folder)
    for label, op in (
        ("Place Feature Points Automatically", bpy.ops.mpeg4.auto_place_feature_points),
        ("Set Up Face", bpy.ops.mpeg4.setup_face),
    ):
        if op() != {"FINISHED"}:
            raise SystemExit(f"{label} failed on the ICT head")
    if engine == "elastic" and bpy.ops.mpeg4.set_engine(engine="ELASTIC_BONES") != {"FINISHED"}:
        raise SystemExit("Set Engine failed on the ICT head")
    empties = face_data.fp_empties(head)
    at_rest = {fp_id: np.array(ob.location) for fp_id, ob in empties.items()}
    nearest = {fp_id: int(np.argmin(np.linalg.norm(neutral - at_rest[fp_id], axis=1))) for fp_id in empties}
    face = slice(0, FACE_AREA)
    out = np.empty(3 * len(head.data.vertices), np.float32)
    rows = {}
    for path in sorted(folder.glob("*.obj")):
        if path.stem == "generic_neutral_mesh" or path.stem.startswith("identity") or path.stem in LEFT_OUT:
            continue
        offsets = read_obj(path) - neutral
        for fp_id, ob in empties.items():
            ob.location = at_rest[fp_id] + offsets[nearest[fp_id]]
        bpy.context.view_layer.update()
        live.apply_face(head, force=True)
        evaluated = head.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        evaluated.attributes["position"].data.foreach_get("vector", out)
        deformed = out.reshape(-1, 3).astype(np.float64)[face] - neutral[face]
        sculpted = offsets[face]
        errors = np.linalg.norm(deformed - sculpted, axis=1)
        motion = np.linalg.norm(sculpted, axis=1)
        still = motion < STILL_MM * 1e-3
        error = float(errors.sum())
        rows[path.stem] = {"error": error, "motion": float(motion.sum()), "spill_error": float(errors[still].sum())}
        rows[path.stem]["e"] = error / rows[path.stem]["motion"]
    for fp_id, ob in empties.items():
        ob.location = at_rest[fp_id]

    def pooled(names):
        picked = [rows[n] for n in names]
        error = sum(r["error"] for r in picked)
        return error / sum(r["motion"] for r in picked), sum(r["spill_error"] for r in picked) / error

    groups = {"all": list(rows), "eyes": [n for n in rows if n.startswith("eye")]}
    groups["brows"] = [n for n in rows if n.startswith("brow")]
    groups["upper face"] = [n for n in rows if n.startswith(UPPER_FACE)]
    return {"engine": engine, "per_expression": rows, "pooled": {k: pooled(v) for k, v in groups.items()}}


def print_fp_motion(report: dict, command: str) -> None:
    print(f"`{command}`\n")
    print("| ICT expression | E | spill |\n|---|---:|---:|")
    for name, r in report["per_expression"].items():
        print(f"| {name} | {r['e']:.3f} | {100 * r['spill_error'] / max(r['error'], 1e-12):.0f} % |")
    print(f"\n{report['engine']}, driven by each expression's FP motion; pooled E (spill):")
    for group, (e, spill) in report["pooled"].items():
        print(f"- {group}: {e:.3f} ({100 * spill:.0f} %)")


def print_report(report: dict, command: str, held: bool = False) -> None:
    print(f"`{command}`\n")
    print(
        "| ARKit shape | E at weight 1 | share of error | sculpt's largest move (mm) | ours (mm) | best weight "
        "| E there |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    error = sum(r["error"] for r in report["per_shape"].values())
    for name in ARKIT_NAMES:
        r = report["per_shape"].get(name)
        if r is None:
            continue
        print(
            f"| {name} | {r['e']:.3f} | {100 * r['error'] / error:.0f}% | {r['sculpt_max_mm']:.1f} | "
            f"{r['ours_max_mm']:.1f} | {r['best_weight']:.2f} | {r['e_best']:.3f} |"
        )
    print(
        f"\npooled E {report['e_pooled']:.3f}; {report['below_1']} of {report['count']} below E 1.0 "
        f"({report['engine']}); not in ICT: {', '.join(report['missing']) or 'none'}; "
        f"left out: {', '.join(report['skipped'])}"
    )
    print_breakdown(report["breakdown"])
    if held:
        print_held_fps(report["held_fps"])


def main(argv=None) -> int:
    argv = sys.argv[sys.argv.index("--") + 1 :] if argv is None and "--" in sys.argv else argv
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ict", type=Path, required=True, help="ICT FaceKit's FaceXModel folder")
    parser.add_argument("--engine", choices=["planar", "elastic"], default="planar")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--blend", type=Path, help="save the set-up head with its keys here (to look at)")
    parser.add_argument("--fp-motion", action="store_true", help="drive the engine by each expression's FP motion")
    parser.add_argument("--held-fps", action="store_true", help="list the FPs each sculpt moves and its key holds")
    args = parser.parse_args(argv)
    if not (args.ict / "generic_neutral_mesh.obj").is_file():
        raise SystemExit(f"{args.ict}: no generic_neutral_mesh.obj (give ICT FaceKit's FaceXModel folder)")
    addon.register()
    command = ".venv/bin/python -m scripts.bench.arkit_ict " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.fp_motion:
        report = fp_motion(args.ict, args.engine)
        print_fp_motion(report, command)
    else:
        report = evaluate(args.ict, args.engine, args.blend)
        print_report(report, command, args.held_fps)
    if args.json:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
