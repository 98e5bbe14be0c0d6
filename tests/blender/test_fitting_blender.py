"""Fitting in Blender: Fit to Feature Points, rigid parts, Import/Export FDP, calibration mesh, Back to Generic,
Remove, and bad input leaving the scene as it was."""

import subprocess
import sys
import textwrap
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

from addon.blender import face_data, face_setup, fitting_store, rest_shape
from addon.fitting.fdp_file import Fdp, read_fdp, write_fdp
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.fapu import compute_fapu

from .helpers import DEMO_FAP, SAMPLE, positions, select, set_up_sample
from .test_hardening import snapshot, unset_sample

ROOT = Path(__file__).resolve().parents[2]
ALICE = ROOT.parent / "shared" / "interop" / "fap" / "bestdpf_xface-new" / "alice.fdp"
# a shear and an uneven scale, so the fit is not a similarity
AFFINE = np.array([[1.1, 0.05, 0.0], [0.0, 0.95, 0.1], [0.02, 0.0, 1.05]])
SHIFT = np.array([0.01, -0.02, 0.03])


def neutral(head) -> dict[str, np.ndarray]:
    return {fp_id: np.array(ob[face_data.EMPTY_REST_PROP]) for fp_id, ob in face_data.fp_empties(head).items()}


def move_fps(head, targets: dict[str, np.ndarray]) -> None:
    empties = face_data.fp_empties(head)
    for fp_id, target in targets.items():
        empties[fp_id].location = target


def similarity(scale: float, degrees: float, shift) -> tuple[np.ndarray, np.ndarray]:
    turn = np.array(Matrix.Rotation(np.radians(degrees), 3, "Z"))
    return scale * turn, np.asarray(shift, dtype=np.float64)


def state(head) -> dict:
    """The scene as `snapshot` sees it, plus the mesh's rest copy, the face's settings, the fitting holder and
    the data a texture brings."""
    scene = snapshot()
    meshes = scene.pop("meshes")  # by object: set-up names each new control mesh after the one it replaces
    return {
        **scene,
        "meshes": {ob.name: meshes[ob.data.name] for ob in bpy.data.objects if ob.type == "MESH"},
        "mesh_count": len(meshes),
        "rest": rest_shape.stored_rest(head.data).tobytes(),
        "fapu": tuple(head.mpeg4_face.fapu),
        "neutral": {k: tuple(v) for k, v in neutral(head).items()},
        "holder": fitting_store.holder(head) is not None,
        "uv": [layer.name for layer in head.data.uv_layers],
        "materials": sorted(m.name for m in bpy.data.materials),
        "images": sorted(i.name for i in bpy.data.images),
    }


def lash(head) -> bpy.types.Object:
    """A small left eyelash mesh, child of the head above the left eye."""
    mesh = bpy.data.meshes.new("Eyelash L")
    mesh.from_pydata([(0.0, 0.0, 0.0), (0.01, 0.0, 0.0), (0.0, 0.0, 0.005)], [], [(0, 1, 2)])
    ob = bpy.data.objects.new("Eyelash L", mesh)
    bpy.context.scene.collection.objects.link(ob)
    ob.parent = head
    ob.location = bpy.data.objects["Eye L"].location + Vector((-0.005, -0.012, 0.008))
    bpy.context.view_layer.update()
    return ob


def test_an_affine_map_of_the_fps_fits_the_mesh_exactly_and_rigid_parts_follow_undistorted():
    head = set_up_sample()
    eyelash = lash(head)
    generic = rest_shape.stored_rest(head.data).astype(np.float64)
    parts = ("Eye L", "Eye R", "Teeth Lower", "Teeth Upper", "Tongue", "Eyelash L")
    meshes = {name: positions(bpy.data.objects[name].data).copy() for name in parts}
    poses = {name: tuple(bpy.data.objects[name].matrix_basis.col[3]) for name in parts}
    targets = {fp_id: AFFINE @ p + SHIFT for fp_id, p in neutral(head).items()}
    move_fps(head, targets)
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}

    np.testing.assert_allclose(positions(head.data), generic @ AFFINE.T + SHIFT, rtol=0, atol=1e-6)
    np.testing.assert_allclose(rest_shape.stored_rest(head.data), generic @ AFFINE.T + SHIFT, rtol=0, atol=1e-6)
    empties = face_data.fp_empties(head)
    for fp_id, target in targets.items():
        np.testing.assert_allclose(empties[fp_id].location, target, rtol=0, atol=1e-6, err_msg=fp_id)
        np.testing.assert_allclose(empties[fp_id][face_data.EMPTY_REST_PROP], target, rtol=0, atol=1e-6)
    for name in parts:
        ob = bpy.data.objects[name]
        np.testing.assert_array_equal(positions(ob.data), meshes[name], err_msg=name)  # not distorted
        assert tuple(ob.matrix_basis.col[3]) != poses[name], name  # but moved
        assert ob.scale[0] == pytest.approx(ob.scale[1], abs=1e-6) == pytest.approx(ob.scale[2], abs=1e-6)
    # the left eye sits where the map takes its centre, up to the best similarity of its FPs
    centre = np.array(bpy.data.objects["Eye L"].location)
    assert np.linalg.norm(centre - (AFFINE @ np.array(poses["Eye L"][:3]) + SHIFT)) < 0.003
    assert eyelash.location != bpy.data.objects["Eye L"].location


def test_fps_land_where_placed_and_the_fit_stays_local():
    head = set_up_sample()
    generic = rest_shape.stored_rest(head.data).astype(np.float64)
    rest = neutral(head)
    placed = {
        "9.3": rest["9.3"] + [0.0, -0.006, 0.0],  # nose tip forward
        "2.1": rest["2.1"] + [0.0, 0.0, -0.005],  # chin down
        "3.5": rest["3.5"] + [0.002, 0.0, 0.0],  # left pupil out (eye surface: not snapped)
    }
    move_fps(head, placed)
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
    empties = face_data.fp_empties(head)
    np.testing.assert_allclose(empties["3.5"].location, placed["3.5"], rtol=0, atol=1e-6)
    for fp_id in ("9.3", "2.1"):  # skin FPs: set-up snaps them onto the fitted skin, a hair away
        assert np.linalg.norm(np.array(empties[fp_id].location) - placed[fp_id]) < 2e-4, fp_id
    for fp_id in ("4.1", "10.1", "11.6"):  # untouched and given as they were
        np.testing.assert_allclose(empties[fp_id].location, rest[fp_id], rtol=0, atol=1e-6, err_msg=fp_id)
    motion = np.linalg.norm(positions(head.data) - generic, axis=1)
    # the back of the skull moves only with the small affine part of the FPs' motion (the DFFD's outer sites)
    back = generic[:, 1] > rest["11.6"][1] - 0.03
    assert motion.max() > 0.004 and motion[back].max() < 0.15 * motion.max()


def test_the_fitted_face_plays_a_fap_stream_with_fapu_scaled_by_the_map():
    head = set_up_sample()
    fapu = np.array(head.mpeg4_face.fapu)
    linear, shift = similarity(1.08, 0.0, [0.004, -0.01, 0.02])  # FAPU are measured along the face's axes
    move_fps(head, {fp_id: linear @ p + shift for fp_id, p in neutral(head).items()})
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
    np.testing.assert_allclose(np.array(head.mpeg4_face.fapu), 1.08 * fapu, rtol=2e-5)

    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    scene = bpy.context.scene
    rest = positions(head.data).copy()
    moved = 0.0
    for frame in range(scene.frame_start, scene.frame_start + 40, 4):
        scene.frame_set(frame)
        now = positions(head.data)
        assert np.all(np.isfinite(now)), frame
        moved = max(moved, float(np.abs(now - rest).max()))
    assert moved > 0.002


def test_back_to_generic_restores_the_face_bit_for_bit():
    head = set_up_sample()
    before = state(head)
    poses = {name: bpy.data.objects[name].matrix_basis.copy() for name in ("Eye L", "Teeth Lower")}
    linear, shift = similarity(0.93, -4.0, [0.0, 0.01, -0.005])
    move_fps(head, {fp_id: linear @ p + shift for fp_id, p in neutral(head).items()})
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
    face_data.fp_empties(head)["9.3"].location.y -= 0.004  # a second fit starts from the generic face too
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
    assert state(head) != before
    assert bpy.ops.mpeg4.fit_reset() == {"FINISHED"}
    bpy.context.view_layer.update()
    after = state(head)
    assert after == before
    for name, pose in poses.items():
        assert bpy.data.objects[name].matrix_basis == pose
    assert not fitting_store.has_generic(head)
    with pytest.raises(RuntimeError, match="has not been fitted"):
        bpy.ops.mpeg4.fit_reset()


def fdp_files(tmp_path, head) -> Path:
    """An FDP of the head under AFFINE with cylindrical texture coordinates and a 32 x 32 image."""
    image = bpy.data.images.new("person", 32, 32)
    pixels = np.random.default_rng(1).random((32, 32, 4), dtype=np.float32)
    pixels[..., 3] = 1.0
    image.pixels.foreach_set(pixels.ravel())
    image.filepath_raw = str(tmp_path / "person.png")
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    points = {fp_id: BLENDER_FACE_AXES @ (AFFINE @ p + SHIFT) for fp_id, p in neutral(head).items()}
    centre = np.mean(list(points.values()), axis=0)
    heights = np.array([p[1] for p in points.values()])
    uvs = {
        fp_id: np.array(
            [
                0.5 + np.arctan2(p[0] - centre[0], p[2] - centre[2]) / (2 * np.pi),
                (p[1] - heights.min()) / np.ptp(heights) * 0.9 + 0.05,
            ]
        )
        for fp_id, p in points.items()
        if fp_id not in ("11.4", "11.5")  # on the cylinder's axis
    }
    path = tmp_path / "person.fdp.json"
    write_fdp(path, Fdp(points, uvs, "person.png"))
    return path


def test_import_fdp_fits_and_textures_and_back_to_generic_takes_the_texture_away(tmp_path):
    head = set_up_sample()
    generic = rest_shape.stored_rest(head.data).astype(np.float64)
    before = state(head)
    path = fdp_files(tmp_path, head)
    assert bpy.ops.mpeg4.import_fdp(filepath=str(path)) == {"FINISHED"}
    np.testing.assert_allclose(positions(head.data), generic @ AFFINE.T + SHIFT, rtol=0, atol=1e-6)
    layer = head.data.uv_layers[fitting_store.UV_MAP_NAME]
    uvs = np.empty(len(head.data.loops) * 2, dtype=np.float32)
    layer.data.foreach_get("uv", uvs)
    assert uvs.min() >= 0.0 and uvs.max() <= 1.0 and np.ptp(uvs) > 0.5
    assert head.data.uv_layers.active.name == "UVMap"  # the mask image still reads the face's own UVs
    material = head.active_material
    node = material.node_tree.nodes[fitting_store.IMAGE_NODE]
    assert node.image.name == "person.png" and node.image.size[:] == (32, 32)
    assert material.node_tree.nodes[fitting_store.UV_NODE].uv_map == fitting_store.UV_MAP_NAME
    assert bpy.ops.mpeg4.fit_reset() == {"FINISHED"}
    bpy.context.view_layer.update()
    assert state(head) == before
    assert not head.material_slots and not head.data.materials and "person.png" not in bpy.data.images


def test_import_fdp_into_a_material_of_the_face_restores_its_links(tmp_path):
    head = set_up_sample()
    material = bpy.data.materials.new("Skin")
    head.data.materials.append(material)
    shader = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    colour = material.node_tree.nodes.new("ShaderNodeRGB")
    material.node_tree.links.new(colour.outputs[0], shader.inputs["Base Color"])
    assert bpy.ops.mpeg4.import_fdp(filepath=str(fdp_files(tmp_path, head))) == {"FINISHED"}
    assert shader.inputs["Base Color"].links[0].from_node.name == fitting_store.IMAGE_NODE
    assert bpy.ops.mpeg4.fit_reset() == {"FINISHED"}
    assert shader.inputs["Base Color"].links[0].from_node == colour
    assert len(material.node_tree.nodes) == 3 and list(head.data.materials) == [material]


def test_remove_after_a_fit_leaves_the_file_as_it_was_before_set_up(tmp_path):
    head = unset_sample()
    lash(head)
    before = snapshot()
    uv_layers, materials = [layer.name for layer in head.data.uv_layers], sorted(bpy.data.materials.keys())
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fdp(filepath=str(fdp_files(tmp_path, head))) == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), set_frame_range=False) == {"FINISHED"}
    bpy.context.scene.frame_set(5)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    bpy.context.view_layer.update()  # world matrices of the parts put back
    after = snapshot()
    for name in before["objects"]:
        assert after["objects"].get(name) == before["objects"][name], name
    assert after == before
    assert [layer.name for layer in head.data.uv_layers] == uv_layers
    assert sorted(bpy.data.materials.keys()) == materials and "person.png" not in bpy.data.images


def test_export_fdp_writes_the_points_and_fapu(tmp_path):
    head = set_up_sample()
    path = tmp_path / "head.fdp.json"
    assert bpy.ops.mpeg4.export_fdp(filepath=str(path)) == {"FINISHED"}
    fdp = read_fdp(path)
    rest = face_data.local_positions(head, face_data.fp_empties(head))
    assert fdp.feature_points.keys() == rest.keys()
    for fp_id, p in fdp.in_mesh(BLENDER_FACE_AXES).items():
        np.testing.assert_allclose(p, rest[fp_id], rtol=0, atol=1e-12)
    assert fdp.fapu == compute_fapu(rest)
    np.testing.assert_allclose(list(fdp.fapu.as_dict().values()), head.mpeg4_face.fapu, rtol=1e-6)


@pytest.mark.skipif(not ALICE.is_file(), reason="the XFace interop files are not next to the checkout")
def test_an_xface_fdp_gives_its_fapu_and_changes_nothing_else():
    head = set_up_sample()
    before = state(head)
    assert bpy.ops.mpeg4.import_fdp(filepath=str(ALICE), xface_unit=0.001) == {"FINISHED"}
    np.testing.assert_allclose(head.mpeg4_face.fapu, [0.016, 0.069, 0.051, 0.030, 0.050], rtol=1e-6)
    after = state(head)
    after.pop("fapu"), before.pop("fapu")
    assert after == before


def calibration_target(head, linear, shift) -> bpy.types.Object:
    """A copy of the head mapped by (linear, shift), with its own FP empties in '<target> FPs'."""
    mesh = head.data.copy()
    mesh.attributes["position"].data.foreach_set(
        "vector", (positions(head.data).astype(np.float64) @ linear.T + shift).astype(np.float32).ravel()
    )
    target = bpy.data.objects.new("Scan", mesh)
    target.matrix_world = head.matrix_world
    bpy.context.scene.collection.objects.link(target)
    collection = bpy.data.collections.new("Scan FPs")
    bpy.context.scene.collection.children.link(collection)
    world = np.array(head.matrix_world)
    for fp_id, p in neutral(head).items():
        empty = bpy.data.objects.new(f"Scan FP {fp_id}", None)
        empty["mpeg4_fp"] = fp_id
        empty.location = world[:3, :3] @ (linear @ p + shift) + world[:3, 3]
        collection.objects.link(empty)
    bpy.context.view_layer.update()
    return target


def test_fit_to_a_calibration_mesh_lays_the_face_on_it():
    head = set_up_sample()
    generic = rest_shape.stored_rest(head.data).astype(np.float64)
    rest = neutral(head)
    linear, shift = np.diag([1.06, 0.97, 1.02]), np.array([0.0, 0.004, -0.006])
    target = calibration_target(head, linear, shift)
    target.select_set(True)
    assert bpy.ops.mpeg4.fit_to_calibration_mesh() == {"FINISHED"}
    fitted = positions(head.data).astype(np.float64)
    surface = BVHTree.FromObject(target, bpy.context.evaluated_depsgraph_get())  # the same frame as the head's
    off = np.array([(surface.find_nearest(Vector(p))[0] - Vector(p)).length for p in fitted])
    before = np.linalg.norm(generic - (generic @ linear.T + shift), axis=1)
    assert np.median(off) < 1e-5 and np.percentile(off, 95) < 0.02 * np.percentile(before, 95)
    empties = face_data.fp_empties(head)
    for fp_id in ("3.5", "9.11", "10.9"):  # off the skin: not snapped
        np.testing.assert_allclose(empties[fp_id].location, linear @ rest[fp_id] + shift, rtol=0, atol=1e-6)


def unchanged_by(head, call, match: str) -> None:
    bpy.context.view_layer.update()
    before = state(head)
    with pytest.raises(RuntimeError, match=match):
        call()
    assert state(head) == before


def test_too_few_feature_points_leave_the_scene_unchanged():
    head = set_up_sample()
    face_data.fp_empties(head)["9.3"].location.y -= 0.004
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}  # the generic face has all FPs
    for fp_id, ob in face_data.fp_empties(head).items():
        if fp_id not in ("2.1", "9.3", "3.5"):
            bpy.data.objects.remove(ob)
    unchanged_by(head, bpy.ops.mpeg4.fit_to_feature_points, "at least")


def test_coincident_feature_points_given_apart_leave_the_scene_unchanged():
    head = set_up_sample()
    empties = face_data.fp_empties(head)
    empties["11.4"].location.z += 0.01
    empties["11.5"].location.z += 0.02
    bpy.context.view_layer.update()
    unchanged_by(head, bpy.ops.mpeg4.fit_to_feature_points, "11.4 and 11.5 are one point")


def test_a_calibration_mesh_without_feature_points_is_refused():
    head = set_up_sample()
    mesh = head.data.copy()
    target = bpy.data.objects.new("Scan", mesh)
    bpy.context.scene.collection.objects.link(target)
    select(head)
    unchanged_by(head, bpy.ops.mpeg4.fit_to_calibration_mesh, "Select the calibration mesh too")
    target.select_set(True)
    unchanged_by(head, bpy.ops.mpeg4.fit_to_calibration_mesh, "Scan has no feature points")


def test_a_set_up_refusing_the_fitted_face_puts_everything_back(monkeypatch):
    head = set_up_sample()
    face_data.fp_empties(head)["9.3"].location.y -= 0.005
    bpy.context.view_layer.update()

    def refuse(face):
        raise face_setup.Mpeg4Error("refused")

    monkeypatch.setattr(face_setup, "plan", refuse)
    unchanged_by(head, bpy.ops.mpeg4.fit_to_feature_points, "refused")


def test_animated_feature_points_are_refused():
    head = set_up_sample()
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    unchanged_by(head, bpy.ops.mpeg4.fit_to_feature_points, "are animated")


def test_a_bad_fdp_file_leaves_the_scene_unchanged(tmp_path):
    head = set_up_sample()
    path = tmp_path / "bad.fdp.json"
    path.write_text('{"format": "mpeg4-face-fdp", "version": 1, "feature_points": {"3.5": [0, 0, "x"]}}')
    unchanged_by(head, lambda: bpy.ops.mpeg4.import_fdp(filepath=str(path)), "3.5")
    path.write_text('{"format": "mpeg4-face-fdp", "version": 1, "feature_points": {"3.5": [0, 0, 1]}}')
    unchanged_by(head, lambda: bpy.ops.mpeg4.import_fdp(filepath=str(path)), "at least")


def test_a_face_with_shape_keys_fits_its_reference_key_and_keeps_the_offsets_of_the_others():
    head = unset_sample()
    head.shape_key_add(name="Basis", from_mix=False)
    smile = head.shape_key_add(name="Smile", from_mix=False)
    co = rest_shape.read_key(smile).copy()
    co[:, 2] += 0.002
    smile.data.foreach_set("co", co.ravel())
    keys = {block.name: rest_shape.read_key(block).copy() for block in head.data.shape_keys.key_blocks}
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    generic = keys["Basis"].astype(np.float64)
    move_fps(head, {fp_id: AFFINE @ p + SHIFT for fp_id, p in neutral(head).items()})
    assert bpy.ops.mpeg4.fit_to_feature_points() == {"FINISHED"}
    blocks = head.data.shape_keys.key_blocks
    fitted = rest_shape.read_key(blocks["Basis"]).astype(np.float64)
    np.testing.assert_allclose(fitted, generic @ AFFINE.T + SHIFT, rtol=0, atol=1e-6)
    offset = rest_shape.read_key(blocks["Smile"]).astype(np.float64) - fitted
    np.testing.assert_allclose(offset, keys["Smile"] - keys["Basis"], rtol=0, atol=1e-6)
    assert bpy.ops.mpeg4.fit_reset() == {"FINISHED"}
    for name, co in keys.items():
        np.testing.assert_array_equal(rest_shape.read_key(blocks[name]), co, err_msg=name)


def test_without_scipy_a_fit_is_refused_with_a_message_and_nothing_changes(monkeypatch):
    head = set_up_sample()
    face_data.fp_empties(head)["9.3"].location.y -= 0.004
    monkeypatch.setitem(sys.modules, "scipy.spatial", None)  # what `import scipy.spatial` meets without scipy
    unchanged_by(head, bpy.ops.mpeg4.fit_to_feature_points, r"fitting needs scipy \(Qhull\)")


# Blender ships numpy but not scipy: without the extension's scipy wheel the add-on must still load and play;
# only fitting and the switch to Elastic Bones (which makes skin weights) are refused.
WITHOUT_SCIPY = textwrap.dedent("""
    import sys
    sys.modules["scipy"] = None  # no scipy in this Python
    import bpy
    import addon
    addon.register()
    bpy.ops.wm.open_mainfile(filepath=sys.argv[-1])
    head = bpy.data.objects["Head"]
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    bpy.data.objects["FP 2.1"].location.z -= 0.01
    for refused in (bpy.ops.mpeg4.fit_to_feature_points, lambda: bpy.ops.mpeg4.set_engine(engine="ELASTIC_BONES")):
        try:
            refused()
        except RuntimeError as error:
            print("REFUSED:", error)
    assert not any(name.startswith("scipy") for name in sys.modules if sys.modules[name])
    print("LOADED-WITHOUT-SCIPY")
""")


def test_the_add_on_loads_and_sets_up_without_scipy_and_refuses_fitting_and_elastic_bones():
    result = subprocess.run(
        [sys.executable, "-c", WITHOUT_SCIPY, str(SAMPLE)], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert "LOADED-WITHOUT-SCIPY" in result.stdout, result.stdout[-3000:] + result.stderr[-3000:]
    assert "REFUSED: Error: fitting needs scipy (Qhull), which Blender does not ship" in result.stdout, result.stdout
    assert "REFUSED: Error: Elastic Bones' skin weights need scipy (sparse graphs)" in result.stdout, result.stdout
