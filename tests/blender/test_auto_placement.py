"""Place Feature Points Automatically on the sample head and its variants; refusing what is not a head."""

import bpy
import numpy as np
import pytest

from addon.blender import auto_placement, face_data
from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.placement.landmarks import spine_top
from scripts.bench import variants

from .helpers import open_sample, select


def _sample_without_fps(change=None):
    """The sample head taken down, its FP empties' world positions kept as the truth and the empties
    deleted; `change` (a variant function) applied before they are deleted. The truth's 7.1 is the top of
    the spine as placement defines it (`landmarks.spine_top`), not the sample's head joint marker."""
    head = open_sample()
    select(head)
    bpy.ops.mpeg4.remove_face()
    if change is not None:
        change(head)
    bpy.context.view_layer.update()
    empties = face_data.fp_empties(head)
    truth = np.array([empties[fp_id].matrix_world.translation for fp_id in FP_IDS])
    truth[fp_index("7.1")] = spine_top(truth)
    for ob in empties.values():
        bpy.data.objects.remove(ob)
    bpy.context.view_layer.update()
    select(head)
    return head, truth


def _placed(head) -> np.ndarray:
    bpy.context.view_layer.update()
    empties = face_data.fp_empties(head)
    assert sorted(empties) == sorted(FP_IDS)
    for fp_id, ob in empties.items():
        assert ob.name == f"FP {fp_id}" and ob.parent == head and ob.users_collection[0].name == "Head FPs"
    return np.array([empties[fp_id].matrix_world.translation for fp_id in FP_IDS])


def _errors_mm(head, truth, scale=1.0) -> np.ndarray:
    return np.linalg.norm(_placed(head) - truth, axis=1) * 1000.0 / scale


def test_sample_head_gets_its_own_points_back():
    head, truth = _sample_without_fps()
    assert bpy.ops.mpeg4.auto_place_feature_points() == {"FINISHED"}
    errors = _errors_mm(head, truth)
    assert errors.mean() <= 1.0
    assert np.median(errors) <= 0.5
    # confidences are kept on each empty, the low ones listed on the face
    confidence = [face_data.fp_empties(head)[f][auto_placement.CONFIDENCE_PROP] for f in FP_IDS]
    assert all(0.0 <= c <= 1.0 for c in confidence)
    assert set(auto_placement.low_confidence(head)) <= set(FP_IDS)
    # set-up works on the result unchanged
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}


@pytest.mark.parametrize(
    "name, change, scale, mean_mm",
    [
        ("remeshed", lambda face: variants.voxel_remesh(face, 0.003), 1.0, 3.0),
        ("joined parts", variants.join_parts, 1.0, 1.0),
        ("y up", variants.rotate_y_up, 1.0, 1.0),
        ("scaled", lambda face: variants.scale(face, 10.0), 10.0, 1.0),
    ],
)
def test_variants_of_the_sample(name, change, scale, mean_mm):
    head, truth = _sample_without_fps(change)
    assert bpy.ops.mpeg4.auto_place_feature_points() == {"FINISHED"}, name
    errors = _errors_mm(head, truth, scale)
    assert errors.mean() <= mean_mm, (name, errors.mean())


def test_a_deforming_modifier_does_not_move_the_points_off_the_rest_mesh():
    """Placement reads the mesh at rest (where set-up binds it); a modifier that changes the shape as shown (an
    Armature on a skinned character, here a Displace 5 mm out along the normals) must not pull the empties
    onto the shown shape."""
    head, truth = _sample_without_fps()
    displace = head.modifiers.new("Shown shape", "DISPLACE")
    displace.strength, displace.mid_level = 0.005, 0.0
    assert bpy.ops.mpeg4.auto_place_feature_points() == {"FINISHED"}
    assert _errors_mm(head, truth).mean() <= 1.0  # as without the modifier (test_sample_head_gets_...)
    head.modifiers.remove(displace)


def test_existing_points_move_only_when_asked():
    head, truth = _sample_without_fps()
    assert bpy.ops.mpeg4.auto_place_feature_points() == {"FINISHED"}
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.z += 0.02
    with pytest.raises(RuntimeError, match="already has 84 feature points"):
        bpy.ops.mpeg4.auto_place_feature_points()
    assert chin.location.z == pytest.approx(truth[0][2] - head.location.z + 0.02, abs=2e-3)
    assert bpy.ops.mpeg4.auto_place_feature_points(move_existing=True) == {"FINISHED"}
    assert np.linalg.norm(_placed(head)[0] - truth[0]) < 2e-3


def _object_names() -> set[str]:
    return {ob.name for ob in bpy.data.objects} | {c.name for c in bpy.data.collections}


@pytest.mark.parametrize("shape", ["sphere", "cube"])
def test_not_a_head_is_refused_and_nothing_changes(shape):
    if shape == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, segments=48, ring_count=24)
    else:
        bpy.ops.mesh.primitive_cube_add(size=0.2)
    before = _object_names()
    with pytest.raises(RuntimeError, match="does not look like a human head"):
        bpy.ops.mpeg4.auto_place_feature_points()
    assert _object_names() == before
