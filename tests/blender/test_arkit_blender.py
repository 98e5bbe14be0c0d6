"""The ARKit bridge in Blender: the 52 shape keys made on the sample head, captures imported both ways."""

import json

import bpy
import numpy as np
import pytest

from addon.arkit.captures import live_link_header
from addon.arkit.deformations import hinge_axis
from addon.arkit.mapping import weights_to_faps
from addon.arkit.recipes import ARKIT_NAMES
from addon.blender import arkit_keys, elastic_rig, face_data, fap_io, rest_shape
from addon.errors import Mpeg4Error
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.fap_groups import shape_faps
from addon.mpeg4.feature_points import FP_IDS
from tests.blender.helpers import ROOT, evaluated_positions, open_sample, select, set_up_sample


def _key(ob, name) -> np.ndarray:
    block = ob.data.shape_keys.key_blocks[name]
    co = np.empty(3 * len(block.data), dtype=np.float32)
    block.data.foreach_get("co", co)
    return co.reshape(-1, 3).astype(np.float64)


def _offset(ob, name) -> np.ndarray:
    return _key(ob, name) - _key(ob, ob.data.shape_keys.reference_key.name)


def _made_keys(head):
    assert bpy.ops.mpeg4.make_arkit_shape_keys() == {"FINISHED"}
    return {name: _offset(head, name) for name in ARKIT_NAMES}


def test_the_52_keys_move_the_right_part_of_the_face_the_right_way():
    head = set_up_sample()
    rest = np.array([v.co for v in head.data.vertices])
    offsets = _made_keys(head)
    names = [block.name for block in head.data.shape_keys.key_blocks]
    assert names[0] == "Basis" and set(ARKIT_NAMES) <= set(names)
    assert all(head.data.shape_keys.key_blocks[name].value == 0.0 for name in ARKIT_NAMES)
    np.testing.assert_allclose(evaluated_positions(head), rest, atol=1e-6)  # the face looks as it did
    moved = {name: np.linalg.norm(offset, axis=1) for name, offset in offsets.items()}
    assert all(m.max() > 1e-4 for name, m in moved.items() if not name.startswith("eyeLook")), "each key moves"
    # Left is the face's own left, Blender +X on the sample head
    for name in ("eyeBlinkLeft", "mouthSmileLeft", "browOuterUpLeft", "cheekSquintLeft", "noseSneerLeft"):
        weights = moved[name]
        assert np.average(rest[:, 0], weights=weights) > 0.005, name
        assert np.average(rest[:, 0], weights=moved[name.replace("Left", "Right")]) < -0.005, name
    blink = offsets["eyeBlinkLeft"]
    assert blink[moved["eyeBlinkLeft"].argmax(), 2] < -0.005  # the upper lid comes down (Blender Z up)
    # the smile's corner goes up about as far as out (ARKit's "upward movement"; 2.9 mm up, 7.4 out before)
    fps = {fp_id: np.array(ob.location) for fp_id, ob in face_data.fp_empties(head).items()}
    corner = offsets["mouthSmileLeft"][np.linalg.norm(rest - fps["2.4"], axis=1).argmin()]
    assert corner[2] > 0.004 and corner[2] > 0.7 * corner[0] > 0.0  # up (Blender +Z), out (the face's left, +X)
    jaw = offsets["jawOpen"]
    chin = moved["jawOpen"].argmax()
    assert jaw[chin, 2] < -0.01 and rest[chin, 2] < np.median(rest[:, 2])  # the chin drops
    # ... turning about the jaw joints: drawn back (+Y) as it drops, the chin bottom 2.1 by what open_jaw says
    near = {fp_id: np.linalg.norm(rest - point, axis=1).argmin() for fp_id, point in fps.items()}
    assert jaw[near["2.1"], 1] > 0.015 and jaw[near["2.1"], 2] < -0.012
    # ... and so does the skin between the chin and the jaw's turning centre, not only the FPs: every vertex the
    # jaw carries keeps its distance from the axis it turns about (it swings about it, not straight down), and
    # that axis lies below the condyles: 13 mm in front of the ear points 10.3/10.4 and 32.4 mm below
    # (hinge_axis, scaled by ES0 61.5 mm against an adult's 63), no longer through them
    axes = face_data.face_axes(head)
    neutral = np.array([fps[fp_id] for fp_id in FP_IDS])
    hinge, axis = (vector @ axes for vector in hinge_axis(neutral @ axes.T))
    ears = 0.5 * (fps["10.3"] + fps["10.4"])
    np.testing.assert_allclose((ears - hinge) @ axes[1], 0.0324 * 61.5 / 63.0, atol=0.002)  # face up: Blender +Z
    np.testing.assert_allclose((hinge - ears) @ axes[2], 0.013 * 61.5 / 63.0, atol=0.002)  # forward: -Y
    carried = np.linalg.norm(jaw, axis=1) > 0.01
    before, after = rest[carried] - hinge, rest[carried] + jaw[carried] - hinge
    change = np.abs(np.linalg.norm(np.cross(after, axis), axis=1) - np.linalg.norm(np.cross(before, axis), axis=1))
    assert carried.sum() > 100 and change.max() < 0.001  # 0.6 mm of the 22 they move (the engine's slack); 4 mm
    # when only the FPs turned and the skin between them was interpolated
    # mouthClose is made over jawOpen (ARKit's lips closing "independent of jaw position"): the lower lip the jaw
    # took down comes back up over the open jaw, the upper lip and the chin stay (before: made on the face at
    # rest, where the lips meet at once, so over jawOpen the lips stayed as far apart; the upper lip came down).
    # All the way: jawOpen + mouthClose leaves the lower lip within 2 mm of where it was at rest (it was 29 mm:
    # 19 below and 22 behind, when the lips' soft limit eased the lip's rise to 500 MNS and the raised lip still
    # turned all the way with the mandible)
    close = offsets["mouthClose"]
    assert close[near["2.3"], 2] > 0.006 and close[near["8.2"], 2] > 0.006
    for fp_id in ("2.3", "8.2"):
        closed = jaw[near[fp_id]] + close[near[fp_id]]
        assert np.linalg.norm(closed) < 0.002, (fp_id, closed)
    for fp_id in ("2.4", "2.5"):  # and the corners, which the jaw carried half way (15 mm off when they stayed)
        closed = jaw[near[fp_id]] + close[near[fp_id]]
        assert np.linalg.norm(closed) < 0.002, (fp_id, closed)
    assert abs(close[near["2.2"], 2]) < 0.001 and abs(close[near["8.1"], 2]) < 0.001  # 0.7 mm: the lower lip meets it
    assert np.linalg.norm(close[near["2.1"]]) < 0.0005
    # mouthLeft: "movement of both lips to the left" (+X): the lips' middle goes with the corners (0 before)
    for fp_id in ("2.2", "2.3", "8.1", "8.2"):
        assert offsets["mouthLeft"][near[fp_id], 0] > 0.004 and offsets["mouthRight"][near[fp_id], 0] < -0.004, fp_id
    # ... and the nose's bottom edge a share of the way (`nose_base_shift`; MakeHuman's modifier that moves the
    # mouth sideways takes it half as far; it stayed)
    for fp_id in ("9.15", "9.5", "9.4"):
        assert offsets["mouthLeft"][near[fp_id], 0] > 0.001 and offsets["mouthRight"][near[fp_id], 0] < -0.001, fp_id
    # the sneer lifts its own side's nostril with the upper lip beside it (no FAP raises 9.1 / 9.2)
    sneer = offsets["noseSneerLeft"]
    assert sneer[near["9.1"], 2] > 0.001 and abs(sneer[near["9.2"], 2]) < 0.0002
    assert abs(sneer[near["9.1"], 0]) < 0.001  # raised, not widened (4.8 mm out with stretch_l_nose, AU 38's)
    # the lifted upper lip raises the nose's bottom edge beside it (9.5: the lip's upper edge; no FAP moves it,
    # and it stayed before), not the nostril's border 9.1 (AU 9's) nor the other side's 9.4
    upper = offsets["mouthUpperUpLeft"]
    assert upper[near["9.5"], 2] > 0.003 and abs(upper[near["9.4"], 2]) < 0.0005, (
        upper[near["9.5"]],
        upper[near["9.4"]],
    )
    assert upper[near["9.1"], 2] < 0.5 * upper[near["9.5"], 2], upper[near["9.1"]]
    # the infraorbital triangle rises with the raised lip (FACS AU 10 and AU 12; `infraorbital_lift`): the skin at
    # the cheek bone 5.3 rises with the smile's corner and the lifted upper lip, on their side only (0 before)
    for name in ("mouthSmileLeft", "mouthUpperUpLeft"):
        assert offsets[name][near["5.3"], 2] > 0.001 and abs(offsets[name][near["5.4"], 2]) < 0.0002, name
    assert abs(offsets["mouthFrownLeft"][near["5.3"], 2]) < 0.0002  # a lowered corner leaves it
    # the Cupid's bow's peaks (no FAP moves them) go with the upper lip's outer contour either side of them: the
    # rolled upper lip takes them down with it (they stayed up, standing out of the rolled lip; the roll's push
    # took them back already)
    roll = offsets["mouthRollUpper"]
    for peak, side in (("8.10", "8.5"), ("8.9", "8.6")):
        beside = 0.5 * (roll[near["8.1"], 2] + roll[near[side], 2])
        assert roll[near[peak], 2] < 0.5 * beside < -0.001, (peak, roll[near[peak]], beside)
    # the puffed cheeks go out along the cheek's surface normal, forward (-Y) as well as out (the FAP alone: 7.2 mm
    # straight out, none forward), each as far as puff_cheek moves it
    puff = offsets["cheekPuff"]
    for fp_id, side in (("5.1", 1.0), ("5.2", -1.0)):
        cheek = puff[near[fp_id]]
        assert cheek[1] < -0.003 and side * cheek[0] > 0.004, (fp_id, cheek)
    # the pursed lips come forward (-Y) all round, not only at their mid-points 2.2 / 2.3
    pucker = offsets["mouthPucker"]
    for fp_id in ("8.1", "8.2", "2.4", "2.5", "8.5", "8.8", "8.9", "8.10"):  # 8.9 / 8.10 1 mm before
        assert pucker[near[fp_id], 1] < -0.003, fp_id
    # ... and the nose's bottom edge beside the nostril (9.5, 9.4: no FAP moves it, and it stayed before) comes
    # with the skin between the nostril's border and the lip, under half as far as the lip (2.4 mm of 5.4)
    for fp_id, lip in (("9.5", "8.5"), ("9.4", "8.6")):
        assert 0.25 * pucker[near[lip], 1] > pucker[near[fp_id], 1] > 0.6 * pucker[near[lip], 1], fp_id
    # ... their corners, coming in, come forward along the face's surface more than the lips' push (5 mm): 8 mm
    for fp_id in ("2.4", "2.5"):
        assert pucker[near[fp_id], 1] < -0.008, fp_id
    # the dimple's corner goes back (+Y) as it goes out, sliding on the cheek (ARKit: "backward movement of the
    # left corner"; the FAPs move it sideways only); the lower lip's shrug pushes its outer edge 8.2 out (-Y)
    dimple = offsets["mouthDimpleLeft"]
    assert dimple[near["2.4"], 1] > 0.002 and dimple[near["2.4"], 0] > 0.002, dimple[near["2.4"]]
    assert offsets["mouthShrugLower"][near["8.2"], 1] < -0.001
    assert offsets["mouthShrugLower"][near["2.10"], 2] > 0.002  # mentalis raises the chin with the lip
    assert offsets["browInnerUp"][moved["browInnerUp"].argmax(), 2] > 0.004
    # the frown (AU 4) lowers the whole brow, its outer end too (ARKit's "outer portion")
    frown = offsets["browDownLeft"]
    assert frown[near["4.1"], 2] < -0.003 and frown[near["4.5"], 2] < -0.002, (frown[near["4.1"]], frown[near["4.5"]])
    # eyeLook* turn the eyeballs, jawOpen moves the lower teeth and the tongue
    eye_l, eye_r = bpy.data.objects["Eye L"], bpy.data.objects["Eye R"]
    for eye, side in ((eye_l, "Left"), (eye_r, "Right")):
        keys = [b.name for b in eye.data.shape_keys.key_blocks]
        assert keys == ["Basis", *(f"eyeLook{d}{side}" for d in ("Down", "In", "Out", "Up"))]
    look_out = _offset(eye_l, "eyeLookOutLeft")
    assert np.linalg.norm(look_out, axis=1).max() > 0.002
    for part in ("Teeth Lower", "Tongue"):
        ob = bpy.data.objects[part]
        assert "jawOpen" in ob.data.shape_keys.key_blocks
        drop = _offset(ob, "jawOpen") @ np.array(ob.matrix_world.to_3x3()).T
        assert drop[:, 2].mean() < -0.005
    # ... turning with the jaw about its joints: the front teeth swing back and down, the back teeth move less
    teeth = bpy.data.objects["Teeth Lower"]
    world = np.array(teeth.matrix_world.to_3x3())
    swing = _offset(teeth, "jawOpen") @ world.T
    depth = _key(teeth, "Basis") @ world.T
    front, back = depth[:, 1].argmin(), depth[:, 1].argmax()
    assert swing[front, 1] > 0.005 and swing[front, 2] < -0.005
    assert np.linalg.norm(swing[back]) < 0.8 * np.linalg.norm(swing[front])
    tongue = bpy.data.objects["Tongue"]
    forward = _offset(tongue, "tongueOut") @ np.array(tongue.matrix_world.to_3x3()).T
    assert forward[:, 1].mean() < -0.005  # the tongue comes out (-Y is forward)


def test_running_again_replaces_keeps_the_users_keys_and_remove_takes_them_away():
    head = set_up_sample()
    rest = np.array([v.co for v in head.data.vertices])
    head.shape_key_add(name="Basis", from_mix=False)
    mine = head.shape_key_add(name="My Smile", from_mix=False)
    mine.data[0].co.z += 0.01
    first = _made_keys(head)
    again = _made_keys(head)
    names = [block.name for block in head.data.shape_keys.key_blocks]
    assert names.count("jawOpen") == 1 and "My Smile" in names
    for name in ARKIT_NAMES:
        np.testing.assert_allclose(again[name], first[name], atol=1e-6)
    assert _offset(head, "My Smile")[0, 2] == pytest.approx(0.01, abs=1e-6)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert [block.name for block in head.data.shape_keys.key_blocks] == ["Basis", "My Smile"]
    assert bpy.data.objects["Eye L"].data.shape_keys is None
    np.testing.assert_allclose(np.array([v.co for v in head.data.vertices]), rest)


def test_remove_takes_away_a_basis_made_for_the_keys_and_a_users_arkit_name_is_refused():
    head = set_up_sample()
    _made_keys(head)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert head.data.shape_keys is None
    head = set_up_sample()
    head.shape_key_add(name="Basis", from_mix=False)
    head.shape_key_add(name="jawOpen", from_mix=False)
    with pytest.raises(RuntimeError, match="already has shape keys named jawOpen"):
        bpy.ops.mpeg4.make_arkit_shape_keys()
    names = [block.name for block in head.data.shape_keys.key_blocks if block.name != rest_shape.SHAPE_KEY_NAME]
    assert names == ["Basis", "jawOpen"]


def test_elastic_bones_make_the_keys_with_its_own_engine():
    head = set_up_sample()
    assert bpy.ops.mpeg4.set_engine(engine=elastic_rig.ELASTIC) == {"FINISHED"}
    offsets = _made_keys(head)
    moved = np.linalg.norm(offsets["jawOpen"], axis=1)
    assert offsets["jawOpen"][moved.argmax(), 2] < -0.01
    assert np.linalg.norm(offsets["eyeBlinkLeft"], axis=1).max() > 0.002


def _live_link_take(path, frames: int = 12):
    header = live_link_header()
    rows = [",".join(header)]
    for k in range(frames):
        values = dict.fromkeys(header[2:], 0.0) | {"JawOpen": k / (frames - 1), "HeadYaw": 0.05}
        rows.append(",".join([f"00:00:00:{k:02d}.000", "61", *(f"{values[h]:g}" for h in header[2:])]))
    path.write_text("\n".join(rows) + "\n")


def test_a_capture_keys_the_arkit_shape_keys(tmp_path):
    head = set_up_sample()
    _made_keys(head)
    path = tmp_path / "take.csv"
    _live_link_take(path)
    bpy.context.scene.render.fps = 30
    assert bpy.ops.mpeg4.import_arkit(filepath=str(path), target="SHAPE_KEYS", start_frame=1) == {"FINISHED"}
    curve = head.data.shape_keys.animation_data.action
    assert curve is not None
    bpy.context.scene.frame_set(12)
    assert head.data.shape_keys.key_blocks["jawOpen"].value == pytest.approx(1.0)
    assert bpy.data.objects["Teeth Lower"].data.shape_keys.key_blocks["jawOpen"].value == pytest.approx(1.0)
    bpy.context.scene.frame_set(1)
    assert head.data.shape_keys.key_blocks["jawOpen"].value == pytest.approx(0.0)
    _made_keys(head)  # made again: the capture's keys find them by name
    bpy.context.scene.frame_set(12)
    assert head.data.shape_keys.key_blocks["jawOpen"].value == pytest.approx(1.0)
    assert bpy.ops.mpeg4.remove_face() == {"FINISHED"}
    assert head.data.shape_keys is None


def test_a_capture_becomes_a_fap_stream_that_exports_as_fap(tmp_path):
    head = set_up_sample()
    path = tmp_path / "take.json"
    weights = np.zeros((6, 52))
    weights[:, ARKIT_NAMES.index("jawOpen")] = np.linspace(0, 1, 6)
    doc = {
        "exportFps": 30,
        "numPoses": 52,
        "numFrames": 6,
        "facsNames": list(ARKIT_NAMES),
        "weightMat": weights.tolist(),
    }
    path.write_text(json.dumps(doc))
    bpy.context.scene.render.fps = 30
    assert bpy.ops.mpeg4.import_arkit(filepath=str(path), target="FAPS", start_frame=1) == {"FINISHED"}
    jaw = next(ob for ob in bpy.data.objects if ob.get("mpeg4_fp") == "2.1")
    bpy.context.scene.frame_set(1)
    z0 = jaw.location.z
    bpy.context.scene.frame_set(6)
    assert z0 - jaw.location.z > 0.015  # jawOpen 1220 MNS of an 18 mm MNS0, eased to 1081
    out = tmp_path / "take.fap"
    fap_io.export_fap(bpy.context, head, str(out), 1, 6)
    stream = read_fap(out)
    played = shape_faps(weights_to_faps(weights))  # as the face plays it: within its plausible ranges
    assert stream.values[-1, 2] == pytest.approx(played[-1, 2], abs=2)


def test_a_bad_capture_changes_nothing(tmp_path):
    head = set_up_sample()
    path = tmp_path / "bad.csv"
    path.write_text("jawOpen,eyeBlinkLeft\n0,0\n0.5,nan\n")
    actions = len(bpy.data.actions)
    with pytest.raises(RuntimeError, match="bad.csv: line 3: 'nan' is not a finite number"):
        bpy.ops.mpeg4.import_arkit(filepath=str(path), target="FAPS")
    with pytest.raises(RuntimeError, match="no ARKit shape keys"):
        path.write_text("jawOpen\n0\n")
        bpy.ops.mpeg4.import_arkit(filepath=str(path), target="SHAPE_KEYS")
    assert len(bpy.data.actions) == actions and head.data.shape_keys is None
    assert not arkit_keys.has_keys(head)


def test_the_second_sample_face_and_an_incomplete_fp_set():
    head = open_sample(ROOT / "sample_blends" / "makehuman_head_b.blend")
    select(head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    offsets = _made_keys(head)
    assert np.linalg.norm(offsets["jawOpen"], axis=1).max() > 0.01
    head = open_sample()
    select(head)
    empties = {ob["mpeg4_fp"]: ob for ob in bpy.data.collections["Head FPs"].objects if "mpeg4_fp" in ob}
    for fp_id in ("4.5", "4.6", "5.3", "5.4", "2.13", "2.14"):  # the outer brows and the cheeks' lift points
        bpy.data.objects.remove(empties[fp_id])
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    offsets = _made_keys(head)
    assert np.linalg.norm(offsets["eyeBlinkLeft"], axis=1).max() > 0.005
    assert np.all(np.isfinite(offsets["browOuterUpLeft"]))


def test_a_run_that_fails_half_way_leaves_the_earlier_keys(monkeypatch):
    head = set_up_sample()
    first = _made_keys(head)
    deformed = arkit_keys._deformed
    calls = []

    def failing(face):
        calls.append(1)
        if len(calls) == 10:
            raise Mpeg4Error("the face could not be deformed")
        return deformed(face)

    monkeypatch.setattr(arkit_keys, "_deformed", failing)
    with pytest.raises(Mpeg4Error, match="could not be deformed"):
        arkit_keys.make_keys(bpy.context, head)
    names = [block.name for block in head.data.shape_keys.key_blocks]
    assert not any(name.startswith(arkit_keys.NEW_PREFIX) for name in names)
    assert set(ARKIT_NAMES) <= set(names) and len(names) == len(set(names))
    for name in ARKIT_NAMES:
        np.testing.assert_array_equal(_offset(head, name), first[name])
    eye = bpy.data.objects["Eye L"]
    assert [b.name for b in eye.data.shape_keys.key_blocks][1:] == [
        f"eyeLook{d}Left" for d in ("Down", "In", "Out", "Up")
    ]
