"""Regression tests of the hardening issue: every one failed (or crashed) before its fix."""

import time

import bpy
import numpy as np
import pytest

from addon.blender import binding_store, eyelid_rig, face_data, fp_empties, live, rest_shape
from addon.blender.menus import MPEG4_FH_fap
from addon.mpeg4.fap_file import read_fap

from .helpers import DEMO_FAP, open_sample, positions, select, set_up_sample

N_FAPS = 68


def write_fap(path, frames, fps=25.0, values=None, name="test"):
    """A stream keying FAP 3 (open_jaw) and FAP 49 (head yaw) at the given stream frame numbers."""
    lines = [f"2.1 {name} {fps!r} {len(frames)}"]
    mask = ["0"] * N_FAPS
    mask[2] = mask[48] = "1"
    for i, frame in enumerate(frames):
        lines.append(" ".join(mask))
        jaw, yaw = values[i] if values is not None else (200 * (i % 3), 1000 * (i % 2))
        lines.append(f"{frame} {jaw} {yaw}")
    path.write_text("\n".join(lines) + "\n")
    return path


class Transform(tuple):
    """A transform's numbers, equal to another's within 1e-12: a library version (NumPy 1 or 2, its LAPACK) may round
    a fitted eye centre, and so a driver's angle at rest, an ULP differently (0 or 7e-21)."""

    def __eq__(self, other):
        return isinstance(other, tuple) and len(other) == len(self) and np.allclose(self, other, rtol=0.0, atol=1e-12)

    __hash__ = tuple.__hash__


def snapshot():
    """What a user could tell apart in the file: objects, transforms, meshes, animation, properties."""
    objects = {}
    for ob in bpy.data.objects:
        anim = ob.animation_data
        objects[ob.name] = (
            ob.type,
            ob.parent.name if ob.parent else None,
            Transform(value for row in ob.matrix_world for value in row),
            Transform(ob.delta_location),
            Transform(ob.delta_rotation_euler),
            Transform(ob.delta_rotation_quaternion),
            ob.rotation_mode,
            ob.empty_display_size if ob.type == "EMPTY" else None,
            sorted(ob.keys()),
            None
            if anim is None
            else (anim.action.name if anim.action else None, len(anim.nla_tracks), len(anim.drivers)),
            [m.name for m in ob.modifiers],
        )
    meshes = {}
    for mesh in bpy.data.meshes:
        keys = [k.name for k in mesh.shape_keys.key_blocks] if mesh.shape_keys else None
        meshes[mesh.name] = (positions(mesh).tobytes(), keys, sorted(mesh.keys()))
    scene = bpy.context.scene
    return {
        "objects": objects,
        "meshes": meshes,
        "actions": sorted(a.name for a in bpy.data.actions),
        "texts": sorted(t.name for t in bpy.data.texts),
        "collections": sorted(c.name for c in bpy.data.collections),
        "scene": (scene.frame_start, scene.frame_end, scene.render.use_lock_interface, sorted(scene.keys())),
    }


def unset_sample():
    """The sample head as a user would have it before set-up (the shipped file is set up)."""
    head = open_sample()
    select(head)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    return head


# ----------------------------------------------------------------------------- reliability


def test_set_up_again_after_applying_a_subdivision_starts_afresh():
    head = set_up_sample()
    n = len(head.data.vertices)
    head.modifiers.new("Subdivision", "SUBSURF").levels = 1
    bpy.ops.object.modifier_apply(modifier="Subdivision")
    bpy.context.view_layer.update()
    assert len(head.data.vertices) > n
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert binding_store.load(head).n_vertices == len(head.data.vertices)
    np.testing.assert_array_equal(rest_shape.stored_rest(head.data), positions(head.data))
    face_data.fp_empties(head)["2.1"].location.z -= 0.01
    bpy.context.view_layer.update()
    assert head.mpeg4_face.enabled and np.abs(positions(head.data) - rest_shape.stored_rest(head.data)).max() > 0.004


def test_coincident_feature_points_are_refused_before_anything_changes():
    head = set_up_sample()
    empties = face_data.fp_empties(head)
    key = binding_store.stored_key(head)
    empties["9.7"].location = empties["4.1"].location  # two corners of one control triangle on one spot
    before = {name: tuple(ob.location) for name, ob in bpy.data.objects.items()}
    with pytest.raises(RuntimeError, match="coincide or lie on one line"):
        bpy.ops.mpeg4.setup_face()
    assert binding_store.stored_key(head) == key  # the previous set-up is kept
    assert {name: tuple(ob.location) for name, ob in bpy.data.objects.items()} == before


@pytest.mark.parametrize(
    ("frames", "fps", "message"),
    [
        ([0, 1], 1e-300, "fps"),
        ([0, 2**53 - 1], 25.0, "frame"),
        ([0, 1_000_000_000], 25.0, "frame"),
    ],
)
def test_streams_that_cannot_play_are_refused_before_keying(tmp_path, frames, fps, message):
    head = set_up_sample()
    path = write_fap(tmp_path / "bad.fap", frames, fps=fps)
    actions = sorted(a.name for a in bpy.data.actions)
    before = snapshot()
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.mpeg4.import_fap(filepath=str(path))
    assert sorted(a.name for a in bpy.data.actions) == actions
    assert snapshot() == before
    assert head.mpeg4_face.enabled


def test_far_apart_frames_key_only_what_is_there(tmp_path):
    set_up_sample()
    path = write_fap(tmp_path / "far.fap", [0, 1_000_000], fps=1000.0)
    assert bpy.ops.mpeg4.import_fap(filepath=str(path), start_frame=0) == {"FINISHED"}
    chin = face_data.fp_empties(bpy.data.objects["Head"])["2.1"]
    fcurve = chin.animation_data.action.layers[0].strips[0].channelbags[0].fcurves.find("location", index=2)
    assert len(fcurve.keyframe_points) == 2
    assert fcurve.keyframe_points[1].co.x == pytest.approx(1_000_000 / 1000.0 * 24.0)


def test_absurd_values_are_refused_and_clamp_tames_them(tmp_path):
    head = set_up_sample()
    path = write_fap(tmp_path / "huge.fap", [0, 1], values=[(0, 0), (1e100, 0)])
    with pytest.raises(RuntimeError, match="Clamp"):
        bpy.ops.mpeg4.import_fap(filepath=str(path))
    assert bpy.ops.mpeg4.import_fap(filepath=str(path), clamp=1000.0) == {"FINISHED"}
    scene = bpy.context.scene
    scene.frame_set(scene.frame_start + 1)
    teeth = head.mpeg4_face.lower_teeth
    assert all(np.isfinite(teeth.matrix_world).ravel())
    assert np.isfinite(positions(head.data)).all()


def test_crafted_binding_dtype_is_refused_without_allocating():
    head = set_up_sample()
    group = binding_store.holder(head)[binding_store.BINDING_PROP]
    group["pair_weight.dtype"] = "V3000000000"  # a 3 GB item size
    live.forget()  # as opening the file does
    assert binding_store.load(head) is None
    group["pair_weight.dtype"] = "<f8"
    group["pair_weight.shape"] = [10**9, 3]  # a shape that does not match the stored array
    live.forget()
    assert binding_store.load(head) is None
    bpy.context.scene.frame_set(3)
    face_data.fp_empties(head)["2.1"].location.z -= 0.01
    bpy.context.view_layer.update()
    assert not head.mpeg4_face.enabled and "not bound" in head.mpeg4_face.status


def _posed_sample():
    head = set_up_sample()
    face_data.fp_empties(head)["2.1"].location.z -= 0.01
    bpy.context.view_layer.update()
    rest = rest_shape.stored_rest(head.data).copy()
    assert np.abs(positions(head.data) - rest).max() > 0.004
    return head, rest


def test_a_shape_key_added_while_posed_gets_the_rest_shape():
    head, rest = _posed_sample()
    head.shape_key_add(name="Basis", from_mix=False)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(rest_shape.read_key(head.data.shape_keys.reference_key), rest)
    # the pose now goes into our own key on top, and Deform off shows the rest shape
    assert head.data.shape_keys.key_blocks.get(rest_shape.SHAPE_KEY_NAME) is not None
    head.mpeg4_face.enabled = False
    np.testing.assert_array_equal(positions(head.data), rest)


def test_a_vertex_added_in_edit_mode_while_posed_does_not_bake_the_pose():
    head, rest = _posed_sample()
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.context.view_layer.update()
    assert head.mpeg4_face.status == live.PAUSED_IN_EDIT_MODE
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.mesh.primitive_cube_add(size=0.001)  # adds vertices to the edited mesh
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    n = len(rest)
    assert len(head.data.vertices) == n + 8
    np.testing.assert_array_equal(positions(head.data)[:n], rest)  # the rest shape, not the pose
    assert not head.mpeg4_face.enabled and "Edit Mode" in head.mpeg4_face.status
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}  # and it sets up again on the edited mesh
    assert binding_store.load(head).n_vertices == n + 8


def test_edit_mode_without_edits_resumes():
    head, rest = _posed_sample()
    posed = positions(head.data).copy()
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.context.view_layer.update()
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.update()
    assert head.mpeg4_face.enabled and head.mpeg4_face.status == ""
    np.testing.assert_allclose(positions(head.data), posed, atol=1e-7)


def test_a_face_far_from_the_origin_does_not_drift():
    head = set_up_sample()
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.z -= 0.01
    bpy.context.view_layer.update()
    near = positions(head.data).copy()
    chin.location.z += 0.01
    head.location = (2000.0, -1500.0, 700.0)
    bpy.context.view_layer.update()
    np.testing.assert_array_equal(positions(head.data), rest_shape.stored_rest(head.data))  # rest exactly
    chin.location.z -= 0.01
    bpy.context.view_layer.update()
    np.testing.assert_allclose(positions(head.data), near, atol=1e-6)


def test_head_rotation_round_trips_in_quaternion_mode(tmp_path):
    stream = read_fap(DEMO_FAP)
    results = {}
    for mode in ("XYZ", "QUATERNION", "ZXY"):
        head = set_up_sample()
        head.rotation_mode = mode
        bpy.context.scene.render.fps = 25
        assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=0) == {"FINISHED"}
        out = tmp_path / f"{mode}.fap"
        bpy.ops.mpeg4.export_fap(filepath=str(out), frame_start=0, frame_end=40)
        results[mode] = read_fap(out).values[:, 47:50]
    expected = stream.values[:41, 47:50]
    for mode, values in results.items():
        np.testing.assert_allclose(values, expected, atol=2.0, err_msg=mode)


def test_axis_angle_faces_are_told_why_head_motion_cannot_import():
    head = set_up_sample()
    head.rotation_mode = "AXIS_ANGLE"
    with pytest.raises(RuntimeError, match="Axis Angle"):
        bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP))


# ----------------------------------------------------------------------------- what users expect


def test_operators_say_why_they_cannot_run():
    with pytest.raises(RuntimeError, match="Select the face mesh"):
        bpy.ops.mpeg4.setup_face()
    head = unset_sample()
    assert bpy.ops.mpeg4.setup_face.poll()
    for op in (bpy.ops.mpeg4.remove_face, bpy.ops.mpeg4.import_fap, bpy.ops.mpeg4.export_fap, bpy.ops.mpeg4.bake):
        with pytest.raises(RuntimeError, match="not set up"):
            op()
    bpy.ops.mpeg4.setup_face()
    head.mpeg4_face.enabled = False
    with pytest.raises(RuntimeError, match="Turn Deform on"):
        bpy.ops.mpeg4.bake()


def test_menus_and_the_drop_handler_are_registered():
    import addon.blender.menus as menus

    def entries(menu):
        return [f.__name__ for f in menu._dyn_ui_initialize()]

    assert menus.menu_import.__name__ in entries(bpy.types.TOPBAR_MT_file_import)
    assert menus.menu_export.__name__ in entries(bpy.types.TOPBAR_MT_file_export)
    assert menus.menu_object.__name__ in entries(bpy.types.VIEW3D_MT_object)
    assert hasattr(bpy.types, "MPEG4_MT_object") and hasattr(bpy.types, "MPEG4_FH_fap")
    assert MPEG4_FH_fap.bl_import_operator == "mpeg4.import_fap" and MPEG4_FH_fap.bl_file_extensions == ".fap"
    assert bpy.ops.mpeg4.import_fap.get_rna_type().properties["files"].type == "COLLECTION"


def test_one_action_per_stream_named_after_the_file_and_reimport_replaces_head_motion(tmp_path):
    head = set_up_sample()
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    streams = [a for a in bpy.data.actions if "mpeg4_stream" in a]
    assert [a.name for a in streams] == ["demo"]
    empties = face_data.fp_empties(head)
    assert all(ob.animation_data.action == streams[0] for ob in empties.values())
    assert head.animation_data.action == streams[0]
    # a stream without head motion replaces the old one; the head goes back to its own delta
    still = write_fap(tmp_path / "still.fap", [0, 1], values=[(0, 0), (100, 0)])
    text = still.read_text().replace(" 1 ", " 1 ", 1)
    lines = text.splitlines()
    mask = ["0"] * N_FAPS
    mask[2] = "1"
    lines[1] = lines[3] = " ".join(mask)
    lines[2], lines[4] = "0 0", "1 100"
    still.write_text("\n".join(lines) + "\n")
    assert bpy.ops.mpeg4.import_fap(filepath=str(still)) == {"FINISHED"}
    assert sorted(a.name for a in bpy.data.actions if "mpeg4_stream" in a) == ["still"]
    assert head.animation_data is None or head.animation_data.action is None
    assert tuple(head.delta_rotation_euler) == (0.0, 0.0, 0.0)


def test_add_mode_adds_the_stream_to_the_existing_motion(tmp_path):
    head = set_up_sample()
    chin = face_data.fp_empties(head)["2.1"]
    scene = bpy.context.scene
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=0) == {"FINISHED"}
    scene.frame_set(30)
    once = np.array(chin.location) - np.array(chin[face_data.EMPTY_REST_PROP])
    assert np.abs(once).max() > 1e-3
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=0, mode="ADD") == {"FINISHED"}
    scene.frame_set(30)
    twice = np.array(chin.location) - np.array(chin[face_data.EMPTY_REST_PROP])
    np.testing.assert_allclose(twice, 2 * once, atol=1e-6)
    assert [a.name for a in bpy.data.actions if "mpeg4_stream" in a] == ["demo.001"]


def test_remove_leaves_the_file_as_it_was_before_set_up(tmp_path):
    head = unset_sample()
    head.rotation_mode = "QUATERNION"
    before = snapshot()
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP)) == {"FINISHED"}
    scene = bpy.context.scene
    scene.frame_end = scene.frame_start + 3
    assert bpy.ops.mpeg4.bake(target="POINT_CACHE", filepath=str(tmp_path / "c.pc2")) == {"FINISHED"}
    head.mpeg4_face.enabled = True
    assert bpy.ops.mpeg4.bake(target="SHAPE_KEYS") == {"FINISHED"}
    scene.frame_end = before["scene"][1]
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    after = snapshot()
    for part in before:
        if part == "objects":
            for name in before[part]:
                assert after[part].get(name) == before[part][name], name
        assert after[part] == before[part], part
    assert not live._states


def test_a_property_callback_error_is_reported_not_raised():
    head = set_up_sample()
    head.data.uv_layers.remove(head.data.uv_layers[0]) if head.data.uv_layers else None
    image = bpy.data.images.new("masks", 4, 4)
    head.mpeg4_face.mask_image = image  # needs UVs: a clear status, no traceback
    assert "no UV map" in head.mpeg4_face.status


def test_x_mirror_places_the_partner_and_empties_are_drawn_to_scale():
    head = unset_sample()
    for ob in list(face_data.fp_empties(head).values()):
        bpy.data.objects.remove(ob)
    head.mpeg4_face.use_x_mirror = True
    world = head.matrix_world @ face_data.Vector((0.03, -0.09, 0.05)) if hasattr(face_data, "Vector") else None
    from mathutils import Vector

    world = head.matrix_world @ Vector((0.03, -0.09, 0.05))
    assert bpy.ops.mpeg4.place_feature_points(fp_id="3.5", location=world) == {"FINISHED"}
    empties = face_data.fp_empties(head)
    left, right = empties["3.5"], empties["3.6"]
    assert tuple(right.location) == (-left.location.x, left.location.y, left.location.z)
    assert left.empty_display_size == pytest.approx(fp_empties.display_size(head))
    assert 0.002 < left.empty_display_size * max(head.scale) < 0.01  # a few millimetres on a human head


def test_x_mirror_moves_the_partner_of_the_empty_being_moved():
    head = set_up_sample()
    head.mpeg4_face.use_x_mirror = True
    empties = face_data.fp_empties(head)
    left, right = empties["8.3"], empties["8.4"]
    select(left)
    left.location.z += 0.004
    bpy.context.view_layer.update()
    assert tuple(right.location) == (-left.location.x, left.location.y, left.location.z)
    head.mpeg4_face.use_x_mirror = False
    before = tuple(right.location)
    left.location.z += 0.004
    bpy.context.view_layer.update()
    assert tuple(right.location) == before


def test_a_slider_change_rebinds_in_the_background_while_the_old_binding_plays(monkeypatch):
    head = set_up_sample()
    monkeypatch.setattr(binding_store, "BACKGROUND_REBIND", True)
    monkeypatch.setattr(binding_store, "REBIND_DELAY", 0.0)
    old_key = binding_store.stored_key(head)
    start = time.perf_counter()
    head.mpeg4_face.radius_fraction = 1.5
    head.mpeg4_face.radius_fraction = 1.6  # a drag: only the last value is bound
    blocked = time.perf_counter() - start
    assert binding_store.busy(head) and binding_store.stored_key(head) == old_key  # the old one still plays
    assert blocked < 0.1
    deadline = time.monotonic() + 30
    while binding_store.busy(head) and time.monotonic() < deadline:
        binding_store.poll_jobs()
        time.sleep(0.01)
    assert not binding_store.busy(head) and binding_store.stored_key(head) != old_key
    expected = binding_store.stored_inputs(head)
    assert binding_store.stored_key(head) == expected.key and expected.params["radius_fraction"] == pytest.approx(1.6)


def test_what_a_rebind_does_not_change_is_not_made_again_on_the_main_thread(monkeypatch):
    """After a slider's rebind the main thread only stores and shows it: the lip guard (0.3 s at 68k vertices)
    depends on the rest shape and masks, not the binding's settings, and the kernel's layout was made on the
    worker thread."""
    from addon.deform import fused

    head = set_up_sample()
    monkeypatch.setattr(binding_store, "BACKGROUND_REBIND", True)
    monkeypatch.setattr(binding_store, "REBIND_DELAY", 0.0)
    guard, old_key = live._states[head.session_uid].lip_guard, binding_store.stored_key(head)
    assert guard is not None
    lids = eyelid_rig.current(head)
    assert lids is not None
    head.mpeg4_face.radius_fraction = 1.5
    deadline = time.monotonic() + 30
    while binding_store.busy(head) and time.monotonic() < deadline:
        job = binding_store._jobs[head.session_uid]
        if job.thread is not None and not job.thread.is_alive() and fused.available():
            assert ("fused", "planar_bones", "float32") in job.result._evaluation  # made by the worker
        binding_store.poll_jobs()
        time.sleep(0.01)
    state = live._states[head.session_uid]
    assert state.key == binding_store.stored_key(head) != old_key
    assert state.lip_guard is guard
    assert eyelid_rig.current(head) is lids  # the lids' fold-free weights were not made again
    head.mpeg4_face.keep_lips_apart = False
    head.mpeg4_face.keep_lips_apart = True
    assert live._states[head.session_uid].lip_guard is guard  # switched off and on: the same inputs
    live.forget()  # as an undo does: the same inputs, the same weights
    assert live.apply_face(head, force=True)
    assert eyelid_rig.current(head) is lids
    live.on_load_post()  # another file: nothing kept
    assert not eyelid_rig._made and not eyelid_rig._rigs


def test_the_binding_reloads_bit_identical_and_is_not_on_the_mesh(tmp_path):
    import dataclasses

    head = set_up_sample()
    bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP))
    before = binding_store.load(head)
    assert binding_store.BINDING_PROP not in head.data  # the mesh is copied every frame: keep it small
    scene = bpy.context.scene
    scene.frame_set(40)
    posed = positions(head.data).copy()
    path = tmp_path / "saved.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    head = bpy.data.objects["Head"]
    after = binding_store.load(head)
    assert after is not before
    for field in dataclasses.fields(before):
        if field.init:
            a, b = getattr(before, field.name), getattr(after, field.name)
            assert np.array_equal(a, b) and getattr(a, "dtype", None) == getattr(b, "dtype", None), field.name
    bpy.context.scene.frame_set(41)
    bpy.context.scene.frame_set(40)
    np.testing.assert_array_equal(positions(head.data), posed)


def test_set_up_while_posed_snaps_onto_the_rest_surface():
    from mathutils.bvhtree import BVHTree

    head = set_up_sample()
    chin = face_data.fp_empties(head)["2.1"]
    chin.location.y -= 0.006  # off the surface, and the face follows it: the mesh shows a pose
    bpy.context.view_layer.update()
    rest = rest_shape.stored_rest(head.data).copy()
    assert np.abs(positions(head.data) - rest).max() > 0.002
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    tree = BVHTree.FromPolygons(rest.tolist(), [list(p.vertices) for p in head.data.polygons])
    _nearest, _normal, _index, distance = tree.find_nearest(chin.location)
    assert distance < 1e-6
    np.testing.assert_array_equal(rest_shape.stored_rest(head.data), rest)  # the rest shape, not the pose


def test_a_failure_preparing_the_new_binding_still_takes_it_in(monkeypatch):
    """Building the kernel's layout on the worker thread is only a head start: if it fails, the new binding is
    stored and shown all the same (the first frame builds the layout)."""
    head = set_up_sample()
    monkeypatch.setattr(binding_store, "BACKGROUND_REBIND", True)
    monkeypatch.setattr(binding_store, "REBIND_DELAY", 0.0)
    old_key = binding_store.stored_key(head)

    def broken(*_args, **_kwargs):
        raise RuntimeError("no layout today")

    monkeypatch.setattr(live, "prepare_playback", broken)
    head.mpeg4_face.radius_fraction = 1.5
    deadline = time.monotonic() + 30
    while binding_store.busy(head) and time.monotonic() < deadline:
        binding_store.poll_jobs()
        time.sleep(0.01)
    assert binding_store.stored_key(head) != old_key
    assert head.mpeg4_face.enabled and not head.mpeg4_face.status
