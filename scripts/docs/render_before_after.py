"""Close-ups of the face parts issue 13 was about, as one version of the add-on shows them (one row per run).

    .venv/bin/python -m scripts.docs.render_before_after --code DIR --out ROW.png
    .venv/bin/python -m scripts.docs.render_before_after --montage BEFORE.png AFTER.png --out OUT.png

`--code DIR` is a tree of the project (this checkout, or an older one unpacked with `git archive COMMIT | tar -x
-C DIR`): its add-on is loaded and its own sample head set up with its own Set Up Face, then a stream with one
frame per pose is imported with its own Import FAP Stream, so each version shows what it did. Poses (FAP
values in FAP units): blink, gaze left, right, up, down, brows up, brows down, smile, pout, jaw open. Workbench,
orthographic, the eyes, brows or mouth framed. Only bpy and numpy are imported besides DIR's add-on, so an old
tree needs nothing from this one.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
from pathlib import Path

import numpy as np

TILE = 240
EYES, BROWS, MOUTH = ("3.5", "3.6", 0.1, 0.0), ("3.5", "3.6", 0.1, 0.016), ("2.4", "2.5", 0.07, -0.004)
EYE = ("3.5", "3.5", 0.045, 0.0)  # one eye, close: a turn shows in the eyeball and the lids
POSES = (  # name, {FAP: value}, framing (two FPs to centre on, width, vertical shift)
    ("blink", {19: 1024, 20: 1024}, EYES),
    ("gaze left", {23: 30000, 24: 30000}, EYE),
    ("gaze right", {23: -30000, 24: -30000}, EYE),
    ("gaze up", {25: -25000, 26: -25000}, EYE),
    ("gaze down", {25: 25000, 26: 25000}, EYE),
    ("brows up", {n: 250 for n in range(31, 37)}, BROWS),
    ("brows down", {n: -150 for n in range(31, 37)}, BROWS),
    ("smile", {12: 250, 13: 250, 6: 150, 7: 150, 59: 250, 60: 250, 53: 150, 54: 150}, MOUTH),
    ("pout", {16: 300, 17: 300}, MOUTH),
    ("jaw open", {3: 600}, MOUTH),
)


def write_stream(path: Path) -> None:
    """A .fap (version 2.1 text) with one frame per pose, every FAP 3-68 transmitted (0 where the pose has none)."""
    lines = [f"2.1 poses 1 {len(POSES)}"]
    for k, (_name, values, _frame) in enumerate(POSES):
        lines.append("0 0 " + " ".join("1" for _ in range(66)))
        lines.append(f"{k} " + " ".join(str(values.get(n, 0)) for n in range(3, 69)))
    path.write_text("\n".join(lines) + "\n")


def render_row(code: Path, out: Path) -> None:
    import bpy

    # DIR's add-on as the package `addon`, from its own folder (nothing else is looked up there)
    spec = importlib.util.spec_from_file_location(
        "addon", code / "addon" / "__init__.py", submodule_search_locations=[str(code / "addon")]
    )
    addon = importlib.util.module_from_spec(spec)
    sys.modules["addon"] = addon
    spec.loader.exec_module(addon)
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=str(code / "sample_blends" / "makehuman_head.blend"))
    scene, head = bpy.context.scene, bpy.data.objects["Head"]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob == head)
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    with tempfile.TemporaryDirectory() as tmp:
        stream = Path(tmp) / "poses.fap"
        write_stream(stream)
        assert bpy.ops.mpeg4.import_fap(filepath=str(stream), start_frame=1, timing="SCENE") == {"FINISHED"}
        head.mpeg4_face.enabled = True
        camera_data = bpy.data.cameras.new("close-up")
        camera_data.type = "ORTHO"
        camera = bpy.data.objects.new("close-up", camera_data)
        scene.collection.objects.link(camera)
        scene.camera = camera
        camera.rotation_euler = (np.pi / 2, 0.0, 0.0)  # looking along +y at the face
        scene.render.engine = "BLENDER_WORKBENCH"
        scene.render.resolution_x = scene.render.resolution_y = TILE
        scene.render.resolution_percentage = 100
        scene.render.image_settings.file_format = "PNG"
        scene.render.image_settings.color_mode = "RGB"
        front = min(v[1] for v in head.bound_box) * head.matrix_world.to_scale()[1] + head.matrix_world.translation.y
        tiles = []
        for k, (_name, _values, (a, b, width, shift)) in enumerate(POSES):
            scene.frame_set(1 + k)
            fp = {ob.get("mpeg4_fp"): ob for ob in bpy.data.objects if ob.get("mpeg4_fp")}
            rest = [fp[f].matrix_world.translation for f in (a, b)]
            centre = (rest[0] + rest[1]) / 2
            camera.location = (centre.x, front - 0.3, centre.z + shift)
            camera_data.ortho_scale = width
            scene.render.filepath = str(Path(tmp) / "tile.png")
            bpy.ops.render.render(write_still=True)
            image = bpy.data.images.load(scene.render.filepath)
            pixels = np.array(image.pixels[:], dtype=np.float32).reshape(TILE, TILE, image.channels)[..., :3]
            bpy.data.images.remove(image)
            tiles.append(pixels)
    np.save(out.with_suffix(".npy"), np.concatenate(tiles, axis=1))
    print(out.with_suffix(".npy"))


def montage(rows: list[Path], out: Path) -> None:
    import bpy

    picture = np.concatenate([np.load(row.with_suffix(".npy")) for row in rows[::-1]], axis=0)  # first on top
    height, width = picture.shape[:2]
    image = bpy.data.images.new("montage", width, height)
    image.pixels.foreach_set(np.concatenate([picture, np.ones((height, width, 1), np.float32)], axis=2).ravel())
    image.filepath_raw, image.file_format = str(out), "PNG"
    image.save()
    print(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--code", type=Path, help="the project tree whose add-on renders the row")
    parser.add_argument("--montage", type=Path, nargs=2, metavar=("BEFORE", "AFTER"), help="rows to stack")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.montage:
        montage(args.montage, args.out)
    elif args.code:
        render_row(args.code.resolve(), args.out)
    else:
        parser.error("give --code or --montage")
    return 0


if __name__ == "__main__":
    sys.exit(main())
