"""The bundled sample heads: FPs on their surfaces and mirrored, plausible FAPU, a sound control mesh,
masks, and the ground-truth expression units on the hidden reference copy only."""

from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Vector

from addon.mpeg4.control_mesh import MASK_NAMES, check_control_mesh, control_fp_ids, template_indices
from addon.mpeg4.feature_points import FEATURE_POINTS, FP_IDS

SAMPLES = Path(__file__).resolve().parents[2] / "sample_blends"
FILES = ("makehuman_head.blend", "makehuman_head_b.blend")
HEAD = "Head"
SURFACE_OBJECTS = {"eye": {"L": "Eye L", "R": "Eye R"}, "teeth": "Teeth", "tongue": "Tongue"}
UPPER_INNER_LIP, LOWER_INNER_LIP = {"2.2", "2.6", "2.7"}, {"2.3", "2.8", "2.9"}
UPPER_EYELIDS, LOWER_EYELIDS = {"3.1", "3.2"}, {"3.3", "3.4"}
EXPRESSION_UNITS = 34


@pytest.fixture(params=FILES)
def head(request):
    bpy.ops.wm.open_mainfile(filepath=str(SAMPLES / request.param))
    return bpy.data.objects[HEAD]


def fp_empties(head):
    return {obj["mpeg4_fp"]: obj for obj in bpy.data.collections[f"{HEAD} FPs"].objects if obj.type == "EMPTY"}


def fp_locations(head):
    return {fp_id: np.array(empty.location) for fp_id, empty in fp_empties(head).items()}


def candidate_surfaces(head, fp):
    """The objects an FP may lie on: the head skin, or the named eye / teeth / tongue objects."""
    if fp.surface in ("skin", "ear", "hair"):
        return [head]
    if fp.surface == "eye":
        return [bpy.data.objects[SURFACE_OBJECTS["eye"][fp.side]]]
    return [obj for obj in head.children if obj.name.startswith(SURFACE_OBJECTS[fp.surface])]


def test_84_fp_empties_parented_with_identity_inverse(head):
    empties = fp_empties(head)
    assert sorted(empties, key=FP_IDS.index) == list(FP_IDS)
    for fp_id, empty in empties.items():
        assert empty.name == f"FP {fp_id}"
        assert empty.parent == head
        assert np.allclose(np.array(empty.matrix_parent_inverse), np.eye(4))


def test_each_fp_lies_on_its_surface(head):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    empties = fp_empties(head)
    for fp in FEATURE_POINTS:
        world = empties[fp.id].matrix_world.translation
        if fp.surface == "inside":
            assert head.ray_cast(head.matrix_world.inverted() @ world, Vector((0, 0, 1)))[0]  # enclosed
            continue
        distances = []
        for obj in candidate_surfaces(head, fp):
            evaluated = obj.evaluated_get(depsgraph)
            local = obj.matrix_world.inverted() @ world
            found, closest, _, _ = evaluated.closest_point_on_mesh(local)
            assert found
            distances.append(((obj.matrix_world @ closest) - world).length)
        assert min(distances) < 1e-6, f"FP {fp.id} is {min(distances):.2e} m off its {fp.surface} surface"


def test_left_and_right_fps_mirror_across_the_midline(head):
    positions = fp_locations(head)
    for fp in FEATURE_POINTS:
        mirrored = positions[fp.mirror or fp.id] * np.array([-1.0, 1.0, 1.0])
        assert np.linalg.norm(positions[fp.id] - mirrored) < 1e-3, fp.id
        if fp.side != "mid":
            assert (positions[fp.id][0] > 0) == (fp.side == "L"), f"{fp.id} on the wrong side"


def test_fapu_is_plausible_for_an_adult(head):
    fapu = dict(zip(("IRISD0", "ES0", "ENS0", "MNS0", "MW0"), head.mpeg4_face.fapu, strict=True))
    ranges = {
        "ES0": (0.055, 0.075),
        "IRISD0": (0.006, 0.014),
        "ENS0": (0.035, 0.065),
        "MNS0": (0.010, 0.030),
        "MW0": (0.040, 0.065),
    }
    assert set(fapu) == set(ranges)
    for name, (low, high) in ranges.items():
        assert low < fapu[name] < high, f"{name} = {fapu[name]}"


def test_control_mesh_is_manifold_facing_out_and_spans_no_opening(head):
    control = bpy.data.objects[f"{HEAD} Control"]
    assert control.parent == head
    ids = control_fp_ids(FP_IDS)
    points = np.array([v.co for v in control.data.vertices])
    triangles = np.array([list(p.vertices) for p in control.data.polygons])
    assert points.shape == (len(ids), 3)
    assert np.array_equal(triangles, template_indices(ids))
    assert check_control_mesh(points, triangles) == []
    locations = fp_locations(head)
    assert np.allclose(points, [locations[fp_id] for fp_id in ids], atol=1e-7)
    centre = locations["7.1"]
    corners = points[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert np.all(np.einsum("ij,ij->i", normals, corners.mean(axis=1) - centre) > 0)
    for triangle in triangles:
        fps = {ids[i] for i in triangle}
        assert not (fps & UPPER_INNER_LIP and fps & LOWER_INNER_LIP), fps
        assert not (fps & UPPER_EYELIDS and fps & LOWER_EYELIDS), fps


def test_masks_separate_the_lips_and_the_eyelids(head):
    index = {head.vertex_groups[name].index: name for name in MASK_NAMES}
    weights = {name: np.zeros(len(head.data.vertices)) for name in MASK_NAMES}
    for vertex in head.data.vertices:
        for element in vertex.groups:
            if element.group in index:
                weights[index[element.group]][vertex.index] = element.weight
    coordinates = np.array([v.co for v in head.data.vertices])
    locations = fp_locations(head)

    def weight(mask, fp_id):
        return weights[mask][np.argmin(np.linalg.norm(coordinates - locations[fp_id], axis=1))]

    for mask, zero, one in (
        ("upper_lip", ("2.3", "2.8", "8.2", "2.1"), ("2.2", "2.6", "8.1", "9.3")),
        ("lower_lip", ("2.2", "2.7", "8.1", "9.3"), ("2.3", "2.9", "8.2", "2.10")),
        ("upper_eyelid", ("3.3", "3.4"), ("3.1", "3.2", "3.13", "9.3")),
        ("lower_eyelid", ("3.1", "3.2"), ("3.3", "3.4", "3.9", "9.3", "2.1")),
    ):
        assert all(weight(mask, fp_id) == 0.0 for fp_id in zero), mask
        assert all(weight(mask, fp_id) == 1.0 for fp_id in one), mask


def test_head_geometry_and_mh_index(head):
    mesh = head.data
    assert 3500 < len(mesh.vertices) < 5000
    assert all(len(polygon.vertices) == 4 for polygon in mesh.polygons)
    assert mesh.uv_layers
    mh_index = np.zeros(len(mesh.vertices), dtype=np.int32)
    mesh.attributes["mh_index"].data.foreach_get("value", mh_index)
    assert len(set(mh_index.tolist())) == len(mh_index) and mh_index.min() >= 0
    world = np.array([head.matrix_world @ v.co for v in mesh.vertices])
    height = world[:, 2].max() - world[:, 2].min()
    assert 0.2 < height < 0.35  # head and neck, in metres
    locations = fp_locations(head)
    assert locations["9.3"][1] < locations["11.6"][1]  # facing -Y: nose in front of the back of the skull
    assert locations["3.5"][0] > 0  # the face's left on +X
    for name in ("Eye L", "Eye R", "Teeth Upper", "Teeth Lower", "Tongue"):
        assert bpy.data.objects[name].parent == head


def test_ground_truth_shape_keys_only_on_the_hidden_reference(head):
    reference = bpy.data.objects[f"{HEAD} Reference"]
    assert reference.hide_viewport and reference.hide_render
    keys = reference.data.shape_keys.key_blocks
    assert len(keys) == EXPRESSION_UNITS + 1 and keys[0].name == "Basis"
    assert "mouth-open" in keys and "eye-left-closure" in keys
    assert head.data.shape_keys is None
    basis = np.array([v.co for v in keys["Basis"].data])
    opened = np.array([v.co for v in keys["mouth-open"].data])
    assert np.allclose(basis, [v.co for v in head.data.vertices], atol=1e-7)
    assert 0.01 < np.abs(opened - basis).max() < 0.05  # the jaw drops by centimetres


def test_the_shipped_set_up_names_each_part_on_its_own_side(head):
    s = head.mpeg4_face
    assert (s.left_eye.name, s.right_eye.name) == ("Eye L", "Eye R")
    assert s.left_eye.matrix_world.translation.x > s.right_eye.matrix_world.translation.x  # left is +X
    assert (s.lower_teeth.name, s.tongue.name) == ("Teeth Lower", "Tongue")
