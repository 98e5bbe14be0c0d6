"""Close-ups of the upper face without and with Still Skin Around Eyes (docs/eyes_brows_before_after.png).

    .venv/bin/python -m scripts.docs.render_eyes_brows [--out docs/eyes_brows_before_after.png] [--targets DIR]

Columns: blink (eye-left-closure), wide eyes (eye-left-opened-up), downward gaze (FAPs 25/26 at 30000, no
sculpt), inner-brow raise (eyebrows-left-inner-up), brow lowering (eyebrows-left-down), smile
(mouth-corner-puller), jaw open (mouth-open). The FP empties move by the unit's FP motion as
`scripts.bench.evaluate` moves them. Rows, top to bottom: the sculpt coloured by how far each vertex moved;
the add-on with Still Skin Around Eyes off (the paper's cover, as before), plain and coloured; the add-on with
it on, plain and coloured. Colour: dark blue still, through green and yellow to red at the column's largest
sculpted motion (the downward gaze: its largest motion with the setting on). Workbench, 240 px tiles; the
largest motion and each tile's E against the sculpt are printed.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from scripts import convert
from scripts.bench import evaluate
from scripts.docs.closeups import aim_camera, closeup_camera, save_rows, set_up_sample, unit_arguments
from scripts.docs.render_eyes import pose
from scripts.docs.render_unfold import unit_motion

ROOT = Path(__file__).resolve().parents[2]
TILE = 240
GAZE_DOWN = {25: 30000, 26: 30000}
# (unit or None for the gaze, the FP the camera looks at, camera yaw and pitch in degrees, ortho scale)
SHOTS = (
    ("eye-left-closure", "3.5", 0.0, 0.0, 0.06),
    ("eye-left-opened-up", "3.5", 0.0, 0.0, 0.06),
    (None, "3.5", 0.0, 0.0, 0.06),
    ("eyebrows-left-inner-up", "4.3", 0.0, 0.0, 0.08),
    ("eyebrows-left-down", "4.3", 0.0, 0.0, 0.08),
    ("mouth-corner-puller", "9.15", 0.0, 0.0, 0.12),
    ("mouth-open", "9.15", 0.0, 0.0, 0.14),
)
STOPS = np.array([(0.05, 0.1, 0.45), (0.1, 0.75, 0.4), (0.95, 0.85, 0.1), (0.9, 0.1, 0.05)])  # still ... largest
GREY = (0.8, 0.8, 0.8, 1.0)


def motion_colours(motion: np.ndarray, largest: float) -> np.ndarray:
    """(N, 4) colours of the vertex motions (metres) on the STOPS ramp from 0 to `largest`."""
    x = np.clip(motion / max(largest, 1e-12), 0.0, 1.0) * (len(STOPS) - 1)
    low = np.minimum(x.astype(int), len(STOPS) - 2)
    t = (x - low)[:, None]
    rgb = (1.0 - t) * STOPS[low] + t * STOPS[low + 1]
    return np.concatenate([rgb, np.ones((len(rgb), 1))], axis=1).astype(np.float32)


def paint(mesh, colours: np.ndarray | None) -> None:
    """Set the 'Motion' point colours (grey everywhere when `colours` is None)."""
    attribute = mesh.color_attributes.get("Motion") or mesh.color_attributes.new("Motion", "FLOAT_COLOR", "POINT")
    if colours is None:
        colours = np.tile(np.array(GREY, np.float32), (len(mesh.vertices), 1))
    attribute.data.foreach_set("color", colours.reshape(-1))
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.find("Motion")
    mesh.update()


def positions(mesh) -> np.ndarray:
    out = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3).astype(np.float64)


def main(argv=None) -> int:
    args = unit_arguments(__doc__, ROOT / "docs" / "eyes_brows_before_after.png", argv)
    sample = evaluate.load_face(evaluate.DEFAULT_FACE)
    files = {evaluate.target_name(p): p for p in evaluate.target_files(args.targets)}
    sculpts = {name: evaluate.target_motion(files[name], sample)[0] for name, *_ in SHOTS if name}
    motions = {name: unit_motion(sample, name, args.targets) for name, *_ in SHOTS if name}
    scene, head, empties, controls, at_rest, rest = set_up_sample(sample.fp_ids)
    live = convert._addon("blender.live")
    every_rest = {ob: ob.location.copy() for ob in empties.values()}  # the pupils too, which the gaze moves
    camera = closeup_camera(scene, head, TILE, SHOTS[0][-1])
    shading = scene.display.shading

    def show(name):
        """Pose the face for a shot; its positions."""
        for ob, place in every_rest.items():
            ob.location = place
        if name is None:
            pose(head, GAZE_DOWN)
        else:
            for ob, place, offset in zip(controls, at_rest, motions[name], strict=True):
                ob.location = place + Vector(offset)
            bpy.context.view_layer.update()
            live.apply_face(head, force=True)
        return positions(head.data)

    def render(name, target, yaw, pitch, ortho, tmp):
        camera.data.ortho_scale = ortho
        aim_camera(camera, bpy.data.objects[f"FP {target}"].matrix_world.translation, 0.4, yaw, pitch)
        return convert.render_frame(scene, scene.frame_current, Path(tmp) / "tile.png")

    head.mpeg4_face.still_upper_face = True  # rebinds (at once: no user interface)
    largest = {name: (np.linalg.norm(sculpts[name], axis=1).max() if name else 0.0) for name, *_ in SHOTS}
    gaze = show(None)
    largest[None] = np.linalg.norm(gaze - rest, axis=1).max()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tiles = []
        shading.color_type = "VERTEX"
        for name, *view in SHOTS:  # the sculpts, written over the posed face (the same FPs: no re-evaluation)
            show(name)
            sculpted = rest + (sculpts[name] if name else 0.0)
            head.data.attributes["position"].data.foreach_set("vector", sculpted.astype(np.float32).ravel())
            paint(head.data, motion_colours(np.linalg.norm(sculpted - rest, axis=1), largest[name]))
            tiles.append(render(name, *view, tmp))
            print(f"{name or 'gaze down'}: largest sculpted motion {1e3 * largest[name]:.2f} mm")
        rows.append(np.concatenate(tiles, axis=1))
        for still in (False, True):
            head.mpeg4_face.still_upper_face = still
            plain, coloured = [], []
            for name, *view in SHOTS:
                deformed = show(name)
                if name:
                    e = evaluate.score(deformed, rest + sculpts[name], rest).e
                    print(f"{name}, Still Skin Around Eyes {'on' if still else 'off'}: E {e:.3f}")
                shading.color_type = "VERTEX"
                paint(head.data, None)
                plain.append(render(name, *view, tmp))
                paint(head.data, motion_colours(np.linalg.norm(deformed - rest, axis=1), largest[name]))
                coloured.append(render(name, *view, tmp))
            rows += [np.concatenate(plain, axis=1), np.concatenate(coloured, axis=1)]
    save_rows(rows, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
