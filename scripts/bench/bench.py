"""End to end: a played frame of the add-on against Blender's Surface Deform, as a user waits for it.

    .venv/bin/python -m scripts.bench.bench [--levels 0 1 2] [--frames 100] [--stream FILE.fap] [--json OUT]
        [--no-unfold]

For each size (the sample head, and its Catmull-Clark subdivisions at levels 1 and 2, applied), in one
process:
- the add-on as a user has it: the head set up with Set Up Face (its own frame handler, its binding
  store), the stream imported onto the FP empties with Import FAP Stream;
- the best peer, Blender's Surface Deform: a copy of the head at rest, bound to a copy of the add-on's
  control mesh whose every vertex is hooked (a Hook modifier) to a copy of its FP empty keyed by the same
  action, so the same animation drives both.
The two live in two scenes that share no object (the peer's empties are copies keyed by the same actions,
its eyes, teeth and tongue copies driven by them), so a `frame_set` evaluates one side only.
Every frame, in alternating order, each side runs `scene.frame_set(f)` and then reads the evaluated
mesh back with `foreach_get` into a float32 buffer; each figure is the median over the frames after two
warm-up frames. `kernel_ms` is `planar_bones.evaluate` alone on the same control positions (a footnote:
it leaves out what Blender does around it). `bind_s` is Set Up Face; `binding_mb` the binding as saved in the .blend.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import binding_store, face_data, live, rest_shape
from addon.deform.planar_bones import evaluate
from addon.mpeg4.fap_file import read_fap, write_fap
from scripts import convert
from scripts.bench.surface_deform import SurfaceDeform, copy_object

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
DEMO = ROOT / "sample_blends" / "demo.fap"
WARM_UP = 2


def _operator(op, **kwargs) -> None:
    if op(**kwargs) != {"FINISHED"}:
        raise SystemExit(f"{op.idname()} did not finish")


def set_up_sample(level: int) -> tuple[bpy.types.Object, float]:
    """Open the sample, subdivide the head `level` times (applied) and set it up; returns (head, set-up time)."""
    bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
    head = bpy.data.objects["Head"]
    convert.select_only(head)
    _operator(bpy.ops.mpeg4.remove_face)
    if level:
        modifier = head.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = level
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    start = time.perf_counter()
    _operator(bpy.ops.mpeg4.setup_face)
    return head, time.perf_counter() - start


def prepare(level: int, stream: Path) -> tuple[bpy.types.Object, float]:
    """The set-up head at `level` with the stream imported; returns (head, set-up time)."""
    head, bind_s = set_up_sample(level)
    _operator(bpy.ops.mpeg4.import_fap, filepath=str(stream), start_frame=1)
    return head, bind_s


def peer_scene(head: bpy.types.Object) -> tuple[bpy.types.Scene, SurfaceDeform]:
    """A second scene with the same content but Surface Deform in place of the add-on, sharing no object.

    Copies of the head (at rest), of its FP empties (keyed by the same actions), of the control mesh (each
    vertex hooked to its empty's copy) and of the eyes, teeth and tongue (their drivers retargeted to the
    copies). Sharing objects would make each scene's depsgraph evaluate what the other one changed.
    """
    settings = head.mpeg4_face
    scene = bpy.data.scenes.new("Surface Deform")
    scene.frame_start, scene.frame_end = bpy.context.scene.frame_start, bpy.context.scene.frame_end
    scene.render.fps, scene.render.fps_base = bpy.context.scene.render.fps, bpy.context.scene.render.fps_base
    rest = copy_object(head, "Head (Surface Deform)")
    for coll in list(rest.users_collection):
        coll.objects.unlink(rest)
    scene.collection.objects.link(rest)
    rest.property_unset("mpeg4_face")
    rest.animation_data_clear()
    rest.data.attributes["position"].data.foreach_set("vector", rest_shape.stored_rest(head.data).ravel())
    copies = {}
    for child in head.children:
        if child == settings.control_object or child.type not in {"EMPTY", "MESH"}:
            continue
        copy = child.copy()  # shares the action: the same keys drive both
        if child.type == "MESH":
            copy.data = child.data.copy()
        scene.collection.objects.link(copy)
        copy.parent = rest
        copy.matrix_parent_inverse = child.matrix_parent_inverse.copy()
        copies[child] = copy
    for copy in copies.values():  # the followers' drivers read the FP empties' copies
        for driver in copy.animation_data.drivers if copy.animation_data else ():
            for variable in driver.driver.variables:
                for target in variable.targets:
                    if target.id in copies:
                        target.id = copies[target.id]
    control = settings.control_object.copy()
    control.data = settings.control_object.data.copy()
    scene.collection.objects.link(control)
    control.parent = rest
    control.matrix_parent_inverse = settings.control_object.matrix_parent_inverse.copy()
    empties = {ob.get(face_data.FP_PROP): ob for ob in copies.values() if ob.get(face_data.FP_PROP)}
    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
        scene.view_layers[0].update()
        for index, fp_id in enumerate(control.data[face_data.FP_IDS_PROP]):
            hook = control.modifiers.new(f"Hook {fp_id}", "HOOK")
            hook.object = empties[fp_id]
            hook.vertex_indices_set([index])
            # identity at rest: the hook's inverse undoes the empty's rest transform in the control's space
            hook.matrix_inverse = empties[fp_id].matrix_world.inverted() @ control.matrix_world
        peer = SurfaceDeform.bind(rest, control, name="Surface Deform", report=print)
    return scene, peer


def _read(ob, depsgraph, out: np.ndarray) -> None:
    ob.evaluated_get(depsgraph).data.attributes["position"].data.foreach_get("vector", out)


def measure(level: int, frames: int, stream: Path, unfold_skin: bool = True) -> dict:
    head, bind_s = prepare(level, stream)
    head.mpeg4_face.unfold_skin = unfold_skin
    scene = bpy.context.scene
    depsgraph = scene.view_layers[0].depsgraph
    peer_scene_, peer = peer_scene(head)
    peer_depsgraph = peer_scene_.view_layers[0].depsgraph
    n = len(head.data.vertices)
    out_pb = np.empty(n * 3, np.float32)
    out_sd = np.empty(n * 3, np.float32)
    kernel_out = np.empty((n, 3), np.float32)
    binding = binding_store.load(head)
    pb, sd, kernel = [], [], []
    first = scene.frame_start
    for i in range(frames + WARM_UP):
        frame = first + i
        sides = [("pb", scene, depsgraph, head, out_pb), ("sd", peer_scene_, peer_depsgraph, peer.obj, out_sd)]
        if i % 2:
            sides.reverse()
        timings = {}
        for name, sc, dg, ob, out in sides:
            start = time.perf_counter()
            sc.frame_set(frame)
            _read(ob, dg, out)
            timings[name] = time.perf_counter() - start
        points = live.control_positions(head, live._state(head))
        start = time.perf_counter()
        evaluate(binding, points, out=kernel_out)
        timings["kernel"] = time.perf_counter() - start
        if i >= WARM_UP:
            pb.append(timings["pb"])
            sd.append(timings["sd"])
            kernel.append(timings["kernel"])
    binding_bytes = binding_store.stored_bytes(head)
    planar_bones_ms = 1000 * float(np.median(pb))
    surface_deform_ms = 1000 * float(np.median(sd))
    return {
        "level": level,
        "vertices": n,
        "planar_bones_ms": round(planar_bones_ms, 2),
        "surface_deform_ms": round(surface_deform_ms, 2),
        "ratio": round(planar_bones_ms / surface_deform_ms, 2),
        "kernel_ms": round(1000 * float(np.median(kernel)), 2),
        "bind_s": round(bind_s, 2),
        "binding_mb": round(binding_bytes / 2**20, 1),
    }


def without_head_turns(path: Path, folder: Path) -> Path:
    """The stream without FAPs 48-50: head turns move the face object, which the peer's copy does not
    follow, and they cost the same on both sides (an object transform)."""
    stream = read_fap(path)
    stream.mask[:, 47:50] = False
    stream.values[:, 47:50] = 0.0
    out = folder / path.name
    write_fap(stream, out)
    return out


def table(sizes: list[dict], frames: int, stream: Path) -> str:
    lines = [
        f"Medians over {frames} frames of `{stream.name}` (head turns left out); numpy {np.__version__}, "
        f"Blender {bpy.app.version_string}.",
        "",
        "| vertices | add-on frame (ms) | Surface Deform frame (ms) | ratio | kernel only (ms) | set-up (s) "
        "| binding (MB) |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in sizes:
        lines.append(
            f"| {s['vertices']} | {s['planar_bones_ms']:.2f} | {s['surface_deform_ms']:.2f} | {s['ratio']:.2f} "
            f"| {s['kernel_ms']:.2f} | {s['bind_s']:.2f} | {s['binding_mb']:.1f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2], choices=[0, 1, 2, 3])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--stream", type=Path, default=DEMO, help="the .fap stream both sides play")
    parser.add_argument("--json", type=Path, help="also write the figures as JSON")
    parser.add_argument("--no-unfold", action="store_true", help="play with Unfold Skin off")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error("--frames must be at least 1")
    addon.register()
    with tempfile.TemporaryDirectory() as folder:
        stream = without_head_turns(args.stream, Path(folder))
        sizes = [measure(level, args.frames, stream, not args.no_unfold) for level in args.levels]
    print(table(sizes, args.frames, args.stream))
    if args.json:
        args.json.write_text(json.dumps({"sizes": sizes}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
