"""The contact sheet of the 52 ARKit shape keys made on the sample head (`docs/arkit_shapes.png`): Workbench
close-ups of the face, one per shape at weight 1, captioned with its ARKit name.

    .venv/bin/python -m scripts.docs.render_arkit [--out docs/arkit_shapes.png] [--tile 200]
    .venv/bin/python -m scripts.docs.render_arkit --shapes mouthUpperUpLeft,noseSneerLeft --close --turn 35 --out R.png

`--shapes` renders those shapes only, in one row (a before / after row: run it in an older tree, `git archive COMMIT
| tar -x -C DIR`, with this script copied in, and stack the rows with `scripts.docs.render_before_after --montage`,
which reads the `.npy` each row leaves beside its PNG); `--close` frames the nose and mouth; `--turn` turns the head
that many degrees to its left for an oblique view.

The keys are made by Make ARKit Shape Keys (Planar Bones with lids, lips and Unfold Skin, as played) and shown the
way a capture plays them: keyed one shape per frame onto the face and its parts (`arkit_keys.key_capture`). A shape
whose key is made over another (mouthClose over jawOpen, the recipe's 'over') is shown with that one at 1 too, as
ARKit uses it, and captioned so.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

from addon.arkit.captures import Capture
from addon.arkit.recipes import ARKIT_INDEX, ARKIT_NAMES, N_SHAPES, load_recipes
from addon.blender import arkit_keys
from scripts import convert
from scripts.docs.render_speech import FACE, aim, grid, open_head, tiles

ROOT = Path(__file__).resolve().parents[2]
COLUMNS = 8
MOUTH = ("9.15", -0.008, 0.09)  # `--close`: the nose and the mouth


def render(path: Path, tile: int, shapes: list[str] | None = None, close: bool = False, turn: float = 0.0) -> None:
    scene, face = open_head()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.make_arkit_shape_keys() == {"FINISHED"}
    weights, captions = np.eye(N_SHAPES), list(ARKIT_NAMES)
    for name, base in load_recipes().over.items():
        weights[ARKIT_INDEX[name], ARKIT_INDEX[base]] = 1.0
        captions[ARKIT_INDEX[name]] = f"{name} + {base}"
    one_each = Capture("shapes", 25.0, np.arange(N_SHAPES), weights)
    arkit_keys.key_capture(bpy.context, face, one_each, np.arange(N_SHAPES, dtype=np.float64))
    convert.frame_face(scene, face, tile)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    face.rotation_euler.z += np.radians(turn)
    bpy.context.view_layer.update()
    aim(scene, MOUTH if close else FACE)
    frames = range(N_SHAPES) if shapes is None else [ARKIT_INDEX[name] for name in shapes]
    pictures = tiles(scene, frames, [captions[frame] for frame in frames], tile)
    sheet = grid(pictures, COLUMNS if shapes is None else len(frames))
    convert.save_png(sheet, path)
    if shapes is not None:  # a row for `render_before_after --montage`
        np.save(path.with_suffix(".npy"), sheet[..., :3])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "arkit_shapes.png")
    parser.add_argument("--tile", type=int, default=200)
    parser.add_argument("--shapes", help="comma-separated ARKit names: those shapes only, in one row")
    parser.add_argument("--close", action="store_true", help="frame the nose and the mouth")
    parser.add_argument("--turn", type=float, default=0.0, help="turn the head this many degrees to its left")
    args = parser.parse_args(argv)
    shapes = None if args.shapes is None else args.shapes.split(",")
    if shapes is not None and (unknown := [name for name in shapes if name not in ARKIT_INDEX]):
        parser.error(f"not ARKit names: {', '.join(unknown)}")
    render(args.out, args.tile, shapes, args.close, args.turn)
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
