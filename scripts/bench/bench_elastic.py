"""End to end: a played frame of Elastic Bones (Armature modifier + elastic layer) against Planar Bones, as a user
waits for it.

    .venv/bin/python -m scripts.bench.bench_elastic [--levels 0 1] [--frames 100] [--stream FILE.fap] [--json OUT]

For each size (the sample head, and its Catmull-Clark subdivisions, applied), in one process: the sample head
set up with Set Up Face and the stream imported (Planar Bones), and a second copy of the sample, set up, switched
to Elastic Bones (Set Engine) and given the same stream (which also bakes the bone keys), then moved into a
scene of its own, so a `frame_set` evaluates one side only. Every frame, in alternating order, each side runs
`scene.frame_set(f)` (the add-on's handler: Planar Bones writes the mesh, Elastic Bones poses the skeleton and
Blender evaluates the Armature modifier) and reads the evaluated mesh back with `foreach_get` into a float32
buffer; each figure is the median over the frames after two warm-up frames, as in `bench.py`. Every other frame
the elastic side runs without the add-on's frame handler: its baked bone keys and the Armature modifier alone,
what playing the exported animation costs Blender (`elastic_keys_only_ms`); of its live frames every other one
runs with Unfold Skin off (`elastic_no_unfold_ms`: the paper's skinning alone, the setting switched outside the
timing); planar runs every frame.
`switch_s` is Set Engine (skeleton, skin weights, vertex groups).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import live
from scripts import convert
from scripts.bench.bench import DEMO, SAMPLE, WARM_UP, _operator, _read


def _append_sample(scene: bpy.types.Scene) -> bpy.types.Object:
    """A copy of the sample's objects and collections in `scene`; returns its head."""
    with bpy.data.libraries.load(str(SAMPLE)) as (src, dst):
        dst.objects = list(src.objects)
        dst.collections = list(src.collections)
    for coll in dst.collections:
        scene.collection.children.link(coll)
    for ob in dst.objects:
        if not ob.users_collection:
            scene.collection.objects.link(ob)
    (head,) = [ob for ob in dst.objects if ob.type == "MESH" and ob.mpeg4_face.control_object is not None]
    return head


def _move_to_new_scene(head, scene: bpy.types.Scene) -> bpy.types.Scene:
    """Move `head`, its children and its FP collection out of `scene` into a new scene with its settings."""
    other = bpy.data.scenes.new(f"{head.name} alone")
    other.frame_start, other.frame_end = scene.frame_start, scene.frame_end
    other.render.fps, other.render.fps_base = scene.render.fps, scene.render.fps_base
    coll = head.mpeg4_face.fp_collection
    other.collection.children.link(coll)
    scene.collection.children.unlink(coll)
    for ob in [head, *head.children_recursive]:
        if scene.collection in ob.users_collection:
            other.collection.objects.link(ob)
            scene.collection.objects.unlink(ob)
    with bpy.context.temp_override(scene=other, view_layer=other.view_layers[0]):
        other.view_layers[0].update()  # makes the scene's depsgraph
    return other


def _set_up(head, level: int, stream: Path, engine: str) -> float:
    """Remove the sample's set-up, subdivide, set up, switch engine, import; returns the switch time."""
    convert.select_only(head)
    coll = head.mpeg4_face.fp_collection
    _operator(bpy.ops.mpeg4.remove_face)
    coll.name = f"{head.name} FPs"  # a second copy's is "Head FPs.001": set-up finds it by the face's name
    if level:
        modifier = head.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = level
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    _operator(bpy.ops.mpeg4.setup_face)
    start = time.perf_counter()
    if engine != "PLANAR_BONES":
        _operator(bpy.ops.mpeg4.set_engine, engine=engine)
    switch_s = time.perf_counter() - start
    _operator(bpy.ops.mpeg4.import_fap, filepath=str(stream), start_frame=1)
    return switch_s


def measure(level: int, frames: int, stream: Path) -> dict:
    bpy.ops.wm.read_homefile(use_empty=True)
    planar_scene = bpy.context.scene
    planar_scene.render.fps = 25
    planar = _append_sample(planar_scene)
    _set_up(planar, level, stream, "PLANAR_BONES")
    elastic = _append_sample(planar_scene)
    switch_s = _set_up(elastic, level, stream, "ELASTIC_BONES")
    elastic_scene = _move_to_new_scene(elastic, planar_scene)
    n = len(planar.data.vertices)
    sides = [
        ("planar", planar_scene, planar, np.empty(n * 3, np.float32)),
        ("elastic", elastic_scene, elastic, np.empty(n * 3, np.float32)),
    ]
    timings = {"planar": [], "elastic": [], "keys": [], "no_unfold": []}
    handlers = bpy.app.handlers.frame_change_post
    for i in range(2 * frames + WARM_UP):
        frame = planar_scene.frame_start + i
        keys_only = i % 2 == 1  # every other frame the elastic side plays its baked keys alone
        for name, scene, face, out in sides[:: -1 if i // 2 % 2 else 1]:
            if name == "elastic" and keys_only:
                name = "keys"
                handlers.remove(live.on_frame_change)
            elif name == "elastic" and i % 4 == 2:
                name = "no_unfold"
                face.mpeg4_face.unfold_skin = False
            depsgraph = scene.view_layers[0].depsgraph
            start = time.perf_counter()
            scene.frame_set(frame)
            _read(face, depsgraph, out)
            if i >= WARM_UP:
                timings[name].append(time.perf_counter() - start)
            if name == "keys":
                handlers.append(live.on_frame_change)
            if name == "no_unfold":
                face.mpeg4_face.unfold_skin = True
        if not np.any(sides[0][3] != sides[1][3]) and i >= WARM_UP + 10:
            raise SystemExit("the two engines gave the same mesh: the elastic side is not deforming")
    planar_ms, elastic_ms, keys_ms, no_unfold_ms = (
        1000 * float(np.median(timings[k])) for k in ("planar", "elastic", "keys", "no_unfold")
    )
    return {
        "level": level,
        "vertices": n,
        "planar_bones_ms": round(planar_ms, 2),
        "elastic_bones_ms": round(elastic_ms, 2),
        "ratio": round(elastic_ms / planar_ms, 2),
        "elastic_keys_only_ms": round(keys_ms, 2),
        "elastic_no_unfold_ms": round(no_unfold_ms, 2),
        "switch_s": round(switch_s, 2),
        "bones": len(elastic.get("mpeg4_elastic_skeleton").data.bones),
    }


def table(sizes: list[dict], frames: int, stream: Path) -> str:
    lines = [
        f"Medians over {frames} frames of `{stream.name}` for the baked keys, {frames // 2} for each live elastic "
        f"column, {2 * frames} for Planar Bones; "
        f"numpy {np.__version__}, Blender {bpy.app.version_string}.",
        "",
        "| vertices | Planar Bones frame (ms) | Elastic Bones frame (ms) | ratio | Elastic Bones, Unfold Skin off (ms) "
        "| Elastic Bones, baked keys only (ms) | Set Engine (s) |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in sizes:
        lines.append(
            f"| {s['vertices']:,} | {s['planar_bones_ms']} | {s['elastic_bones_ms']} | {s['ratio']} "
            f"| {s['elastic_no_unfold_ms']} | {s['elastic_keys_only_ms']} | {s['switch_s']} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--stream", type=Path, default=DEMO)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    addon.register()
    sizes = [measure(level, args.frames, args.stream) for level in args.levels]
    print(table(sizes, args.frames, args.stream))
    if args.json:
        args.json.write_text(json.dumps(sizes, indent=2) + "\n")


if __name__ == "__main__":
    main()
