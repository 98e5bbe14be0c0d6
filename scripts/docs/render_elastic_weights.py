"""Close-ups of Elastic Bones with its skin weights unsmoothed and smoothed (docs/elastic_weights_before_after.png).

    .venv/bin/python -m scripts.docs.render_elastic_weights [--out docs/elastic_weights_before_after.png]

Columns: inner-brow raise (eyebrows-left-inner-up) and brow raise (eyebrows-left-up) from the front, coloured by
motion (dark blue still, red at the sculpt's largest motion); mouth-open at 1.5 times its FP motion seen from the
front and from three-quarters, plain, with the faces turned over painted red. Rows: the sculpt (coloured; plain for the
mouth); Elastic Bones with `skinning.SMOOTHING_WIDTH` = 0 (the weights as before); with the shipped smoothing.
Both rows use the shipped trained parameters. The engine is driven by the unit's FP motion as
`scripts.bench.evaluate --method elastic_bones` drives it. Workbench, 300 px tiles.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from addon.elastic import skinning
from scripts import convert
from scripts.bench import evaluate
from scripts.bench.elastic_bones import ElasticBonesMethod
from scripts.docs.closeups import UNITS, aim_camera, closeup_camera, save_rows
from scripts.docs.render_eyes_brows import motion_colours, paint
from scripts.docs.render_unfold import paint_folds

ROOT = Path(__file__).resolve().parents[2]
TILE = 300
# (unit, FP motion times, coloured by motion, FP the camera looks at, yaw, pitch, ortho scale)
SHOTS = (
    ("eyebrows-left-inner-up", 1.0, True, "4.3", 0.0, 0.0, 0.08),
    ("eyebrows-left-up", 1.0, True, "4.3", 0.0, 0.0, 0.08),
    ("mouth-open", 1.5, False, "2.10", 0.0, 0.0, 0.1),
    ("mouth-open", 1.5, False, "2.10", -45.0, 0.0, 0.1),
)


def render_row(face, method, shots, motion: dict, camera, label: str, tmp: Path) -> np.ndarray:
    """One row of tiles, a tile per shot: the sculpt (`method` None) or `method` driven by the unit's FP motion
    times the shot's scale, coloured by motion or plain with the faces turned over red (counts and E printed)."""
    scene, head = bpy.context.scene, face.head
    tiles = []
    convert.render_frame(scene, scene.frame_current, tmp / "tile.png")  # the first render shows the mesh as loaded
    for name, scale, coloured, target, yaw, pitch, ortho in shots:
        offsets, fp_offsets = motion[name]
        sculpted = face.rest + scale * offsets
        shown = sculpted if method is None else method.evaluate(face.control_rest + scale * fp_offsets)
        head.data.attributes["position"].data.foreach_set("vector", shown.astype(np.float32).ravel())
        head.data.update()
        if coloured:
            largest = np.linalg.norm(sculpted - face.rest, axis=1).max()
            paint(head.data, motion_colours(np.linalg.norm(shown - face.rest, axis=1), largest))
        else:
            count = paint_folds(head, face.rest)
            print(f"{name} x{scale}, {label}: {count} faces turned over")
        if method is not None:
            e = evaluate.score(shown, sculpted, face.rest).e
            print(f"{name} x{scale}, {label}: E {e:.3f}")
        camera.data.ortho_scale = ortho
        aim_camera(camera, bpy.data.objects[f"FP {target}"].matrix_world.translation, 0.4, yaw, pitch)
        tiles.append(convert.render_frame(scene, scene.frame_current, tmp / "tile.png"))
    return np.concatenate(tiles, axis=1)


def prepare_shots(shots):
    """The sample face, each shot's unit motion by name, and the close-up camera, the scene shaded by vertex colour."""
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    files = {evaluate.target_name(p): p for p in evaluate.target_files(UNITS)}
    motion = {name: evaluate.target_motion(files[name], face) for name, *_ in shots}
    scene = bpy.context.scene
    camera = closeup_camera(scene, face.head, TILE, shots[0][-1])
    scene.display.shading.color_type = "VERTEX"
    return face, motion, camera


def sculpt_and_engine_main(doc: str, out: Path, shots, argv=None) -> int:
    """A close-up script's main: two rows of `shots` tiles, the sculpt over Elastic Bones (shipped weights and
    parameters), saved at `--out` (default `out`)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=out)
    out = parser.parse_args(argv).out
    face, motion, camera = prepare_shots(shots)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [render_row(face, method, shots, motion, camera, label, Path(tmp))
                for label, method in (("the sculpt", None), ("Elastic Bones", ElasticBonesMethod(face)))]  # fmt: skip
    save_rows(rows, out)
    return 0


def before_after_main(doc: str, out: Path, shots, settings, argv=None) -> int:
    """A close-up script's main: rows of `shots` tiles, the sculpt over Elastic Bones' skinning (Unfold Skin off)
    with the `skinning` constants set as each (label, {name: value}) of `settings` says in turn (shipped
    parameters; the constants restored after), saved at `--out` (default `out`)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=out)
    out = parser.parse_args(argv).out
    face, motion, camera = prepare_shots(shots)
    shipped = {name: getattr(skinning, name) for _label, values in settings for name in values}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            rows = [render_row(face, None, shots, motion, camera, "the sculpt", Path(tmp))]
            for label, values in settings:
                for name, value in {**shipped, **values}.items():
                    setattr(skinning, name, value)
                method = ElasticBonesMethod(face, unfold_skin=False)  # the skinning alone: the weights compared
                rows.append(render_row(face, method, shots, motion, camera, label, Path(tmp)))
    finally:
        for name, value in shipped.items():
            setattr(skinning, name, value)
    save_rows(rows, out)
    return 0


def main(argv=None) -> int:
    settings = (("unsmoothed", {"SMOOTHING_WIDTH": 0}), ("smoothed", {}))
    return before_after_main(__doc__, ROOT / "docs" / "elastic_weights_before_after.png", SHOTS, settings, argv)


if __name__ == "__main__":
    sys.exit(main())
