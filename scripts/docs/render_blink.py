"""Close-ups of the full blink from the front and from above and below (docs/blink_closeup.png).

    .venv/bin/python -m scripts.docs.render_blink [--out docs/blink_closeup.png] [--targets DIR]
    .venv/bin/python -m scripts.docs.render_blink --faces DIR [--out docs/real_meshes_blink.png]

Rows: the sample's left eye at rest; the add-on's full blink (`scripts.bench.evaluate.BLINK`: 3.1 moved onto 3.3,
as the evaluation's blink); the sculptor's closed eye (eye-left-closure). Columns: looked at straight, from 30
degrees below and above (views the seen gap, `overlaps.seen_lid_gap`, is measured from: `evaluate.VIEWS`), from 45
degrees below and to the temple side (beyond them), and from the temple side (the lids' margins in profile).
Workbench, 240 px tiles; each view's seen gap of the left eye is printed (the side view's: none, the eye's
opening is not across that view).

With `--faces` (.blend files, or folders of them, e.g. `scripts.bench.variants OUT`): one row per face, the sample
first, each set up and given the same full blink (`scripts.bench.variant_blink.full_blink`); tiles: the left eye
straight on and from 30 degrees below, then the right eye the same, 0.6 times the pupils' distance across.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from scripts import convert
from scripts.bench import evaluate, variant_blink
from scripts.docs.closeups import aim_camera, closeup_camera, render_tile, save_rows, set_up_sample, unit_arguments
from scripts.docs.render_eyes_brows import positions

ROOT = Path(__file__).resolve().parents[2]
TILE = 240
# yaw (degrees, + to the face's left), pitch (+ above), ortho scale (m)
VIEWS = ((0.0, 0.0, 0.03), (0.0, -30.0, 0.03), (0.0, 30.0, 0.03), (45.0, -45.0, 0.03), (75.0, 0.0, 0.03))


def look_at_the_eye(scene, camera, pupil, view, scratch) -> np.ndarray:
    """A tile of the eye from one of `VIEWS` (yaw, pitch, the camera's width)."""
    yaw, pitch, ortho = view
    camera.data.ortho_scale = ortho
    aim_camera(camera, pupil, 0.4, yaw, pitch)
    return render_tile(scene, scratch)


def blink_rows(files: list[Path], out: Path) -> None:
    """`--faces`: a row of the full blink per face (see the module's text), written to `out`."""
    face_data = convert._addon("blender.face_data")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in [variant_blink.SAMPLE, *files]:
            bpy.ops.wm.open_mainfile(filepath=str(path))
            scene, face = bpy.context.scene, variant_blink._face()
            assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
            closed = variant_blink.full_blink(face)
            face.data.attributes["position"].data.foreach_set("vector", closed.astype(np.float32).ravel())
            face.data.update()
            for ob in scene.objects:  # the FP empties and the control mesh stay out of the pictures
                # only hidden, never shown: the sample's hidden rest copy ("Head Reference"), shown, showed through
                # the closed lids as patches (sessions 9-12 took them for the made lids' skin)
                if ob.type == "EMPTY" or ob == face.mpeg4_face.control_object:
                    ob.hide_render = True
            empties = face_data.fp_empties(face)
            pupils = [empties[k].matrix_world.translation.copy() for k in ("3.5", "3.6")]
            camera = closeup_camera(scene, face, TILE, 0.6 * (pupils[0] - pupils[1]).length)
            tiles = []
            for pupil in pupils:
                for pitch in variant_blink.PITCHES:
                    aim_camera(camera, pupil, 0.4, 0.0, pitch)
                    tiles.append(render_tile(scene, tmp))
            print(f"{path.stem}: left eye straight, 30 degrees below; right eye the same")
            rows.append(tiles)
    save_rows(rows, out)


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[1:]
    if "--faces" in argv:
        parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
        parser.add_argument("--faces", nargs="+", type=Path, required=True)
        parser.add_argument("--out", type=Path, default=ROOT / "docs" / "real_meshes_blink.png")
        args = parser.parse_args(argv)
        convert.addon_package()
        blink_rows([f for p in args.faces for f in (sorted(p.glob("*.blend")) if p.is_dir() else [p])], args.out)
        return 0
    args = unit_arguments(__doc__, ROOT / "docs" / "blink_closeup.png", argv)
    sample = evaluate.load_face(evaluate.DEFAULT_FACE)
    files = {evaluate.target_name(p): p for p in evaluate.target_files(args.targets)}
    sculpt = sample.rest + evaluate.target_motion(files["eye-left-closure"], sample)[0]
    scene, head, empties, controls, at_rest, rest = set_up_sample(sample.fp_ids)
    for upper, lower in evaluate.BLINK:
        empties[upper].location = Vector(empties[lower].location)
    bpy.context.view_layer.update()
    convert._addon("blender.live").apply_face(head, force=True)
    shapes = {"rest": rest, "add-on's full blink": positions(head.data), "the sculpt (eye-left-closure)": sculpt}
    camera = closeup_camera(scene, head, TILE, VIEWS[0][-1])
    pupil = bpy.data.objects["FP 3.5"].matrix_world.translation
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, shape in shapes.items():
            head.data.attributes["position"].data.foreach_set("vector", shape.astype(np.float32).ravel())
            head.data.update()
            seen = [1e3 * evaluate.seen_gap(sample, shape, (0,), (view[:2],)) for view in VIEWS[:-1]]
            print(f"{name}: seen gap (mm) " + ", ".join(f"{g:.2f}" for g in seen))
            rows.append([look_at_the_eye(scene, camera, pupil, view, tmp) for view in VIEWS])
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
