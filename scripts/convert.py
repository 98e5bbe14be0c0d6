"""Batch conversion: FAP streams -> baked face animation (Alembic), a preview video and a contact sheet.

    blender --background FACE.blend --python scripts/convert.py -- IN.fap... -o OUTDIR [options]
    python -m scripts.convert --face FACE.blend IN.fap... -o OUTDIR [options]      (bpy module)

Every argument is checked before any work: the files exist and can be read, the options are in range,
no two streams would write the same outputs, the output folder can be written and the face file has a
face. Each problem stops the run with one line `convert.py: error: ...` and exit status 2.

Then, for each stream: open the face file afresh, set the face up if it is not yet, import the stream
(one stream frame per scene frame, at the stream's frame rate), bake the deformation to a PC2 point
cache, export Alembic with Blender's own exporter, render a Workbench (or Cycles) preview MP4 and a PNG
contact sheet. One line per stream, `[i/n] PATH: ok ...` or `[i/n] PATH: FAILED: reason`, then
`N converted, M failed in T s`; a stream that fails leaves no outputs and the others still convert; the
exit status is 1 if any failed, 130 after Ctrl+C.

Blender's own output while a stream converts (a line or more per rendered frame) goes to `OUTDIR/STEM.log`;
stderr shows a progress bar instead (on a terminal; otherwise a line at 25, 50 and 75 %).

`--jobs N` converts each stream in a Blender process of its own, N at a time: the command that started
this one, given that single stream (see `child_command`). The lines still come in stream order; a process
that ends without its line (killed, crashed) makes its stream FAILED with how it ended.

The add-on is the installed extension when Blender has it enabled, else the `addon` package of the
checkout this script sits in, else the installed extension enabled for this run (the bpy module does
not enable extensions by itself). So a copy of this file alone works wherever the extension is installed.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import functools
import importlib
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

EXTENSION_ID = "mpeg4_face"  # the manifest's id: installed, the add-on is the package bl_ext.<repo>.mpeg4_face
RESOLUTIONS = (16, 8192)
SHEET_FRAMES = (0, 100)
JOBS = (1, 64)
ENGINES = ("WORKBENCH", "CYCLES")
FACE_ENGINES = {"planar": "PLANAR_BONES", "elastic": "ELASTIC_BONES"}  # --engine-face -> Object.mpeg4_face.engine
MAX_CACHE_BYTES = 4 * 2**30  # a point cache on disk beyond this is a mistaken frame range, not a wish
OUTPUT_SUFFIXES = (".pc2", ".abc", ".mp4", "_sheet.png", ".glb")
CAPTURE_SUFFIXES = (".csv", ".json")  # ARKit captures: converted to a FAP stream, which is written as STEM.fap
ARKIT_CSV_SUFFIX = "_arkit.csv"
SCRATCH_SUFFIXES = ("_sheet.frame.png",)  # the contact sheet's one-frame renders


class ConvertError(Exception):
    """A problem with the arguments or with one stream; the message is the whole report."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, without the usage block
        self.exit(2, f"{self.prog}: error: {message}\n")


def _int_in(low: int, high: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number from {low} to {high}")
        return value

    return parse


def frame_range(text: str) -> tuple[int | None, int | None]:
    """`FIRST:LAST` in stream frames, both included; either end may be left out (`10:`, `:50`)."""
    first, colon, last = text.partition(":")
    ends = (first.strip(), last.strip())
    if not colon or not all(end == "" or end.isdigit() for end in ends):
        raise argparse.ArgumentTypeError(f"{text!r} is not FIRST:LAST in whole frame numbers, e.g. 0:100")
    lo, hi = (int(end) if end else None for end in ends)
    if lo is not None and hi is not None and hi < lo:
        raise argparse.ArgumentTypeError(f"{text!r} ends before it starts")
    return lo, hi


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = _Parser(prog="convert.py", description="Convert MPEG-4 FAP streams on a face.")
    parser.add_argument(
        "streams",
        nargs="*",
        type=Path,
        help=".fap files, or ARKit captures (Live Link Face .csv, Audio2Face .json, a CSV/JSON of the 52 weights)",
    )
    parser.add_argument("-o", "--out", type=Path, required=True, help="output folder")
    parser.add_argument("--face", type=Path, help="the face .blend (default: the file Blender opened)")
    parser.add_argument("--object", help="name of the face mesh (default: the first mesh with feature points)")
    parser.add_argument(
        "--resolution",
        type=_int_in(*RESOLUTIONS),
        default=480,
        help=f"preview height and width in pixels ({RESOLUTIONS[0]} to {RESOLUTIONS[1]})",
    )
    parser.add_argument("--frames", type=frame_range, help="stream frames to convert, FIRST:LAST, e.g. 0:100")
    parser.add_argument("--engine", choices=ENGINES, default=ENGINES[0], help="the preview's render engine")
    parser.add_argument(
        "--engine-face",
        choices=tuple(FACE_ENGINES),
        default="planar",
        help="what moves the face: Planar Bones (baked to a point cache) or Elastic Bones (a skeleton, baked to keys)",
    )
    parser.add_argument(
        "--glb",
        action="store_true",
        help="also write STEM.glb: face, skeleton and animation (with --engine-face elastic)",
    )
    parser.add_argument(
        "--arkit-glb",
        action="store_true",
        help="also write FACE_arkit.glb: the face and its parts with the 52 ARKit shape keys as morph targets",
    )
    parser.add_argument(
        "--arkit-csv",
        action="store_true",
        help="also write STEM_arkit.csv: each stream as ARKit weights (Live Link Face CSV) and its round trip error",
    )
    parser.add_argument("--no-video", action="store_true", help="skip the preview video")
    parser.add_argument(
        "--audio", type=Path, help="a sound file for the preview video, from the stream's frame 0 (one stream only)"
    )
    parser.add_argument(
        "--sheet",
        type=_int_in(*SHEET_FRAMES),
        default=12,
        help=f"frames on the contact sheet (0: no sheet; at most {SHEET_FRAMES[1]})",
    )
    parser.add_argument(
        "--jobs",
        type=_int_in(*JOBS),
        default=1,
        help="streams converted at once, each in a Blender process of its own (1: one after another, in this one)",
    )
    return parser.parse_intermixed_args(argv)


def stream_options(args) -> list[str]:
    """The options that shape one stream's outputs, as this script's command line takes them."""
    options = ["--resolution", str(args.resolution), "--engine", args.engine, "--sheet", str(args.sheet)]
    if args.engine_face != "planar":
        options += ["--engine-face", args.engine_face]
    if args.glb:
        options.append("--glb")
    if args.arkit_csv:
        options.append("--arkit-csv")
    if args.frames:
        options.append("--frames=" + ":".join("" if end is None else str(end) for end in args.frames))
    if args.object:
        options.append(f"--object={args.object}")  # one argument, even for a name that starts with '-'
    if args.no_video:
        options.append("--no-video")
    return options


def script_argv() -> list[str]:
    if "--" in sys.argv:
        return sys.argv[sys.argv.index("--") + 1 :]
    return sys.argv[1:] if not bpy.app.background or bpy.app.binary_path == "" else []


@functools.cache
def addon_package():
    """The add-on's package, registered (see the module's docstring for which one)."""
    import addon_utils  # Blender's own module, importable once bpy is

    installed = [
        f"bl_ext.{repo.module}.{EXTENSION_ID}"
        for repo in bpy.context.preferences.extensions.repos
        if repo.enabled and (Path(repo.directory) / EXTENSION_ID / "__init__.py").is_file()
    ]
    for name in installed:
        if addon_utils.check(name)[1]:
            return importlib.import_module(name)
    checkout = Path(__file__).resolve().parents[1]
    if (checkout / "addon" / "__init__.py").is_file():
        # the one path set-up of the scripts: `blender --python` runs this file without the checkout on sys.path
        if str(checkout) not in sys.path:
            sys.path.insert(0, str(checkout))
        import addon

        if not hasattr(bpy.types, "MPEG4_OT_setup_face"):
            addon.register()
        return addon
    for name in installed:
        addon_utils.enable(name, default_set=False)
        if addon_utils.check(name)[1]:
            return importlib.import_module(name)
    raise ConvertError(
        f"the MPEG-4 face extension ({EXTENSION_ID}) is not installed in this Blender and this script is not "
        "in a checkout of it"
    )


def _addon(module: str):
    """A module of the add-on, e.g. `_addon("blender.face_data")`, whatever the add-on's package is called."""
    return importlib.import_module(f"{addon_package().__name__}.{module}")


def check_input(path: Path, what: str) -> None:
    if not path.exists():
        raise ConvertError(f"{what} not found: {path}")
    if not path.is_file():
        raise ConvertError(f"{what} is not a regular file: {path}")
    try:
        with path.open("rb"):
            pass
    except OSError as exc:
        raise ConvertError(f"cannot read {what} {path}: {exc.strerror}") from None


def check_distinct_outputs(streams: list[Path]) -> None:
    """Outputs are named after the stream's stem, so two streams with one stem would overwrite each other."""
    seen: dict[str, Path] = {}
    for stream in streams:
        key = stream.stem.casefold()  # case-insensitive file systems would overwrite too
        if key in seen:
            if seen[key].resolve() == stream.resolve():
                raise ConvertError(f"{stream} is given twice")
            raise ConvertError(f"{seen[key]} and {stream} would both write {stream.stem}.*: rename one")
        seen[key] = stream


def check_output_folder(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        raise ConvertError(f"cannot write to the output folder {out}: {exc.strerror}") from None


def check_arguments(args) -> Path:
    """Every check that needs no Blender data, before any work; returns the face file."""
    face_file = args.face or (Path(bpy.data.filepath) if bpy.data.filepath else None)
    if face_file is None:
        raise ConvertError("give the face file: --face FACE.blend (or open it with blender FACE.blend)")
    check_input(face_file, "face file")
    if not args.streams and not args.arkit_glb:
        raise ConvertError("give the streams to convert (or --arkit-glb to export the face's ARKit shape keys)")
    for stream in args.streams:
        check_input(stream, "stream")
    check_distinct_outputs(args.streams)
    if args.audio is not None:
        check_input(args.audio, "audio file")
        if len(args.streams) > 1:
            raise ConvertError(f"--audio is the sound of one stream, and {len(args.streams)} streams are given")
    if args.glb and args.engine_face != "elastic":
        raise ConvertError("--glb exports a skeleton and its keys: add --engine-face elastic")
    check_output_folder(args.out)
    return face_file.resolve()


def pick_face(name: str | None):
    face_data = _addon("blender.face_data")
    if name:
        face = bpy.data.objects.get(name)
        if face is None or face.type != "MESH":
            raise ConvertError(f"no mesh object named {name!r} in the face file")
        if not face_data.fp_empties(face):
            raise ConvertError(
                f"the mesh {name!r} has no feature points (no '{face_data.fp_collection_name(face)}' collection "
                "of FP empties): name the face mesh with --object, or leave it out to take the first face"
            )
        return face
    for ob in bpy.data.objects:
        if ob.type == "MESH" and face_data.fp_empties(ob):
            return ob
    raise ConvertError("the face file has no face with feature points (a mesh with a '<name> FPs' collection)")


def open_face(face_file: Path, name: str | None):
    try:
        bpy.ops.wm.open_mainfile(filepath=str(face_file))
    except RuntimeError as exc:
        raise ConvertError(f"cannot open the face file {face_file}: {_message(exc)}") from None
    return pick_face(name)


def scene_rate(fps: float) -> tuple[int, float]:
    """Blender's (fps, fps_base) for a stream's frame rate, or ConvertError if Blender cannot play it."""
    limits = bpy.types.RenderSettings.bl_rna.properties
    rate = max(1, round(fps))
    base = rate / fps
    if not (rate <= limits["fps"].hard_max and limits["fps_base"].hard_min <= base <= limits["fps_base"].hard_max):
        raise ConvertError(f"Blender cannot play a frame rate of {fps:g} fps")
    return rate, base


def stream_frames(stream, selection, vertices: int) -> tuple[int, int]:
    """The stream frames to convert (first, last), checked against Blender's limits and the bake's memory."""
    if not len(stream.frame_numbers):
        raise ConvertError("the stream has no frames")
    first, last = int(stream.frame_numbers[0]), int(stream.frame_numbers[-1])
    lo, hi = selection or (None, None)
    if lo is not None or hi is not None:
        picked = max(first, lo if lo is not None else first), min(last, hi if hi is not None else last)
        if picked[1] < picked[0]:
            raise ConvertError(f"--frames selects no frame of the stream (its frames are {first}..{last})")
        first, last = picked
    end = bpy.types.Scene.bl_rna.properties["frame_end"].hard_max
    if last > end:
        raise ConvertError(f"frame {last} is beyond Blender's last frame {end}: choose frames with --frames")
    size = (last - first + 1) * vertices * 3 * 4
    if size > MAX_CACHE_BYTES:
        raise ConvertError(
            f"frames {first}..{last} would make a {size / 2**30:.1f} GiB point cache (at most "
            f"{MAX_CACHE_BYTES / 2**30:.0f} GiB): choose fewer frames with --frames"
        )
    return first, last


def select_only(ob):
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def frame_face(scene, face, resolution: int):
    """An orthographic camera straight in front of the face (-Y), framing its skin feature points."""
    feature_point = _addon("mpeg4.feature_points").feature_point
    points = np.array(
        [
            ob.matrix_world.translation
            for fp_id, ob in _addon("blender.face_data").fp_empties(face).items()
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


def add_audio(scene, path: Path):
    """The sound plays from scene frame 0, where the stream's frame 0 is, and goes into the MP4 as AAC."""
    _addon("blender.speech_ops").add_sound_strip(scene, path, 0)
    scene.render.ffmpeg.audio_codec = "AAC"


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
    sheet = np.empty((rows * tile, columns * tile, 4), dtype=np.float32)
    sheet[...] = tiles[0][0, 0]  # empty cells take the background (a corner pixel), not white
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


class Progress:
    """Progress on stderr: a bar redrawn in place on a terminal, else a line on passing 25, 50 and 75 %, so a
    log gets a few lines per stream instead of one per frame."""

    WIDTH = 24

    def __init__(self, out):
        self.out = out
        self.tty = out.isatty()
        self.start("")

    def start(self, label: str, total: int = 1) -> None:
        self.label, self.total, self.done = label, max(total, 1), 0
        self.drawn = None  # the (percent, note) on the terminal
        self.quarter = 0  # the last quarter written as a line

    def expect(self, total: int) -> None:
        """The number of units, once known."""
        self.total = max(total, 1)

    def advance(self, done: int, note: str = "") -> None:
        self.done = min(done, self.total)
        percent = 100 * self.done // self.total
        if self.tty and self.drawn != (percent, note):
            self.drawn = (percent, note)
            filled = self.WIDTH * self.done // self.total
            bar = f"{self.label} [{'#' * filled}{'.' * (self.WIDTH - filled)}] {percent:3d} % {note}"
            width = shutil.get_terminal_size().columns - 1  # a wrapped line could not be redrawn
            self.out.write(f"\r{bar[:width]}\033[K")
            self.out.flush()
        elif not self.tty and self.quarter < percent // 25 * 25 < 100:  # at 100 % the stream's own line follows
            self.quarter = percent // 25 * 25
            self.out.write(f"{self.label}: {percent} % ({note})\n")
            self.out.flush()

    def clear(self) -> None:
        """Take the bar off the terminal before a line goes to stdout."""
        if self.drawn is not None:
            self.out.write("\r\033[K")
            self.out.flush()
            self.drawn = None


class CtrlC:
    """Ctrl+C acted on between the steps of a conversion. Python raises KeyboardInterrupt wherever Python code
    runs, and inside an operator or a handler Blender turns it into that operator's error or drops it; so where
    Python handles SIGINT (the bpy module), a press is noted while Blender works and raised by `check()`. (The
    Blender binary handles SIGINT itself: the first press breaks a render, the second ends Blender.)"""

    def __init__(self):
        self.pressed = False

    def _note(self, *_args) -> None:
        self.pressed = True

    def check(self) -> None:
        if self.pressed:
            self.pressed = False
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def held(self):
        if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
            yield
            return
        signal.signal(signal.SIGINT, self._note)
        try:
            yield
        finally:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        self.check()


CTRL_C = CtrlC()


@contextlib.contextmanager
def counting(progress: Progress, handlers: list, units: int, note: str):
    """Advance `progress` by one unit per call of a Blender handler list (a frame baked, exported, rendered);
    a step of the conversion, where a noted Ctrl+C is raised."""
    CTRL_C.check()
    first = progress.done

    def tick(*_args):
        progress.advance(min(progress.done + 1, first + units), note)

    progress.advance(first, note)
    handlers.append(tick)
    try:
        yield
    finally:
        if tick in handlers:
            handlers.remove(tick)
    CTRL_C.check()
    progress.advance(first + units, note)


def _flush_c_stdio() -> None:
    """Blender prints through the C library too; its buffer must be empty before the descriptors move."""
    try:
        libc = ctypes.CDLL("ucrtbase" if sys.platform == "win32" else None)
        libc.fflush(None)
    except (OSError, AttributeError):
        pass


@contextlib.contextmanager
def blender_output_to(log: Path):
    """Send everything written to this process's stdout and stderr while the block runs, Blender's C-level
    lines included (`Fra:`, `Saved:`, "Append frame", one or more per rendered frame), to the file `log`."""
    sys.stdout.flush()
    sys.stderr.flush()
    _flush_c_stdio()
    saved = os.dup(1), os.dup(2)
    try:
        with log.open("wb") as sink:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            try:
                yield
            finally:
                sys.stdout.flush()
                sys.stderr.flush()
                _flush_c_stdio()
                os.dup2(saved[0], 1)
                os.dup2(saved[1], 2)
    finally:
        for fd in saved:
            os.close(fd)


def is_capture(path: Path) -> bool:
    return path.suffix.lower() in CAPTURE_SUFFIXES


def read_stream(path: Path):
    """A .fap stream, or an ARKit capture turned into one through the recipe table."""
    if is_capture(path):
        return _addon("arkit.mapping").capture_to_stream(_addon("arkit.captures").read_capture(path))
    return _addon("mpeg4.fap_file").read_fap(path)


def convert_one(face_file: Path, stream_path: Path, out_dir: Path, args, vertices: int, written: list[Path], progress):
    """Convert one stream; every file it starts writing is appended to `written` first. Returns notes for its line."""
    notes = []
    stream = read_stream(stream_path)
    first, last = stream_frames(stream, args.frames, vertices)
    fps, fps_base = scene_rate(stream.fps)  # a bad stream fails here, before the face is opened
    frames = last - first + 1
    tiles = min(args.sheet, frames)
    elastic = args.engine_face == "elastic"
    progress.expect((1 if elastic else 2) * frames + (0 if args.no_video else frames) + tiles + args.glb * frames)

    face = open_face(face_file, args.object)
    scene = bpy.context.scene
    select_only(face)
    if not face.mpeg4_face.enabled:
        bpy.ops.mpeg4.setup_face()
    if face.mpeg4_face.engine != FACE_ENGINES[args.engine_face]:
        bpy.ops.mpeg4.set_engine(engine=FACE_ENGINES[args.engine_face])
    scene.render.fps, scene.render.fps_base = fps, fps_base
    fap_path = stream_path
    if is_capture(stream_path):  # its FAP stream is an output, and what is imported
        fap_path = out_dir / f"{stream_path.stem}.fap"
        written.append(fap_path)
        _addon("mpeg4.fap_file").write_fap(stream, fap_path)
    bpy.ops.mpeg4.import_fap(filepath=str(fap_path), timing="SCENE", start_frame=0, set_frame_range=False)
    if args.arkit_csv:
        csv = out_dir / f"{stream_path.stem}{ARKIT_CSV_SUFFIX}"
        written.append(csv)
        error = _addon("blender.arkit_io").write_arkit_csv(face, stream, csv)
        notes.append(f"FAP -> ARKit -> FAP mean FP error {error * 1000:.3f} mm")
    scene.frame_start, scene.frame_end = first, last

    handlers = bpy.app.handlers
    cache, abc, video, sheet, glb = (out_dir / f"{stream_path.stem}{suffix}" for suffix in OUTPUT_SUFFIXES)
    if not elastic:  # Elastic Bones is baked already: the import keyed the skeleton
        written.append(cache)
        with counting(progress, handlers.frame_change_post, frames, "bake"):
            bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(cache))
    written.append(abc)
    with counting(progress, handlers.frame_change_post, frames, "Alembic"):
        bpy.ops.wm.alembic_export(filepath=str(abc), start=first, end=last, selected=False, evaluation_mode="RENDER")
    if not abc.exists():
        raise ConvertError("Alembic export wrote nothing")
    if args.glb:
        written.append(glb)
        with counting(progress, handlers.frame_change_post, frames, "glTF"):
            export_glb(face, glb)
    frame_face(scene, face, args.resolution)
    set_engine(scene, args.engine)
    if not args.no_video:
        if args.audio is not None:
            add_audio(scene, args.audio.resolve())
        written.append(video)
        with counting(progress, handlers.render_post, frames, "video"):
            render_video(scene, video)
    if tiles:
        written.append(sheet)
        with counting(progress, handlers.render_post, tiles, "contact sheet"):
            contact_sheet(scene, sheet, tiles)
    return notes


def export_glb(face, path: Path) -> None:
    """The face, its skeleton and the meshes that move with them (rendered children: eyes, teeth, tongue), with the
    skeleton's keys, as one binary glTF file (Blender's own exporter, over the scene's frame range)."""
    skeleton = _addon("blender.elastic_rig").skeleton_object(face)
    children = [*face.children, *skeleton.children]
    chosen = {face, skeleton, *(ob for ob in children if ob.type == "MESH" and not ob.hide_render)}
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob in chosen)
    bpy.context.view_layer.objects.active = face
    # a skin carries the skinning alone: Unfold Skin's per-frame corrections under the Armature modifier
    # (addon/blender/elastic_skin.py) stay out of the exported rest mesh and its frames (a failed export ends the
    # conversion, whose file is never saved)
    settings = face.mpeg4_face
    unfold_skin, settings.unfold_skin = settings.unfold_skin, False
    bpy.ops.export_scene.gltf(
        filepath=str(path),
        export_format="GLB",
        use_selection=True,
        export_apply=False,
        export_skins=True,
        export_morph=False,
        export_animations=True,
        export_frame_range=True,
        export_animation_mode="ACTIVE_ACTIONS",
    )
    settings.unfold_skin = unfold_skin
    if not path.exists():
        raise ConvertError("glTF export wrote nothing")


def export_arkit_glb(face_file: Path, args) -> Path:
    """OUT/FACE_arkit.glb: the face (set up if it is not yet) with its 52 ARKit shape keys as morph targets."""
    path = args.out.resolve() / f"{face_file.stem}_arkit.glb"
    face = open_face(face_file, args.object)
    select_only(face)
    if not _addon("blender.binding_store").is_bound(face):
        bpy.ops.mpeg4.setup_face()
    if face.mpeg4_face.engine != FACE_ENGINES[args.engine_face]:
        bpy.ops.mpeg4.set_engine(engine=FACE_ENGINES[args.engine_face])
    try:
        _addon("blender.arkit_io").export_arkit_glb(bpy.context, face, path)
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return path


def _message(exc: BaseException) -> str:
    """One line: Blender's operator errors come as 'Error: text\\n'; a bug also names its exception type."""
    text = " ".join(str(exc).split()).removeprefix("Error: ")
    expected = (ConvertError, OSError, RuntimeError, _addon("errors").Mpeg4Error)
    return text if isinstance(exc, expected) else f"{type(exc).__name__}: {text}"


def report(progress: Progress, i: int, streams: list[Path], outcome: str) -> None:
    progress.clear()
    print(f"[{i}/{len(streams)}] {streams[i - 1]}: {outcome}", flush=True)


def remove_outputs(out_dir: Path, stream: Path) -> None:
    """Whatever a conversion of `stream` that ended half-way may have left (not its log)."""
    for suffix in OUTPUT_SUFFIXES + SCRATCH_SUFFIXES + (ARKIT_CSV_SUFFIX,) + ((".fap",) if is_capture(stream) else ()):
        (out_dir / f"{stream.stem}{suffix}").unlink(missing_ok=True)


def convert_here(face_file: Path, args, vertices: int, progress: Progress) -> int:
    """Convert the streams one after another in this process; returns how many failed."""
    out_dir = args.out.resolve()
    failed = 0
    with CTRL_C.held():
        for i in range(1, len(args.streams) + 1):
            CTRL_C.check()
            failed += not convert_stream(face_file, i, args, out_dir, vertices, progress)
    return failed


def convert_stream(face_file: Path, i: int, args, out_dir: Path, vertices: int, progress: Progress) -> bool:
    """Convert the i-th stream here and report it; False if it failed."""
    stream = args.streams[i - 1]
    start = time.perf_counter()
    progress.start(f"[{i}/{len(args.streams)}] {stream}")
    log = out_dir / f"{stream.stem}.log"
    written: list[Path] = []
    try:
        with blender_output_to(log):
            notes = convert_one(face_file, stream.resolve(), out_dir, args, vertices, written, progress)
        names = ", ".join(p.name for p in written)
        outcome = f"ok in {time.perf_counter() - start:.1f} s -> {names}" + "".join(f"; {note}" for note in notes)
    except Exception as exc:  # one bad stream must not stop the others
        outcome = f"FAILED: {_message(exc)}"
        for path in written:
            path.unlink(missing_ok=True)
    except BaseException:  # Ctrl+C: no half-written outputs
        for path in written:
            path.unlink(missing_ok=True)
        raise
    finally:
        if log.exists() and log.stat().st_size == 0:  # the stream failed before Blender said anything
            log.unlink()
    report(progress, i, args.streams, outcome)
    return outcome.startswith("ok")


def child_command(face_file: Path, stream: Path, args) -> tuple[list[str], Path | None]:
    """The command that converts `stream` alone in a new process, started the way this one was, and the folder
    to start it in. Inside Blender that is the Blender binary (`sys.executable` is Blender's bundled Python
    there, not Blender); with the bpy module it is this interpreter, running this module from its checkout
    (`python -m scripts.convert`) or this file (a copy next to an installed extension)."""
    options = ["--face", str(face_file), str(stream), "-o", str(args.out.resolve()), *stream_options(args)]
    script = Path(__file__).resolve()
    if bpy.app.binary_path:  # "" in the bpy module
        blender = [bpy.app.binary_path, "--background", "--python-exit-code", "1", "--python", str(script), "--"]
        return [*blender, *options], None
    spec = globals().get("__spec__")  # None when run as a file
    if spec is not None and spec.name:
        return [sys.executable, "-m", spec.name, *options], script.parents[spec.name.count(".")]
    return [sys.executable, str(script), *options], None


class Child:
    """One stream converting in a process of its own; its output goes to temporary files (no pipes to drain)."""

    def __init__(self, stream: Path, command: list[str], cwd: Path | None):
        self.stream = stream
        self.crashed = False
        self.stdout = tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace")
        self.stderr = tempfile.TemporaryFile("w+", encoding="utf-8", errors="replace")
        self.process = subprocess.Popen(
            command, cwd=cwd, stdin=subprocess.DEVNULL, stdout=self.stdout, stderr=self.stderr
        )

    def outcome(self) -> str | None:
        """`ok ...` or `FAILED: reason` once the process has ended, None before."""
        status = self.process.poll()
        if status is None:
            return None
        self.stdout.seek(0)
        self.stderr.seek(0)
        stdout, stderr = self.stdout.read(), self.stderr.read()
        self.stdout.close()
        self.stderr.close()
        mine = f"[1/1] {self.stream}: "
        for line in stdout.splitlines():
            if line.startswith(mine):
                return line.removeprefix(mine)
        refusals = [line for line in stderr.splitlines() if line.startswith("convert.py: error: ")]
        if refusals:  # e.g. the face file went away after this process checked it
            return f"FAILED: {refusals[-1].removeprefix('convert.py: error: ')}"
        self.crashed = True
        how = f"exit status {status}"
        if status < 0:
            with contextlib.suppress(ValueError):
                how += f", killed by {signal.Signals(-status).name}"
        return f"FAILED: the process converting it ended without a result ({how})"

    def stop(self) -> None:
        """Ask the process to stop as Ctrl+C would (it cleans up after its current step), and end it if it has not
        within a few seconds (a step such as the video can take minutes)."""
        if self.process.poll() is None:
            if sys.platform == "win32":
                self.process.terminate()
            else:
                self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(timeout=3)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.stdout.close()
        self.stderr.close()


def convert_in_processes(face_file: Path, args, progress: Progress) -> int:
    """Convert each stream in a process of its own, at most `--jobs` at once, reporting in stream order;
    returns how many failed."""
    streams, out_dir = args.streams, args.out.resolve()
    outcomes: list[str | None] = [None] * len(streams)
    waiting = list(range(len(streams)))
    running: dict[int, Child] = {}
    reported = 0
    progress.start(f"{len(streams)} streams, {args.jobs} at once", len(streams))
    try:
        while reported < len(streams):
            while waiting and len(running) < args.jobs:
                i = waiting.pop(0)
                # a press while a child starts (after the fork, before it is recorded) would leave it running
                # unseen: noted here, it is acted on once the child is recorded, and the finally below stops it
                with CTRL_C.held():
                    running[i] = Child(streams[i].resolve(), *child_command(face_file, streams[i].resolve(), args))
            for i, child in list(running.items()):
                outcomes[i] = child.outcome()
                if outcomes[i] is not None:
                    del running[i]
                    if child.crashed:
                        remove_outputs(out_dir, streams[i])
            while reported < len(streams) and outcomes[reported] is not None:
                report(progress, reported + 1, streams, outcomes[reported])
                reported += 1
            done = sum(outcome is not None for outcome in outcomes)
            progress.advance(done, f"{done} done, {len(running)} running")
            time.sleep(0.05)
    finally:  # only after Ctrl+C (or a bug here) is anything still running
        for i, child in running.items():
            child.stop()
            remove_outputs(out_dir, streams[i])
    return sum(outcome.startswith("FAILED") for outcome in outcomes)


def main(argv: list[str] | None = None) -> int:
    started = time.perf_counter()
    args = parse_args(script_argv() if argv is None else argv)
    try:
        face_file = check_arguments(args)
        addon_package()
        vertices = len(open_face(face_file, args.object).data.vertices)
    except ConvertError as exc:
        print(f"convert.py: error: {exc}", file=sys.stderr, flush=True)
        return 2
    # the terminal's stderr, kept apart from fd 2, which Blender's output goes to while a stream converts
    if args.arkit_glb:
        try:
            path = export_arkit_glb(face_file, args)
        except Exception as exc:
            print(f"convert.py: error: ARKit glTF: {_message(exc)}", file=sys.stderr, flush=True)
            return 1
        print(f"{face_file}: ARKit glTF -> {path}", flush=True)
    progress = Progress(os.fdopen(os.dup(2), "w", encoding="utf-8", errors="replace"))
    try:
        if args.jobs > 1 and len(args.streams) > 1:
            failed = convert_in_processes(face_file, args, progress)
        else:
            failed = convert_here(face_file, args, vertices, progress)
    except KeyboardInterrupt:
        progress.clear()
        print("convert.py: interrupted", file=sys.stderr, flush=True)
        return 130
    finally:
        progress.out.close()
    converted = len(args.streams) - failed
    print(f"{converted} converted, {failed} failed in {time.perf_counter() - started:.1f} s", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
