"""FAP values -> FP positions: translations, rotations and the masked-out policy, by hand."""

import numpy as np
import pytest

from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.decode import (
    CLOSING_PAIRS,
    CORNER_PAIRS,
    JAW_RIDERS,
    LIP_COLUMNS,
    fap_to_fp,
    hold_missing,
    meet_at_closure,
)
from addon.mpeg4.faps import LEFT_RIGHT_PAIRS
from addon.mpeg4.fapu import AU, Fapu
from addon.mpeg4.feature_points import FP_IDS, feature_point, fp_index, mirror_index

FAPU = Fapu(IRISD0=0.012, ES0=0.064, ENS0=0.045, MNS0=0.030, MW0=0.052)
RNG = np.random.default_rng(7)
NEUTRAL = RNG.uniform(-0.1, 0.1, size=(84, 3))  # Blender coordinates; only relative motion matters here
NEUTRAL[[fp_index("6.3"), fp_index("6.4")]] = NEUTRAL[fp_index("6.2")] + [[0.02, 0, 0], [-0.02, 0, 0]]


def frames(*assignments):
    """One (68,) value row per dict {fap number: value}."""
    values = np.zeros((len(assignments), 68))
    for row, assignment in enumerate(assignments):
        for number, value in assignment.items():
            values[row, number - 1] = value
    return values


def moved(result, frame=0):
    return {FP_IDS[i] for i in np.flatnonzero(np.linalg.norm(result[frame] - NEUTRAL, axis=1) > 1e-15)}


def test_zero_faps_give_the_neutral_face():
    np.testing.assert_allclose(fap_to_fp(NEUTRAL, frames({}), FAPU)[0], NEUTRAL, rtol=0, atol=1e-15)


def test_open_jaw_512_moves_chin_down_by_half_mns0():
    out = fap_to_fp(NEUTRAL, frames({3: 512}), FAPU)
    k = fp_index("2.1")
    # Blender: down is -Z
    np.testing.assert_allclose(out[0, k] - NEUTRAL[k], [0.0, 0.0, -FAPU.MNS0 / 2], atol=1e-15)
    assert moved(out) == {"2.1", *JAW_RIDERS}
    for fp_id in ("8.3", "5.1", "5.2"):  # the lip corners and the cheeks' centres at their height: half the jaw
        k = fp_index(fp_id)
        np.testing.assert_allclose(out[0, k] - NEUTRAL[k], [0.0, 0.0, -FAPU.MNS0 / 4], atol=1e-15, err_msg=fp_id)


def test_translational_faps_follow_axis_and_fapu():
    out = fap_to_fp(NEUTRAL, frames({6: 100, 7: 100, 31: -200, 19: 1024}), FAPU)
    d = out[0] - NEUTRAL
    np.testing.assert_allclose(d[fp_index("2.4")], [100 * FAPU.MW0 / 1024, 0, 0], atol=1e-15)  # left = +X
    np.testing.assert_allclose(d[fp_index("2.5")], [-100 * FAPU.MW0 / 1024, 0, 0], atol=1e-15)
    np.testing.assert_allclose(d[fp_index("4.1")], [0, 0, -200 * FAPU.ENS0 / 1024], atol=1e-15)
    np.testing.assert_allclose(d[fp_index("3.1")], [0, 0, -FAPU.IRISD0], atol=1e-15)  # lid closes one iris
    thrust = fap_to_fp(NEUTRAL, frames({14: 300}), FAPU)[0] - NEUTRAL
    np.testing.assert_allclose(thrust[fp_index("2.1")], [0, -300 * FAPU.MNS0 / 1024, 0], atol=1e-15)  # -Y


def test_head_yaw_quarter_turn_about_spine_top():
    value = (np.pi / 2) / AU  # ~157,080
    out = fap_to_fp(NEUTRAL, frames({49: value}), FAPU)[0]
    pivot = NEUTRAL[fp_index("7.1")]
    rel, new_rel = NEUTRAL - pivot, out - pivot
    # yaw is about the face's up axis (Blender +Z); positive turns the nose (-Y) toward the face's left (+X)
    expected = np.stack([-rel[:, 1], rel[:, 0], rel[:, 2]], axis=1)
    np.testing.assert_allclose(new_rel, expected, atol=1e-12)
    nose = np.array([0.0, -1.0, 0.0])
    np.testing.assert_allclose(np.array([-nose[1], nose[0], nose[2]]), [1.0, 0.0, 0.0])


def test_head_pitch_and_roll_signs():
    pivot = NEUTRAL[fp_index("7.1")]
    quarter = (np.pi / 2) / AU
    pitch = fap_to_fp(NEUTRAL, frames({48: quarter}), FAPU)[0] - pivot
    roll = fap_to_fp(NEUTRAL, frames({50: quarter}), FAPU)[0] - pivot
    rel = NEUTRAL - pivot
    # pitch down: forward (-Y) goes to down (-Z), up (+Z) goes to forward (-Y)
    np.testing.assert_allclose(pitch, np.stack([rel[:, 0], -rel[:, 2], rel[:, 1]], axis=1), atol=1e-12)
    # roll toward the face's right: up (+Z) goes to the face's right (-X)
    np.testing.assert_allclose(roll, np.stack([-rel[:, 2], rel[:, 1], rel[:, 0]], axis=1), atol=1e-12)


def test_eyeball_yaw_turns_only_the_pupil_about_the_eye_centre():
    pivots = np.array([NEUTRAL[fp_index("3.5")] + [0, 0.012, 0], NEUTRAL[fp_index("3.6")] + [0, 0.012, 0]])
    out = fap_to_fp(NEUTRAL, frames({23: (np.pi / 2) / AU, 26: (np.pi / 2) / AU}), FAPU, eye_pivots=pivots)
    assert moved(out) == {"3.5", "3.6"}
    # left pupil 12 mm in front of its centre (-Y) turns to the face's left (+X)
    np.testing.assert_allclose(out[0, fp_index("3.5")] - pivots[0], [0.012, 0, 0], atol=1e-12)
    # right pupil pitched down: forward goes to down (-Z)
    np.testing.assert_allclose(out[0, fp_index("3.6")] - pivots[1], [0, 0, -0.012], atol=1e-12)


def test_tongue_roll_lifts_both_borders():
    out = fap_to_fp(NEUTRAL, frames({47: 0.3 / AU}), FAPU)[0]
    body = NEUTRAL[fp_index("6.2")]
    for fp_id in ("6.3", "6.4"):
        k = fp_index(fp_id)
        before, after = NEUTRAL[k] - body, out[k] - body
        assert np.linalg.norm(after) == pytest.approx(np.linalg.norm(before))
        assert after[1] == pytest.approx(before[1])  # about the forward axis: depth unchanged
        # the border lifts by 0.02 sin(0.3) and comes in by 0.02 (1 - cos(0.3))
        assert after[2] - before[2] == pytest.approx(0.02 * np.sin(0.3))
        assert abs(after[0]) == pytest.approx(0.02 * np.cos(0.3))


def test_vectorised_over_frames_matches_one_by_one():
    values = RNG.integers(-400, 400, size=(5, 68)).astype(float)
    values[:, :2] = 0
    together = fap_to_fp(NEUTRAL, values, FAPU)
    for f in range(5):
        np.testing.assert_allclose(together[f], fap_to_fp(NEUTRAL, values[f], FAPU)[0], atol=1e-15)


def test_custom_face_axes():
    mpeg_axes = np.eye(3)  # mesh already in the MPEG-4 frame (y up, z forward)
    out = fap_to_fp(NEUTRAL, frames({3: 1024}), FAPU, axes=mpeg_axes)
    np.testing.assert_allclose(out[0, 0] - NEUTRAL[0], [0, -FAPU.MNS0, 0], atol=1e-15)
    assert not np.allclose(BLENDER_FACE_AXES, mpeg_axes)


def test_hold_missing_holds_last_value_and_starts_neutral():
    mask = np.zeros((4, 68), bool)
    values = np.zeros((4, 68))
    mask[1, 2], values[1, 2] = True, 300  # open_jaw sent in frame 1 only
    mask[3, 2], values[3, 2] = True, 0  # an explicit zero is a value, not absence
    mask[0, 5], values[0, 5] = True, 50  # stretch_l_cornerlip in frame 0
    values[2, 2] = 999  # garbage under a zero mask is ignored
    dense = hold_missing(mask, values)
    np.testing.assert_array_equal(dense[:, 2], [0, 300, 300, 0])
    np.testing.assert_array_equal(dense[:, 5], [50, 50, 50, 50])
    np.testing.assert_array_equal(dense[:, 6], [0, 0, 0, 0])


def test_hold_missing_fills_partners_when_asked():
    mask = np.zeros((2, 68), bool)
    values = np.zeros((2, 68))
    mask[0, 5], values[0, 5] = True, 50  # 6 stretch_l_cornerlip -> 7 (right) and 53 (outer)
    mask[1, 6], values[1, 6] = True, 20  # 7 present in frame 1: its own value wins
    dense = hold_missing(mask, values, fill_partners=True)
    assert dense[0, 6] == 50 and dense[0, 52] == 50 and dense[0, 53] == 50
    assert dense[1, 6] == 20 and dense[1, 5] == 20  # partner fill comes before holding
    assert hold_missing(mask, values)[0, 6] == 0


def test_encode_inverts_decode_exactly():
    from addon.mpeg4.encode import NOT_RECOVERED, fp_to_fap

    values = RNG.integers(-600, 600, size=(6, 68)).astype(float)
    values[:, [n - 1 for n in NOT_RECOVERED]] = 0
    values[:, 46] = np.abs(values[:, 46]) * 100  # tongue roll, unidirectional, in AU
    values[:, 22:26] *= 100  # eyeball angles up to ~0.6 rad
    neutral = NEUTRAL.copy()
    for upper, lower in CLOSING_PAIRS:  # openings wide enough that no value closes them (which would stop it)
        neutral[fp_index(upper), 2] = neutral[fp_index(lower), 2] + 0.5
    for column in LIP_COLUMNS:  # lips high enough and far enough apart that no value reorders them
        for k, fp_id in enumerate(reversed(column)):
            neutral[fp_index(fp_id), 2] = neutral[fp_index(column[-1]), 2] + 0.5 * k
    for corner, beside, side in CORNER_PAIRS:  # corners far enough out that no squeeze stops them
        neutral[fp_index(corner), 0] = side * max(
            side * neutral[fp_index(corner), 0], side * neutral[fp_index(beside), 0] + 0.5
        )
    pivots = np.array([neutral[fp_index("3.5")] + [0.003, 0.012, 0.002], neutral[fp_index("3.6")] + [0, 0.011, 0]])
    pts = fap_to_fp(neutral, values, FAPU, eye_pivots=pivots)
    recovered = fp_to_fap(neutral, pts, FAPU, eye_pivots=pivots)
    np.testing.assert_allclose(recovered, values, atol=1e-6)


def test_encode_skips_missing_points():
    from addon.mpeg4.encode import fp_to_fap, recoverable_faps

    neutral = NEUTRAL.copy()
    neutral[fp_index("2.4")] = np.nan
    values = frames({3: 200, 6: 100, 31: 50})
    pts = fap_to_fp(neutral, values, FAPU)
    recovered = fp_to_fap(neutral, pts, FAPU)
    assert recovered[0, 5] == 0 and recovered[0, 2] == pytest.approx(200) and recovered[0, 30] == pytest.approx(50)
    assert 6 not in recoverable_faps(set(FP_IDS) - {"2.4"}) and 3 in recoverable_faps(set(FP_IDS))


def test_head_angles_invert_head_rotation():
    from addon.mpeg4.decode import head_angles, head_rotation

    angles = RNG.uniform(-1.2, 1.2, size=(20, 3))
    np.testing.assert_allclose(head_angles(head_rotation(angles)), angles, atol=1e-12)


def test_head_pivot_falls_back_to_centroid_without_7_1():
    neutral = NEUTRAL.copy()
    neutral[fp_index("7.1")] = np.nan
    out = fap_to_fp(neutral, frames({49: 0.0}), FAPU)[0]
    known = np.all(np.isfinite(neutral), axis=1)
    np.testing.assert_allclose(out[known], neutral[known], atol=1e-15)


def test_meet_at_closure_by_hand():
    # 3 + 3 closes 6 over a gap of 4: each keeps its share (2, 2); 1 + 2 stays open; the upper point moving
    # away by 1 keeps that and the lower stops on it (4 + 1); the lower moving away by 2 and the upper by 9
    down, up = meet_at_closure(np.array([3.0, 1.0, -1.0, 9.0]), np.array([3.0, 2.0, 7.0, -2.0]), 4.0)
    np.testing.assert_allclose(down, [2.0, 1.0, -1.0, 6.0])
    np.testing.assert_allclose(up, [2.0, 2.0, 5.0, -2.0])


def test_meet_at_closure_is_continuous_and_never_crosses():
    a, b = np.meshgrid(np.linspace(-5, 9, 281), np.linspace(-5, 9, 281))
    down, up = meet_at_closure(a, b, 4.0)
    assert np.all(down + up <= 4.0 + 1e-12)
    assert np.abs(np.diff(down, axis=0)).max() < 0.1 and np.abs(np.diff(down, axis=1)).max() < 0.1
    assert np.abs(np.diff(up, axis=0)).max() < 0.1 and np.abs(np.diff(up, axis=1)).max() < 0.1


def _eye_neutral():
    neutral = NEUTRAL.copy()
    neutral[fp_index("3.1")] = [0.03, -0.125, 0.036]  # upper lid 9 mm above the lower (Blender z up)
    neutral[fp_index("3.3")] = [0.03, -0.124, 0.027]
    neutral[fp_index("2.2")] = [0.0, -0.14, -0.04]  # closed mouth: inner lips 0.2 mm apart
    neutral[fp_index("2.3")] = [0.0, -0.14, -0.0402]
    return neutral


@pytest.mark.parametrize("upper, lower", [(1024, 1024), (2000, 0), (0, 3000), (-300, 2000), (5000, 5000)])
def test_eyelids_meet_and_never_cross(upper, lower):
    neutral = _eye_neutral()
    pts = fap_to_fp(neutral, frames({19: upper, 21: lower}), FAPU)[0]
    top, bottom = pts[fp_index("3.1"), 2], pts[fp_index("3.3"), 2]
    assert top >= bottom - 1e-12
    closing = (upper + lower) * FAPU.unit("IRISD")
    if closing >= 0.009:  # they would have crossed: they meet
        assert top == pytest.approx(bottom, abs=1e-12)
        if upper >= 0:  # each closing lid keeps its share of the closure
            share = upper / (upper + lower)
            assert neutral[fp_index("3.1"), 2] - top == pytest.approx(0.009 * share, abs=1e-12)
        else:  # the upper lid opening keeps its motion; the lower one stops on it
            assert neutral[fp_index("3.1"), 2] - top == pytest.approx(upper * FAPU.unit("IRISD"), abs=1e-12)


def test_lids_that_do_not_meet_move_freely():
    neutral = _eye_neutral()
    pts = fap_to_fp(neutral, frames({19: 300, 21: 200}), FAPU)[0]
    assert neutral[fp_index("3.1"), 2] - pts[fp_index("3.1"), 2] == pytest.approx(300 * FAPU.unit("IRISD"))
    assert pts[fp_index("3.3"), 2] - neutral[fp_index("3.3"), 2] == pytest.approx(200 * FAPU.unit("IRISD"))


def test_pressed_lips_stop_at_contact():
    neutral = _eye_neutral()
    pts = fap_to_fp(neutral, frames({4: 400, 5: 400}), FAPU)[0]
    assert pts[fp_index("2.2"), 2] == pytest.approx(pts[fp_index("2.3"), 2], abs=1e-12)
    # with the jaw open the same values leave the lips apart
    pts = fap_to_fp(neutral, frames({3: 1024, 4: 400, 5: 400}), FAPU)[0]
    assert pts[fp_index("2.2"), 2] - pts[fp_index("2.3"), 2] == pytest.approx(0.0002 + 0.030 - 800 * FAPU.unit("MNS"))


def _mouth_neutral():
    """A mouth by hand (Blender: x left, z up): lip heights at the mid line and the left column, mirrored."""
    neutral = NEUTRAL.copy()
    for fp_id, x, z in (
        ("8.1", 0.0, -0.034), ("2.2", 0.0, -0.040), ("2.3", 0.0, -0.0402), ("8.2", 0.0, -0.046),
        ("8.5", 0.014, -0.035), ("2.6", 0.013, -0.0398), ("2.8", 0.011, -0.0404), ("8.7", 0.012, -0.045),
        ("8.3", 0.026, -0.0405), ("2.4", 0.025, -0.0401),
    ):  # fmt: skip
        neutral[fp_index(fp_id)] = [x, -0.14, z]
        mirror = feature_point(fp_id).mirror
        if mirror:
            neutral[fp_index(mirror)] = [-x, -0.14, z]
    return neutral


def test_an_outer_lip_pressed_past_both_inner_lips_stops_at_contact():
    # lower_t_midlip_o 600 lowers 8.1 by 17.6 mm, past 2.2 (6 mm below it) and 2.3; lower_t_midlip 200 lowers
    # 2.2 by 5.9 mm, past 2.3 (0.2 mm below it). 2.2 stops on 2.3, which stays; 8.1 stops on 2.2: all three
    # meet at 2.3's height, and the lower outer lip stays where it is
    neutral = _mouth_neutral()
    pts = fap_to_fp(neutral, frames({51: 600, 4: 200}), FAPU)[0]
    for fp_id in ("8.1", "2.2", "2.3"):
        assert pts[fp_index(fp_id), 2] == pytest.approx(-0.0402, abs=1e-12)
    assert pts[fp_index("8.2"), 2] == pytest.approx(-0.046, abs=1e-12)
    # raise_b_lip_lm_o 700 lifts 8.7 by 20.5 mm past 2.8 (4.6 mm above it), which stays: 8.7 stops on it
    pts = fap_to_fp(neutral, frames({57: 700}), FAPU)[0]
    assert pts[fp_index("8.7"), 2] == pytest.approx(-0.0404, abs=1e-12)
    assert pts[fp_index("8.8"), 2] == pytest.approx(-0.045, abs=1e-12)  # the right side does not move


def test_a_corner_squeezed_inward_stops_short_of_its_neighbours():
    # stretch_l_cornerlip -400 moves 2.4 inward by 20.3 mm; it stops CORNER_KEEP x 12 mm outside 2.6 (x 13 mm),
    # which is nearer than 2.8 (x 11 mm): at 13 + 3 = 16 mm. The right corner mirrors it.
    neutral = _mouth_neutral()
    pts = fap_to_fp(neutral, frames({6: -400, 7: -400}), FAPU)[0]
    assert pts[fp_index("2.4"), 0] == pytest.approx(0.016, abs=1e-12)
    assert pts[fp_index("2.5"), 0] == pytest.approx(-0.016, abs=1e-12)
    assert pts[fp_index("2.6"), 0] == pytest.approx(0.013, abs=1e-12)
    # a small squeeze moves it freely
    pts = fap_to_fp(neutral, frames({6: -100}), FAPU)[0]
    assert pts[fp_index("2.4"), 0] == pytest.approx(0.025 - 100 * FAPU.unit("MW"), abs=1e-12)


LIP_FAP_NUMBERS = (4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 16, 17, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60)


def _lip_frames(n, seed):
    rng = np.random.default_rng(seed)
    values = np.zeros((n, 68))
    for number in LIP_FAP_NUMBERS:
        values[:, number - 1] = np.where(rng.random(n) < 0.5, rng.uniform(-500, 500, n), 0.0)
    values[:, 2] = np.where(rng.random(n) < 0.3, rng.uniform(-100, 1100, n), 0.0)  # open_jaw
    return values


def test_lip_columns_stay_in_order_for_random_lip_faps():
    neutral = _mouth_neutral()
    pts = fap_to_fp(neutral, _lip_frames(500, 3), FAPU)
    for column in LIP_COLUMNS:  # outer upper >= inner upper >= inner lower >= outer lower (Blender z up)
        z = pts[:, [fp_index(fp_id) for fp_id in column], 2]
        assert np.all(np.diff(z, axis=1) <= 1e-12)
    for corner, beside, side in CORNER_PAIRS:
        assert np.all(side * (pts[:, fp_index(corner), 0] - pts[:, fp_index(beside), 0]) > 0.0)


def test_the_lip_stops_are_mirror_symmetric():
    neutral = _mouth_neutral()
    flip = np.array([-1.0, 1.0, 1.0])
    neutral = 0.5 * (neutral + neutral[mirror_index()] * flip)  # a mirror-symmetric face
    values = _lip_frames(200, 4)
    mirrored = values.copy()
    for left, right in LEFT_RIGHT_PAIRS:
        mirrored[:, [left - 1, right - 1]] = values[:, [right - 1, left - 1]]
    pts, pts_mirrored = fap_to_fp(neutral, values, FAPU), fap_to_fp(neutral, mirrored, FAPU)
    np.testing.assert_allclose(pts_mirrored, pts[:, mirror_index()] * flip, atol=1e-15)


def test_the_lip_stops_are_continuous():
    # along a straight path through lip-FAP space, no FP jumps: each step moves it at most a few times as
    # far as the largest step of any FP without the stops
    neutral = _mouth_neutral()
    start, end = _lip_frames(2, 5)
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    pts = fap_to_fp(neutral, start + t * (end - start), FAPU)
    step = np.linalg.norm(np.diff(pts, axis=0), axis=2).max()
    free = np.abs(end - start).max() / 4000 * max(FAPU.MNS0, FAPU.MW0) / 1024
    assert step < 3.0 * free
