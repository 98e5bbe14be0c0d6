"""Side views of the jaw's opening on the sample head (`docs/arkit_rig_jaw.png`): MakeHuman's sculpted mouth-open
unit, MakeHuman's default rig turning its jaw by its own skin weights (`scripts.bench.arkit_spread --rig-jaw`), our
jawOpen key as made, and the key with the jaw's share spread as a membrane from the skin the mandible carries wholly
over the skin nearest the mandible's FPs (the one candidate `arkit_spread --rig-jaw` measures that both development
sources favour; not shipped). The teeth are left at rest in all four (the unit and the rig move the head's skin).

    .venv/bin/python -m scripts.docs.render_arkit_spread [--out docs/arkit_rig_jaw.png] [--tile 320] [--turn -60]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import bpy
import numpy as np

from scripts import convert
from scripts.bench import arkit_spread, evaluate, evaluate_arkit
from scripts.docs.render_speech import FACE, aim, grid, tiles
from scripts.sample.makehuman.head import to_blender

ROOT = Path(__file__).resolve().parents[2]


def offsets() -> list[tuple[str, np.ndarray]]:
    """(caption, (N, 3) offsets of the head's vertices) for the four views."""
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    free = arkit_spread.jaw_free_skins(face)["the skin nearest the mandible's FPs"]
    spread = arkit_spread.jaw_key_with(face, free, wholly=True)
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    key = evaluate_arkit.made_keys(face, "planar")["jawOpen"]
    rig = json.loads((arkit_spread.RIG / "rig.default.json").read_text())
    weights = json.loads((arkit_spread.RIG / "weights.default.json").read_text())["weights"]
    shift = (face.rest - to_blender(arkit_spread.base_mesh_vertices())[face.mh_index]).mean(axis=0)
    pivot = np.array(rig["jaw"]["head"]["default_position"]) + shift
    carried = arkit_spread.rig_weight(weights, arkit_spread.carried_by(rig, "jaw"), face.mh_index)
    pose = carried[:, None] * arkit_spread.turn_about_x(face.rest, pivot, arkit_spread.RIG_JAW_DEGREES)
    unit = evaluate.target_motion(evaluate_arkit.UNITS / "mouth-open.target.gz", face)[0]
    return [
        ("mouth-open unit (sculpt)", unit),
        ("MakeHuman rig, jaw 26.4 deg", pose),
        ("jawOpen key (as made)", key),
        ("key, mandible's share spread", spread),
    ]


def render(path: Path, tile: int, turn: float) -> None:
    views = offsets()
    face = bpy.data.objects[evaluate.HEAD]
    scene = bpy.context.scene
    keys = face.data.shape_keys
    for block in keys.key_blocks[1:]:
        block.value = 0.0
    base = np.array([v.co for v in keys.reference_key.data], dtype=np.float64)
    for frame, (caption, offset) in enumerate(views):
        block = face.shape_key_add(name=caption, from_mix=False)
        block.data.foreach_set("co", (base + offset).astype(np.float32).ravel())
        for other in range(len(views)):
            block.value = float(other == frame)
            block.keyframe_insert("value", frame=other)
    convert.frame_face(scene, face, tile)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    face.rotation_euler.z += np.radians(turn)
    bpy.context.view_layer.update()
    aim(scene, (FACE[0], FACE[1] - 0.045, 0.17))  # the jaw and the neck below it too
    scene.camera.location.x += np.sin(np.radians(-turn)) * 0.06  # the turned head's jaw in the middle
    pictures = tiles(scene, range(len(views)), [caption for caption, _ in views], tile)
    convert.save_png(grid(pictures, len(views)), path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "arkit_rig_jaw.png")
    parser.add_argument("--tile", type=int, default=320)
    parser.add_argument("--turn", type=float, default=-60.0, help="turn the head this many degrees to its left")
    args = parser.parse_args(argv)
    convert.addon_package()
    render(args.out, args.tile, args.turn)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
