"""Set-up on other faces: an incomplete FP set, FPs placed by clicking, the second sample face."""

import bpy
import numpy as np
import pytest

from addon.blender import binding_store, face_data, rest_shape
from addon.mpeg4.control_mesh import spans_opening
from addon.mpeg4.decode import fap_to_fp
from addon.mpeg4.fapu import Fapu
from addon.mpeg4.feature_points import fp_index

from .helpers import DEMO_FAP, ROOT, open_sample, positions, select


def test_incomplete_fp_set_gets_a_delaunay_control_mesh_without_crossing_openings():
    head = open_sample()
    select(head)
    bpy.ops.mpeg4.remove_face()
    empties = face_data.fp_empties(head) or {ob["mpeg4_fp"]: ob for ob in bpy.data.collections["Head FPs"].objects}
    for fp_id in ("4.5", "4.6", "5.3", "5.4", "9.6", "9.7", "2.13", "2.14"):
        bpy.data.objects.remove(empties[fp_id])
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    control = head.mpeg4_face.control_object.data
    ids = list(control[face_data.FP_IDS_PROP])
    assert "4.5" not in ids and "2.1" in ids
    tris = [[ids[k] for k in p.vertices] for p in control.polygons]
    assert len(tris) > 40 and not any(spans_opening(t) for t in tris)
    face_data.fp_empties(head)["2.1"].location.z -= 0.01
    bpy.context.view_layer.update()
    assert np.abs(positions(head.data) - rest_shape.stored_rest(head.data)).max() > 0.004


def test_place_feature_point_creates_snapped_empties_and_setup_needs_them():
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, segments=32, ring_count=16)
    face = bpy.context.active_object
    face.name = "Ball"
    with pytest.raises(RuntimeError, match="no feature point empties"):
        bpy.ops.mpeg4.setup_face()
    assert "Ball FPs" not in bpy.data.collections  # a failed set-up changes nothing
    # place a handful of skin points, a little off the surface: they snap onto it
    layout = {
        "2.1": (0, -0.09),
        "8.3": (0.03, -0.05),
        "8.4": (-0.03, -0.05),
        "9.3": (0, -0.01),
        "4.1": (0.02, 0.04),
        "4.2": (-0.02, 0.04),
        "5.1": (0.06, -0.03),
        "5.2": (-0.06, -0.03),
    }
    for fp_id, (x, z) in layout.items():
        y = -np.sqrt(0.1**2 - x * x - z * z) - 0.005
        assert bpy.ops.mpeg4.place_feature_points(fp_id=fp_id, location=(x, y, z)) == {"FINISHED"}
    empties = face_data.fp_empties(face)
    assert set(empties) == set(layout)
    for ob in empties.values():
        assert ob.parent == face and abs(ob.location.length - 0.1) < 2e-3  # on the (faceted) sphere
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}  # FAPU cannot be measured: a warning, not a failure
    assert not any(face.mpeg4_face.fapu) and face.mpeg4_face.enabled
    with pytest.raises(RuntimeError, match="no FAPU"):
        bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP))


def test_open_jaw_moves_each_faces_chin_by_its_own_mns0():
    for name in ("makehuman_head.blend", "makehuman_head_b.blend"):
        head = open_sample(ROOT / "sample_blends" / name)
        select(head)
        bpy.ops.mpeg4.setup_face()
        fapu = Fapu(*head.mpeg4_face.fapu)
        values = np.zeros((1, 68))
        values[0, 2] = 512
        empties = face_data.fp_empties(head)
        neutral = face_data.neutral_array({k: np.array(ob["mpeg4_rest"]) for k, ob in empties.items()})
        chin = fap_to_fp(neutral, values, fapu)[0, fp_index("2.1")]
        face_data.fp_empties(head)["2.1"].location = chin
        bpy.context.view_layer.update()
        rest = rest_shape.stored_rest(head.data)
        drop = rest[:, 2] - positions(head.data)[:, 2]
        at_chin = np.argmin(np.linalg.norm(rest - neutral[fp_index("2.1")], axis=1))
        # the skin at 2.1 goes down by most of the FP's MNS0/2 (neighbouring triangles that stay blend in)
        assert 0.6 * fapu.MNS0 / 2 < drop[at_chin] < 1.05 * fapu.MNS0 / 2


def test_a_mask_image_binds_like_the_vertex_groups_it_was_painted_from():
    head = open_sample()
    select(head)
    by_groups = binding_store.load(head)
    # paint the four vertex-group masks into an image, texel by texel at each vertex's UV, and use it
    mesh = head.data
    loop_vertex = np.array([loop.vertex_index for loop in mesh.loops])
    loop_uv = np.array([d.uv[:] for d in mesh.uv_layers.active.data])
    from addon.deform.masks import vertex_uvs

    uv = vertex_uvs(loop_vertex, loop_uv, len(mesh.vertices))
    size = 1024
    pixels = np.ones((size, size, 4), dtype=np.float32)
    corner = np.floor(uv * size - 0.5).astype(int)  # the 2x2 texels a bilinear sample at uv reads
    from addon.blender.binding_store import missing_masks, vertex_masks

    groups = vertex_masks(head)
    for channel, name in enumerate(("upper_lip", "lower_lip", "upper_eyelid", "lower_eyelid")):
        for dx in (0, 1):
            for dy in (0, 1):
                x, y = np.clip(corner[:, 0] + dx, 0, size - 1), np.clip(corner[:, 1] + dy, 0, size - 1)
                pixels[y, x, channel] = groups[name]
    image = bpy.data.images.new("masks", size, size, alpha=True, float_buffer=True)
    image.pixels.foreach_set(pixels.ravel())
    key = binding_store.stored_key(head)
    head.mpeg4_face.mask_image = image  # rebinds
    assert binding_store.stored_key(head) != key
    sampled = vertex_masks(head)
    assert missing_masks(head) == [] and set(sampled) == set(groups)
    for name in groups:  # texels shared by neighbouring vertices blur a few weights; the rest match
        assert np.mean(np.abs(sampled[name] - groups[name]) < 0.05) > 0.9
    by_image = binding_store.load(head)
    assert by_image.n_pairs == pytest.approx(by_groups.n_pairs, rel=0.1)
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.z -= 0.01
    bpy.context.view_layer.update()
    assert np.abs(positions(head.data) - rest_shape.stored_rest(head.data)).max() > 0.004


def test_what_a_rebind_keeps_needs_equal_arrays_of_equal_shape():
    rest = np.zeros((4, 3))
    kept = (rest, np.arange(3), np.array(["2.2", "2.3"]))
    assert binding_store.same_inputs(kept, (rest.copy(), np.arange(3), np.array(["2.2", "2.3"])))
    assert not binding_store.same_inputs(kept, (np.zeros((5, 3)), np.arange(3), np.array(["2.2", "2.3"])))
    assert not binding_store.same_inputs(kept, (rest, np.arange(3).reshape(1, 3), np.array(["2.2", "2.3"])))
    assert not binding_store.same_inputs(kept, (rest, np.array([0, 1, 3]), np.array(["2.2", "2.3"])))
    assert not binding_store.same_inputs(kept, (rest, np.arange(3), np.array(["2.2", "2.4"])))
