"""Batch conversion: FAP streams -> baked face animation (Alembic), a preview video and a contact sheet.

    blender --background FACE.blend --python scripts/convert.py -- IN.fap... -o OUTDIR [options]
    python scripts/convert.py --face FACE.blend IN.fap... -o OUTDIR [options]      (bpy module)

For each stream: open the face file afresh, set the face up if it is not yet, import the stream (the
scene takes the stream's frame rate, so there is one key per frame), bake the deformation to a PC2
point cache, export Alembic with Blender's own exporter, render a Workbench (or Cycles) preview MP4
and a PNG contact sheet. One progress line per file; a file that fails is reported and the others
still convert; the exit status is 1 if any failed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _ensure_extension():
    """Use the installed extension if Blender has it, else register the package from this checkout."""
    if hasattr(bpy.types, "MPEG4_OT_setup_face"):
        return
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    import addon

    addon.register()


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="convert.py", description="Convert MPEG-4 FAP streams on a face.")
    parser.add_argument("streams", nargs="+", type=Path, help=".fap files")
    parser.add_argument("-o", "--out", type=Path, required=True, help="output folder")
    parser.add_argument("--face", type=Path, help="the face .blend (default: the file Blender opened)")
    parser.add_argument("--object", help="name of the face mesh (default: the set-up face, or the mesh with FPs)")
    parser.add_argument("--resolution", type=int, default=480, help="preview height and width in pixels")
    parser.add_argument("--frames", help="frame range of the stream to convert, e.g. 0:100 (stream frames)")
    parser.add_argument("--engine", choices=("WORKBENCH", "CYCLES"), default="WORKBENCH")
    parser.add_argument("--no-video", action="store_true", help="skip the preview video")
    parser.add_argument("--sheet", type=int, default=12, help="frames on the contact sheet (0: none)")
    return parser.parse_args(argv)


def script_argv() -> list[str]:
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1 :]
    return sys.argv[1:] if not bpy.app.background or bpy.app.binary_path == "" else []


class ConvertError(Exception):
    pass


def pick_face(name: str | None):
    if name:
        face = bpy.data.objects.get(name)
        if face is None or face.type != "MESH":
            raise ConvertError(f"no mesh object named {name!r} in the face file")
        return face
    candidates = [
        ob
        for ob in bpy.data.objects
        if ob.type == "MESH"
        and (ob.mpeg4_face.control_object is not None or bpy.data.collections.get(f"{ob.name} FPs") is not None)
    ]
    if not candidates:
        raise ConvertError("the face file has no face with feature points (a mesh with a '<name> FPs' collection)")
    return candidates[0]


def select_only(ob):
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def frame_face(scene, face, resolution: int):
    """An orthographic camera straight in front of the face (-Y), framing its skin feature points."""
    from addon.blender import face_data
    from addon.mpeg4.feature_points import feature_point

    points = np.array(
        [
            ob.matrix_world.translation
            for fp_id, ob in face_data.fp_empties(face).items()
            if feature_point(fp_id).surface in ("skin", "hair")
        ]
    )
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo + hi)
    size = float(max(hi[0] - lo[0], hi[2] - lo[2])) * 1.4
    cam_data = bpy.data.cameras.new("MPEG-4 Preview")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = size
    cam = bpy.data.objects.new("MPEG-4 Preview", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (centre[0], lo[1] - 4 * size, centre[2])
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    cam_data.clip_end = 10 * size
    scene.camera = cam
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100


def set_engine(scene, engine: str):
    if engine == "CYCLES":
        scene.render.engine = "CYCLES"
        scene.cycles.samples = 16
        scene.cycles.device = "CPU"
    else:
        scene.render.engine = "BLENDER_WORKBENCH"
        scene.display.shading.light = "STUDIO"
        scene.display.shading.color_type = "MATERIAL"


def _image_settings(scene, video: bool):
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5.0+
        settings.media_type = "VIDEO" if video else "IMAGE"
    settings.file_format = "FFMPEG" if video else "PNG"
    if video:
        scene.render.ffmpeg.format = "MPEG4"
        scene.render.ffmpeg.codec = "H264"
        scene.render.ffmpeg.constant_rate_factor = "MEDIUM"


def render_video(scene, path: Path):
    _image_settings(scene, video=True)
    scene.render.filepath = str(path)
    bpy.ops.render.render(animation=True)


def contact_sheet(scene, path: Path, count: int, tile: int = 320):
    """Render `count` frames spread over the range and tile them into one PNG."""
    _image_settings(scene, video=False)
    frames = np.unique(np.linspace(scene.frame_start, scene.frame_end, count).round().astype(int))
    size = (scene.render.resolution_x, scene.render.resolution_y)
    scene.render.resolution_x = scene.render.resolution_y = tile
    scratch = path.with_suffix(".frame.png")
    try:
        tiles = [render_frame(scene, int(frame), scratch) for frame in frames]
    finally:
        scratch.unlink(missing_ok=True)
        scene.render.resolution_x, scene.render.resolution_y = size
    columns = min(len(tiles), 6)
    rows = math.ceil(len(tiles) / columns)
    sheet = np.ones((rows * tile, columns * tile, 4), dtype=np.float32)
    for i, t in enumerate(tiles):  # image rows go bottom-up: first frame at the top left
        r, c = divmod(i, columns)
        sheet[(rows - 1 - r) * tile : (rows - r) * tile, c * tile : (c + 1) * tile] = t
    save_png(sheet, path)


def render_frame(scene, frame: int, scratch: Path) -> np.ndarray:
    """Render `frame` through a scratch PNG and return its (height, width, 4) float pixels (bottom row first)."""
    scene.frame_set(frame)
    scene.render.filepath = str(scratch)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(scratch))
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(height, width, 4)


def save_png(pixels: np.ndarray, path: Path) -> None:
    """Write (height, width, 4) float pixels (bottom row first, as Blender stores images) as a PNG."""
    image = bpy.data.images.new(path.stem, pixels.shape[1], pixels.shape[0], alpha=True)
    image.pixels.foreach_set(np.ascontiguousarray(pixels, dtype=np.float32).ravel())
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)


def convert_one(face_file: Path, stream_path: Path, out_dir: Path, args) -> list[Path]:
    from addon.blender import bake
    from addon.mpeg4.fap_file import read_fap

    stream = read_fap(stream_path)  # a bad file fails here, before any work
    bpy.ops.wm.open_mainfile(filepath=str(face_file))
    scene = bpy.context.scene
    face = pick_face(args.object)
    select_only(face)
    if not face.mpeg4_face.enabled:
        bpy.ops.mpeg4.setup_face()
    scene.render.fps = max(1, round(stream.fps))
    scene.render.fps_base = scene.render.fps / stream.fps
    scene.frame_start = 0
    bpy.ops.mpeg4.import_fap(filepath=str(stream_path), start_frame=0, set_frame_range=False)
    first, last = int(stream.frame_numbers[0]), int(stream.frame_numbers[-1])
    if args.frames:
        lo, _, hi = args.frames.partition(":")
        first, last = max(first, int(lo or first)), min(last, int(hi or last))
        if last < first:
            raise ConvertError(f"--frames {args.frames} selects no frame of the stream ({first}..{last})")
    scene.frame_start, scene.frame_end = first, last

    name = stream_path.stem
    outputs = []
    cache = out_dir / f"{name}.pc2"
    bake.bake_point_cache(bpy.context, face, range(first, last + 1), str(cache))
    outputs.append(cache)
    abc = out_dir / f"{name}.abc"
    bpy.ops.wm.alembic_export(filepath=str(abc), start=first, end=last, selected=False, evaluation_mode="RENDER")
    if not abc.exists():
        raise ConvertError("Alembic export wrote nothing")
    outputs.append(abc)

    frame_face(scene, face, args.resolution)
    set_engine(scene, args.engine)
    if not args.no_video:
        video = out_dir / f"{name}.mp4"
        render_video(scene, video)
        outputs.append(video)
    if args.sheet:
        sheet = out_dir / f"{name}_sheet.png"
        contact_sheet(scene, sheet, args.sheet)
        outputs.append(sheet)
    return outputs


def main(argv: list[str] | None = None) -> int:
    args = parse_args(script_argv() if argv is None else argv)
    face_file = args.face or (Path(bpy.data.filepath) if bpy.data.filepath else None)
    if face_file is None:
        print("error: give the face file: --face FACE.blend (or open it with blender FACE.blend)", file=sys.stderr)
        return 2
    if not face_file.is_file():
        print(f"error: face file not found: {face_file}", file=sys.stderr)
        return 2
    face_file = face_file.resolve()
    _ensure_extension()
    args.out.mkdir(parents=True, exist_ok=True)
    failed = 0
    for i, stream in enumerate(args.streams, 1):
        start = time.perf_counter()
        prefix = f"[{i}/{len(args.streams)}] {stream}"
        try:
            outputs = convert_one(face_file, stream.resolve(), args.out.resolve(), args)
        except Exception as exc:  # one bad stream must not stop the others
            failed += 1
            print(f"{prefix}: FAILED: {exc}", flush=True)
            continue
        names = ", ".join(p.name for p in outputs)
        print(f"{prefix}: ok in {time.perf_counter() - start:.1f} s -> {names}", flush=True)
    print(f"{len(args.streams) - failed} converted, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
