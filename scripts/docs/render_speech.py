"""The README's speech pictures on the sample head: a spoken sentence (`docs/speech_sheet.png`) and the 15 visemes
and 6 expressions (`docs/visemes.png`), Workbench close-ups with a caption under each.

    .venv/bin/python -m scripts.docs.render_speech [--out docs/] [--text "Maybe Bob should show you the map."]

The sentence is spoken with Speak Text's service (`speech_ops.speak`, espeak-ng voice en, 25 fps); each tile is
the frame nearest the centre of one phoneme, captioned with the phoneme, its viseme and its time. The visemes
and expressions play through the face tables as FAP 1 and FAP 2 of a stream (intensity 63), the path an imported
`.fap` takes.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from addon.blender import fap_io, speech_ops
from addon.mpeg4.fap_file import FapStream
from addon.mpeg4.faps import N_FAPS, VISEME_PHONEMES, Expression, Viseme
from addon.speech import espeak
from scripts import convert

ROOT = Path(__file__).resolve().parents[2]
SENTENCE = "Maybe Bob should show you the whole map."
FPS = 25
MOUTH = ("8.1", -0.01, 0.07)  # the FP the camera centres on, vertical offset (m), orthographic scale (m)
FACE = ("9.12", -0.012, 0.15)
CAPTION_HEIGHT = 44
INK = (0.0, 0.0, 0.0, 1.0)
STRESS_MARKS = "',%=!"  # espeak-ng's, left out of the captions


class Captions:
    """A scene of its own that renders one or two lines of text, black on white, as a strip of pixels."""

    def __init__(self, width: int):
        self.scene = scene = bpy.data.scenes.new("Captions")
        camera = bpy.data.objects.new("Captions", bpy.data.cameras.new("Captions"))
        camera.data.type = "ORTHO"
        camera.data.ortho_scale = width / CAPTION_HEIGHT
        camera.location.z = 10.0
        scene.collection.objects.link(camera)
        scene.camera = camera
        self.curve = bpy.data.curves.new("Caption", "FONT")
        self.curve.align_x = self.curve.align_y = "CENTER"
        self.curve.size = 0.42
        self.curve.space_line = 0.85
        ink = bpy.data.materials.new("Ink")
        ink.diffuse_color = INK
        self.curve.materials.append(ink)
        scene.collection.objects.link(bpy.data.objects.new("Caption", self.curve))
        scene.world = bpy.data.worlds.new("Paper")
        scene.world.color = (1.0, 1.0, 1.0)
        scene.render.engine = "BLENDER_WORKBENCH"
        scene.display.shading.light = "FLAT"
        scene.display.shading.color_type = "MATERIAL"
        scene.view_settings.view_transform = "Standard"
        scene.render.resolution_x, scene.render.resolution_y = width, CAPTION_HEIGHT
        scene.render.resolution_percentage = 100
        convert._image_settings(scene, video=False)

    def render(self, text: str, scratch: Path) -> np.ndarray:
        self.curve.body = text
        with bpy.context.temp_override(scene=self.scene):
            return convert.render_frame(self.scene, 0, scratch)


def open_head():
    convert.addon_package()
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / "makehuman_head.blend"))
    scene, face = bpy.context.scene, bpy.data.objects["Head"]
    convert.select_only(face)
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    return scene, face


def aim(scene, view) -> None:
    fp_id, offset, scale = view
    centre = bpy.data.objects[f"FP {fp_id}"].matrix_world.translation
    scene.camera.location.x, scene.camera.location.z = centre.x, centre.z + offset
    scene.camera.data.ortho_scale = scale


def tiles(scene, frames, captions: list[str], size: int) -> list[np.ndarray]:
    """Each frame rendered at `size` pixels with its caption under it (rows bottom-up, as Blender stores them)."""
    scene.render.resolution_x = scene.render.resolution_y = size
    writer = Captions(size)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for frame, caption in zip(frames, captions, strict=True):
            picture = convert.render_frame(scene, int(frame), Path(tmp) / "tile.png")
            out.append(np.concatenate([writer.render(caption, Path(tmp) / "caption.png"), picture], axis=0))
    bpy.data.scenes.remove(writer.scene)
    return out


def grid(images: list[np.ndarray], columns: int) -> np.ndarray:
    """Images in rows of `columns`, the first at the top left, on white."""
    height, width = images[0].shape[:2]
    rows = -(-len(images) // columns)
    sheet = np.ones((rows * height, columns * width, 4), dtype=np.float32)
    for i, image in enumerate(images):
        r, c = divmod(i, columns)
        sheet[(rows - 1 - r) * height : (rows - r) * height, c * width : (c + 1) * width] = image
    return sheet


def shapes_stream() -> FapStream:
    """Frames 0..14: the visemes; frames 15..20: the expressions. Every frame sends both FAP 1 and FAP 2, so
    nothing a previous frame set is held into the next."""
    visemes = [(v, v, 63, 0) for v in Viseme] + [(0, 0, 63, 0)] * (len(Expression) - 1)
    expressions = [(0, 0, 0, 0, 0, 0)] * len(Viseme) + [(e, 63, 0, 0, 0, 0) for e in Expression if e]
    n = len(visemes)
    mask = np.zeros((n, N_FAPS), dtype=bool)
    mask[:, :2] = True
    fields = np.array(visemes, dtype=np.float64), np.array(expressions, dtype=np.float64)
    return FapStream("2.1", "shapes", float(FPS), np.arange(n), mask, np.zeros((n, N_FAPS)), *fields)


def render_shapes(path: Path) -> None:
    scene, face = open_head()
    context = bpy.context
    options = fap_io.ImportOptions(start_frame=0)
    fap_io.key_stream(context, face, fap_io.decode_stream(context, face, shapes_stream(), options, "shapes"), options)
    convert.frame_face(scene, face, 240)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    aim(scene, MOUTH)
    names = [f"{v.name}  {' '.join(VISEME_PHONEMES.get(v, ())) or 'silence'}" for v in Viseme]
    mouths = tiles(scene, range(len(Viseme)), names, 240)
    aim(scene, FACE)
    faces = tiles(scene, range(len(Viseme), len(Viseme) + 6), [e.name.lower() for e in Expression if e], 200)
    convert.save_png(np.concatenate([grid(faces, 6), grid(mouths, 5)], axis=0), path)


def render_sentence(path: Path, text: str) -> None:
    scene, face = open_head()
    speech = espeak.synthesize(text)
    speech_ops.speak(bpy.context, face, speech, fap_io.ImportOptions(start_frame=0), sound=False)
    segments = espeak.speech_segments(speech)
    picked = {}
    for segment in segments:
        frame = round(segment.centre * FPS)
        if segment.viseme != Viseme.NONE and frame not in picked:
            phoneme = segment.label.lstrip(STRESS_MARKS)
            picked[frame] = f"{phoneme}  {segment.viseme.name}\n{frame / FPS:.2f} s"
    convert.frame_face(scene, face, 200)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    aim(scene, MOUTH)
    convert.save_png(grid(tiles(scene, list(picked), list(picked.values()), 200), 6), path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--text", default=SENTENCE)
    parser.add_argument("--only", choices=("sheet", "visemes"), help="render one picture")
    args = parser.parse_args(argv)
    if args.only != "visemes":
        render_sentence(args.out / "speech_sheet.png", args.text)
        print(args.out / "speech_sheet.png")
    if args.only != "sheet":
        render_shapes(args.out / "visemes.png")
        print(args.out / "visemes.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
