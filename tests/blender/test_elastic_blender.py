"""Elastic Bones in Blender (addon/blender/elastic_rig.py, elastic_ops.py): the skeleton built on the sample faces,
Blender's Armature modifier as the core's skinning (eq. 1), the engine switch, Remove, bad input, and the glTF
export of scripts/convert.py."""

import json
import struct
import sys

import bpy
import numpy as np
import pytest
from mathutils import Matrix

from addon.blender import animation, binding_store, elastic_rig, face_data
from addon.elastic.parameters import TRAINED
from addon.elastic.pose import pose_from_fps
from addon.elastic.skeleton import BONES, EYE_BONES, place_skeleton
from addon.elastic.skinning import linear_blend_skinning, skin_weights

from ..scripts.helpers import cut_stream, run_convert
from .helpers import DEMO_FAP, ROOT, SAMPLE, evaluated_positions, open_sample, positions, select

SECOND = ROOT / "sample_blends" / "makehuman_head_b.blend"
PREFIX = elastic_rig.BONE_PREFIX


def set_up(path=SAMPLE, engine=elastic_rig.ELASTIC):
    head = open_sample(path)
    select(head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    if engine == elastic_rig.ELASTIC:
        assert bpy.ops.mpeg4.set_engine(engine=engine) == {"FINISHED"}
    return head


def moved_fps(head) -> dict[str, np.ndarray]:
    return {fp_id: np.array(ob.location, dtype=np.float64) for fp_id, ob in face_data.fp_empties(head).items()}


def core_result(head):
    """What the core makes of the face's rest mesh and FP empties as they are now: (rest, weights, deformed)."""
    neutral = elastic_rig.neutral_fps(head)
    skeleton = place_skeleton(neutral)
    rest = positions(head.data).astype(np.float64)
    weights = skin_weights(rest, face_data.mesh_edges(head.data), skeleton, binding_store.vertex_masks(head))
    transforms = pose_from_fps(skeleton, neutral, moved_fps(head), TRAINED)
    return rest, weights, linear_blend_skinning(rest, weights, transforms)


def snapshot(head) -> dict:
    """What a refused or undone change must leave as it was."""
    return {
        "objects": sorted(ob.name for ob in bpy.data.objects),
        "armatures": len(bpy.data.armatures),
        "groups": [g.name for g in head.vertex_groups],
        "active_group": head.vertex_groups.active_index,
        "modifiers": [m.name for m in head.modifiers],
        "props": sorted(head.keys()),
        "engine": head.mpeg4_face.engine,
        "mesh": positions(head.data).copy(),
        "parts": {
            ob.name: (
                ob.parent and ob.parent.name,
                ob.parent_type,
                ob.parent_bone,
                tuple(map(tuple, ob.matrix_parent_inverse)),
            )
            for ob in bpy.data.objects
            if ob.type == "MESH"
        },
        "muted": sorted(
            (ob.name, f.data_path, f.array_index, f.mute)
            for ob in bpy.data.objects
            if ob.animation_data
            for f in ob.animation_data.drivers
        ),
    }


def assert_same(before: dict, after: dict) -> None:
    np.testing.assert_array_equal(after.pop("mesh"), before.pop("mesh"))
    assert after == before


@pytest.mark.parametrize("path", [SAMPLE, SECOND], ids=["sample", "second sample"])
def test_the_skeleton_is_built_on_the_feature_points(path):
    head = set_up(path)
    arm = elastic_rig.skeleton_object(head)
    assert arm.parent == head and arm.matrix_parent_inverse == Matrix.Identity(4)
    assert arm.matrix_basis == Matrix.Identity(4)  # armature space is the face's mesh space
    parents = {b.name: b.parent.name if b.parent else None for b in arm.data.bones}
    assert parents == {PREFIX + b.name: PREFIX + b.parent if b.parent else None for b in BONES}
    neutral = elastic_rig.neutral_fps(head)
    for bone in BONES:
        data = arm.data.bones[PREFIX + bone.name]
        if bone.name in EYE_BONES:  # from the eyeball's centre, behind the pupil, to the pupil
            np.testing.assert_allclose(data.tail_local, neutral[bone.head[0]], atol=1e-6)
            assert data.head_local.y > data.tail_local.y  # the face looks down -y
        else:
            np.testing.assert_allclose(data.head_local, np.mean([neutral[f] for f in bone.head], axis=0), atol=1e-6)
        if bone.tail and bone.name not in EYE_BONES:
            np.testing.assert_allclose(data.tail_local, np.mean([neutral[f] for f in bone.tail], axis=0), atol=1e-6)
    # the eyes and the jaw's parts ride on their bones; the eyes do not skin the face
    assert bpy.data.objects["Eye L"].parent_bone == PREFIX + "eye_l"
    assert bpy.data.objects["Teeth Lower"].parent_bone == PREFIX + "jaw"
    assert PREFIX + "eye_l" not in head.vertex_groups and PREFIX + "jaw" in head.vertex_groups
    assert head.modifiers[0].type == "ARMATURE" and head.modifiers[0].object == arm


def test_the_armature_modifier_is_the_cores_skinning():
    head = set_up()
    empties = face_data.fp_empties(head)
    empties["2.1"].location.z -= 0.01  # jaw down
    empties["8.4"].location.x -= 0.004  # a lip corner out
    empties["4.1"].location.z += 0.005  # a brow up
    empties["3.5"].location.x += 0.003  # the left pupil (a turning eye, no skin)
    bpy.context.view_layer.update()
    rest, weights, expected = core_result(head)
    # the vertex groups hold the core's weights (float32); the modifier normalises them as eq. 2 does
    groups = face_data.group_weights(
        head, [PREFIX + name for name in place_skeleton(elastic_rig.neutral_fps(head)).names]
    )
    for b, bone in enumerate(BONES):
        np.testing.assert_allclose(groups.get(PREFIX + bone.name, np.zeros(len(rest))), weights[:, b], atol=1e-7)
    np.testing.assert_array_equal(positions(head.data), rest.astype(np.float32))  # the mesh keeps its rest shape
    deformed = evaluated_positions(head)
    assert np.linalg.norm(deformed - rest, axis=1).max() > 1e-3
    assert np.abs(deformed - expected).max() < 1e-5
    # the eyeball turns with its bone: its pupil side follows FP 3.5 sideways
    eye = bpy.data.objects["Eye L"]
    assert eye.matrix_world.to_quaternion().angle > 0.01


def test_one_stream_drives_both_engines_and_switching_back_restores_planar_bones_bit_for_bit():
    head = set_up(engine=elastic_rig.PLANAR)
    scene = bpy.context.scene
    scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    jaw = face_data.fp_empties(head)["2.1"]
    frames = range(scene.frame_start, scene.frame_end + 1)
    heights = [animation.sample(jaw, "location", 2, np.array([f]), jaw.location.z)[0] for f in frames]
    frame = frames[int(np.argmin(heights))]  # the widest open mouth
    scene.frame_set(frame)
    planar = evaluated_positions(head)

    assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC) == {"FINISHED"}
    scene.frame_set(frame)
    elastic = evaluated_positions(head)
    _rest, _weights, expected = core_result(head)
    assert np.abs(elastic - expected).max() < 1e-5  # the same FP empties drive the skeleton
    chin = int(np.argmin(np.linalg.norm(_rest - elastic_rig.neutral_fps(head)["2.1"], axis=1)))  # FP 2.1's vertex
    assert elastic[chin, 2] < _rest[chin, 2] - 1e-3 and planar[chin, 2] < _rest[chin, 2] - 1e-3

    assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.PLANAR) == {"FINISHED"}
    assert elastic_rig.skeleton_object(head) is None and not head.modifiers
    assert not any(g.name.startswith(PREFIX) for g in head.vertex_groups)
    scene.frame_set(frame)
    np.testing.assert_array_equal(evaluated_positions(head), planar)


def test_import_with_elastic_bones_bakes_every_frame_into_keys_per_bone():
    head = set_up()
    scene = bpy.context.scene
    scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), timing="SCENE") == {"FINISHED"}
    arm = elastic_rig.skeleton_object(head)
    frames = scene.frame_end - scene.frame_start + 1
    jaw = f'pose.bones["{PREFIX}jaw"]'
    curves = [animation.find_fcurve(arm, f'pose.bones["{PREFIX}{b.name}"].location', 0) for b in BONES]
    # keys from the first frame to the last (a flat run keeps only its ends: set_keys)
    assert all(c is not None and 2 <= len(c.keyframe_points) <= frames for c in curves)
    assert {(c.keyframe_points[0].co.x, c.keyframe_points[-1].co.x) for c in curves} == {
        (scene.frame_start, scene.frame_end)
    }
    # the keys are the pose the handler sets from the FP empties
    for frame in (scene.frame_start + 20, scene.frame_start + 60):
        scene.frame_set(frame)
        bone = arm.pose.bones[PREFIX + "jaw"]
        keyed = [animation.find_fcurve(arm, f"{jaw}.rotation_quaternion", i).evaluate(frame) for i in range(4)]
        np.testing.assert_allclose(keyed, bone.rotation_quaternion, atol=1e-6)
        keyed = [animation.find_fcurve(arm, f"{jaw}.location", i).evaluate(frame) for i in range(3)]
        np.testing.assert_allclose(keyed, bone.location, atol=1e-7)


def test_remove_leaves_the_file_as_it_was():
    head = open_sample()
    before = snapshot(head)
    select(head)
    bpy.ops.mpeg4.setup_face()
    assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC) == {"FINISHED"}
    bpy.context.scene.render.fps = 25
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    bpy.context.scene.frame_set(30)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    after = snapshot(head)
    # as the Planar Bones test has it: the sample's own empties and parts stay, the control mesh set-up made goes
    before["objects"].remove("Head Control")
    del before["parts"]["Head Control"]
    before["muted"] = after["muted"]  # the followers' drivers go with set-up (the Planar Bones test checks that)
    assert_same(before, after)
    assert not any(a.name.startswith("demo") for a in bpy.data.actions)


def test_a_face_missing_a_bones_feature_point_is_refused_and_nothing_changes():
    head = set_up(engine=elastic_rig.PLANAR)
    bpy.data.objects.remove(face_data.fp_empties(head)["10.9"])  # the ears' tail
    bpy.context.view_layer.update()
    before = snapshot(head)
    with pytest.raises(RuntimeError, match=r"cannot place the elastic-bones skeleton: bone 'ear_l' needs FP 10\.9$"):
        bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC)
    assert_same(before, snapshot(head))


def test_a_vertex_group_named_like_a_bone_is_refused_and_nothing_changes():
    head = set_up(engine=elastic_rig.PLANAR)
    head.vertex_groups.new(name=PREFIX + "jaw")
    before = snapshot(head)
    with pytest.raises(RuntimeError, match=f"vertex groups named like the skeleton's bones: {PREFIX}jaw"):
        bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC)
    assert_same(before, snapshot(head))


def _glb_json(path) -> dict:
    data = path.read_bytes()
    assert data[:4] == b"glTF"
    length = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20 : 20 + length])


def test_convert_writes_a_glb_that_imports_back_with_a_skin_and_an_animation(tmp_path):
    stream = cut_stream(tmp_path / "short.fap", frames=8)
    out = tmp_path / "out"
    result = run_convert(
        "--face", SAMPLE, stream, "-o", out, "--engine-face", "elastic", "--glb", "--no-video", "--sheet", "0"
    )
    assert result.returncode == 0, result.stdout + result.stderr
    glb = out / "short.glb"
    gltf = _glb_json(glb)
    assert len(gltf["skins"]) == 1 and len(gltf["skins"][0]["joints"]) == len(BONES)
    joints = {gltf["nodes"][j]["name"] for j in gltf["skins"][0]["joints"]}
    assert joints == {PREFIX + b.name for b in BONES}
    (animation,) = gltf["animations"]
    times = [gltf["accessors"][sampler["input"]] for sampler in animation["samplers"]]
    assert max(t["count"] for t in times) == 8 and min(t["min"][0] for t in times) == 0.0
    meshes = {node["name"] for node in gltf["nodes"] if "mesh" in node}
    assert {"Head", "Eye L", "Eye R", "Teeth Lower", "Tongue"} <= meshes
    vertices = len(open_sample().data.vertices)
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(glb))
    (arm,) = [ob for ob in bpy.data.objects if ob.type == "ARMATURE"]
    assert len(arm.data.bones) == len(BONES)
    skinned = [ob for ob in bpy.data.objects if any(m.type == "ARMATURE" and m.object == arm for m in ob.modifiers)]
    assert len(skinned) == 1 and len(skinned[0].data.vertices) >= vertices  # glTF splits vertices at UV seams


def test_convert_refuses_glb_without_elastic_bones(tmp_path):
    stream = cut_stream(tmp_path / "short.fap", frames=2)
    result = run_convert("--face", SAMPLE, stream, "-o", tmp_path / "out", "--glb")
    assert result.returncode == 2
    assert (
        result.stderr.strip() == "convert.py: error: --glb exports a skeleton and its keys: add --engine-face elastic"
    )


def test_set_up_face_refuses_an_elastic_bones_face_and_nothing_changes():
    head = set_up()
    before = snapshot(head)
    with pytest.raises(RuntimeError, match="uses Elastic Bones: switch the Engine to Planar Bones, set up"):
        bpy.ops.mpeg4.setup_face()
    assert_same(before, snapshot(head))


def test_without_scipy_the_switch_is_refused_with_a_message_and_nothing_changes(monkeypatch):
    head = set_up(engine=elastic_rig.PLANAR)
    before = snapshot(head)
    for name in ("scipy.sparse", "scipy.sparse.csgraph"):
        monkeypatch.setitem(sys.modules, name, None)  # what `import scipy.sparse` meets without scipy
    with pytest.raises(RuntimeError, match=r"Elastic Bones' skin weights need scipy \(sparse graphs\)"):
        bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC)
    assert_same(before, snapshot(head))
