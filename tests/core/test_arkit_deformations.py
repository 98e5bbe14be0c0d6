"""The recipe table's dedicated deformations (arkit/deformations.py), on hand-worked points (no bpy)."""

import numpy as np

from addon.arkit.deformations import (
    bow_follow,
    cheek_puff,
    corner_slide,
    deform_points,
    hinge_angle,
    hinge_axis,
    infraorbital_lift,
    jaw_hinge,
    nose_base_lift,
    nose_base_shift,
    nostril_lift,
    surface_normals,
    whole_lip_push,
    whole_lip_shift,
)
from addon.arkit.recipes import load_recipes
from addon.mpeg4.decode import JAW_RIDERS
from addon.mpeg4.fap_groups import shape_faps
from addon.mpeg4.feature_points import FP_IDS, N_FEATURE_POINTS, fp_index

FACE_FRAME = np.eye(3)  # x left, y up, z forward: mesh coordinates are the face frame


def _face() -> np.ndarray:
    """84 points spread over a box with an adult's ES0 (63 mm), the ears' lower contacts 10.3/10.4 at
    (+-0.05, 0.0324, -0.013) and the outer eye corners straight in front of them, so that the jaw turns about the
    x axis (`hinge_axis`: 13 mm in front of the tragus and 32.4 mm below); the chin 2.1 at 0.1 below and 0.1 in
    front of that axis."""
    points = np.random.default_rng(7).uniform(-0.1, 0.1, (N_FEATURE_POINTS, 3))
    points[fp_index("10.3")] = (0.05, 0.0324, -0.013)
    points[fp_index("10.4")] = (-0.05, 0.0324, -0.013)
    points[fp_index("3.7")] = (0.045, 0.0324, 0.08)
    points[fp_index("3.12")] = (-0.045, 0.0324, 0.08)
    points[fp_index("3.5")] = (0.0315, 0.04, 0.07)
    points[fp_index("3.6")] = (-0.0315, 0.04, 0.07)
    points[fp_index("2.1")] = (0.0, -0.1, 0.1)
    return points


def _turned(point, angle):
    """`point` turned by `angle` about the x axis through the origin (right-handed: y toward z)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([point[0], c * point[1] - s * point[2], s * point[1] + c * point[2]])


def test_the_chin_turns_about_the_ears_and_drops_as_far_as_open_jaw_says():
    neutral = _face()
    angle = np.radians(30.0)
    drop = -0.1 + 0.1 * np.cos(angle) + 0.1 * np.sin(angle)  # 36.6 mm: h (cos a - 1) + d sin a
    assert np.isclose(hinge_angle(neutral[fp_index("2.1")], np.zeros(3), np.array([1.0, 0.0, 0.0]), drop), angle)
    straight = neutral.copy()
    riders = {"2.1": 1.0, **JAW_RIDERS}
    for fp, share in riders.items():
        straight[fp_index(fp), 1] -= share * drop  # open_jaw as decode moves the jaw
    straight[fp_index("2.3"), 2] += 0.004  # a lip FAP on top of the jaw
    moved = jaw_hinge(neutral, straight, neutral, straight, FACE_FRAME)  # the FPs: each by its JAW_RIDERS share
    chin = moved[fp_index("2.1")]
    np.testing.assert_allclose(chin, [0.0, -0.1 - drop, -0.05 + 0.1 * np.cos(angle)], atol=1e-12)
    assert chin[2] < 0.1 - 0.06  # drawn back 63 mm as it drops 37
    for fp in ("2.4", "2.10", "9.9"):  # the corners turn half as far, the chin and teeth all the way
        expected = _turned(neutral[fp_index(fp)], riders[fp] * angle)
        np.testing.assert_allclose(moved[fp_index(fp)], expected, atol=1e-12, err_msg=fp)
    lip = fp_index("2.3")
    np.testing.assert_allclose(moved[lip], _turned(neutral[lip], angle) + [0.0, 0.0, 0.004], atol=1e-12)
    others = [k for k in range(N_FEATURE_POINTS) if k not in {fp_index(fp) for fp in riders}]
    np.testing.assert_array_equal(moved[others], straight[others])  # the upper lip, nose, eyes stay


def test_the_skin_between_the_hinge_and_the_chin_turns_about_the_hinge():
    neutral = _face()
    drop = 0.02
    straight = neutral.copy()
    straight[fp_index("2.1"), 1] -= drop
    # skin vertices halfway between the hinge and the chin, as an engine moved them: straight down by their
    # share of the jaw (all of it, half, none), one also pushed sideways by another FAP
    rest = np.array([[0.0, -0.05, 0.05], [0.01, -0.05, 0.05], [0.0, -0.05, 0.06], [0.0, 0.05, 0.05]])
    share = np.array([1.0, 1.0, 0.5, 0.0])
    engine = (
        rest - (share * drop)[:, None] * [0.0, 1.0, 0.0] + [[0.0, 0.0, 0.0], [0.003, 0.0, 0.0], [0, 0, 0], [0, 0, 0]]
    )
    moved = jaw_hinge(neutral, straight, rest, engine, FACE_FRAME)
    angle = hinge_angle(neutral[fp_index("2.1")], np.zeros(3), np.array([1.0, 0.0, 0.0]), drop)
    motion = moved - rest
    radius = rest * [0.0, 1.0, 1.0]  # from the hinge axis (the x axis)
    for k in range(3):  # turned: as far from the axis as before, moving across the radius, not along it
        assert np.linalg.norm(motion[k]) > 0.004
        assert np.isclose(np.linalg.norm(moved[k] * [0.0, 1.0, 1.0]), np.linalg.norm(radius[k]), atol=1e-12)
        along = motion[k] @ radius[k] / (np.linalg.norm(motion[k]) * np.linalg.norm(radius[k]))
        assert abs(along) <= np.sin(share[k] * angle / 2) + 1e-9  # a chord's tilt from the tangent, no more
    np.testing.assert_allclose(moved[0], _turned(rest[0], angle), atol=1e-12)  # all of the jaw's turn
    np.testing.assert_allclose(moved[2], _turned(rest[2], 0.5 * angle), atol=1e-12)  # half of it
    np.testing.assert_allclose(moved[1], _turned(rest[1], angle) + [0.003, 0.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(moved[3], rest[3])  # off the jaw: stays
    straight_down = (engine - rest)[0] @ radius[0] / (drop * np.linalg.norm(radius[0]))
    assert abs(straight_down) > 0.7  # what the engine alone gives: along the radius by cos 45 degrees


def test_a_lip_raised_back_over_the_open_jaw_turns_by_what_it_is_left_of_the_drop():
    # mouthClose over jawOpen: the engine's shape with the lower lip raised on top of the jaw's drop. Raised all the
    # way back, the lip is left none of the drop and stays where it closed (ARKit's lips closed "independent of
    # jaw position"); before, its share was the jaw's alone, so it turned all the way down and back with the
    # mandible and kept only the raise on top. Raised a quarter, it turns by three quarters of the angle.
    neutral = _face()
    drop = 0.02
    straight = neutral.copy()
    straight[fp_index("2.1"), 1] -= drop
    rest = np.array([[0.0, -0.05, 0.05], [0.0, -0.05, 0.05]])
    raised = rest - [[0.0, 0.0, 0.0], [0.0, 0.75 * drop, 0.0]]
    angle = hinge_angle(neutral[fp_index("2.1")], np.zeros(3), np.array([1.0, 0.0, 0.0]), drop)
    moved = jaw_hinge(neutral, straight, rest, raised, FACE_FRAME)
    np.testing.assert_allclose(moved[0], rest[0], atol=1e-12)
    np.testing.assert_allclose(moved[1], _turned(rest[1], 0.75 * angle), atol=1e-12)


def test_the_jaw_turns_about_a_centre_below_the_condyle_in_the_faces_size():
    # Beyron's condyle 13 mm in front of the tragus 10.3/10.4 toward the outer eye corners, and the turn's centre
    # 32.4 mm below it (Mehl et al. 2025); the ears themselves were the axis before
    neutral = _face()
    origin, axis = hinge_axis(neutral)
    np.testing.assert_allclose(origin, [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(axis, [1.0, 0.0, 0.0], atol=1e-12)
    # a face modelled in centimetres, twice an adult's size (ES0 12.6), its canthi higher than the tragus: the
    # sizes scale with ES0, and the condyle lies along Beyron's line, the centre straight down from it
    big = 200.0 * neutral
    big[[fp_index("3.7"), fp_index("3.12")], 1] += 10.0
    origin, axis = hinge_axis(big)
    line = np.array([0.0, 10.0, 200.0 * 0.093])
    condyle = 200.0 * np.array([0.0, 0.0324, -0.013]) + 200.0 * 0.013 * line / np.linalg.norm(line)
    np.testing.assert_allclose(origin, condyle - [0.0, 200.0 * 0.0324, 0.0], atol=1e-9)
    np.testing.assert_allclose(axis, [1.0, 0.0, 0.0], atol=1e-12)
    missing = neutral.copy()
    missing[fp_index("3.12")] = np.nan
    assert hinge_axis(missing) is None


def test_jaw_open_at_one_is_the_jaws_maximal_opening():
    """ARKit's 1.0 is the 'maximum movement'; the jaw's maximal opening turns it 36-39 deg (Muto and Kanazawa
    1996). On the sample head's sizes (the chin 72.3 mm below the turn's centre and 59.9 mm in front, an MNS0 of
    18.1 mm) that turn brings the chin near the bottom of its arc (21.6 mm down at 39.6 deg): jawOpen's open_jaw
    turns it 38 deg. The face's soft limit (the jaw up to 1100 MNS) eases it to a 26.4 deg turn, more than the
    22.7 deg of open_jaw 1000 before."""
    table = load_recipes()
    chin, origin, axis = np.array([0.0, -0.0723, 0.0599]), np.zeros(3), np.array([1.0, 0.0, 0.0])
    mns = 0.0181 / 1024.0
    open_jaw = table.recipe("jawOpen")[2]
    assert np.degrees(hinge_angle(chin, origin, axis, open_jaw * mns)) > 36.0
    eased = shape_faps(table.recipe("jawOpen")[None])[0, 2]
    assert 26.0 < np.degrees(hinge_angle(chin, origin, axis, eased * mns)) < 28.0
    assert np.degrees(hinge_angle(chin, origin, axis, shape_faps(np.eye(68)[2:3] * 1000.0)[0, 2] * mns)) < 23.5


def test_the_jaw_turn_is_the_same_in_any_mesh_frame():
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up, -Y
    straight = neutral.copy()
    straight[fp_index("2.1"), 1] -= 0.02
    in_face = jaw_hinge(neutral, straight, neutral, straight, FACE_FRAME)
    in_blender = jaw_hinge(neutral @ axes, straight @ axes, neutral @ axes, straight @ axes, axes)
    np.testing.assert_allclose(in_blender, in_face @ axes, atol=1e-12)


def test_without_the_ear_points_the_jaw_drops_straight():
    neutral = _face()
    neutral[fp_index("10.4")] = np.nan
    straight = neutral.copy()
    straight[fp_index("2.1"), 1] -= 0.02
    np.testing.assert_array_equal(jaw_hinge(neutral, straight, neutral, straight, FACE_FRAME), straight)


def test_the_whole_lip_moves_with_its_mid_points_push():
    neutral = _face()
    pushed = neutral.copy()
    pushed[fp_index("2.2"), 2] += 0.010  # push_t_lip
    pushed[fp_index("2.3"), 2] += 0.006  # push_b_lip
    pushed[fp_index("8.5"), 1] -= 0.002  # a lip FAP's own motion stays
    moved = whole_lip_push(neutral, pushed, FACE_FRAME)
    forward = moved[:, 2] - neutral[:, 2]
    for fp in ("2.2", "8.1", "2.6", "2.7", "8.5", "8.6", "8.9", "8.10"):  # the Cupid's bow's peaks too (they stayed)
        assert np.isclose(forward[fp_index(fp)], 0.010), fp
    for fp in ("2.3", "8.2", "2.8", "2.9", "8.7", "8.8"):
        assert np.isclose(forward[fp_index(fp)], 0.006), fp
    for fp in ("2.4", "2.5", "8.3", "8.4"):
        assert np.isclose(forward[fp_index(fp)], 0.008), fp
    assert np.isclose(moved[fp_index("8.5"), 1], pushed[fp_index("8.5"), 1])
    lips = {fp_index(fp) for fp in "2.2 2.3 2.4 2.5 2.6 2.7 2.8 2.9 8.1 8.2 8.3 8.4 8.5 8.6 8.7 8.8 8.9 8.10".split()}
    nose_base = {fp_index("9.4"), fp_index("9.5")}  # with the skin above the lip (`nose_base_push`, below)
    others = [k for k in range(N_FEATURE_POINTS) if k not in lips | nose_base]
    np.testing.assert_array_equal(moved[others], pushed[others])


def test_the_nose_base_comes_with_the_pushed_lip_as_the_skin_between_the_nostril_and_the_lip():
    # 9.5 lies a quarter of the way down from the nostril's border 9.1 (held by the ala) to the lip's 8.5: it
    # comes forward a quarter of the lip's push; on the right 9.4 lies at 9.2's height and takes 9.2's push (none)
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    for fp, point in {"9.1": (0.014, 0.010, 0.12), "9.5": (0.016, 0.0, 0.11), "8.5": (0.014, -0.030, 0.13)}.items():
        neutral[fp_index(fp)] = point
    for fp, point in {"9.2": (-0.014, 0.010, 0.12), "9.4": (-0.016, 0.010, 0.11)}.items():
        neutral[fp_index(fp)] = point
    pursed = neutral.copy()
    pursed[fp_index("2.2"), 2] += 0.008  # push_t_lip: the upper lip, 8.5 with it, 8 mm forward
    pursed[fp_index("8.5"), 1] -= 0.002  # a lip FAP lowers 8.5: 9.5 keeps its height
    pursed[fp_index("9.5"), 0] += 0.001  # and its sideways place (no FAP moves it; checked as a rule)
    moved = whole_lip_push(neutral @ axes, pursed @ axes, axes) @ axes.T
    np.testing.assert_allclose(moved[fp_index("9.5")], pursed[fp_index("9.5")] + [0.0, 0.0, 0.002], atol=1e-12)
    np.testing.assert_allclose(moved[fp_index("9.4")], neutral[fp_index("9.4")], atol=1e-12)
    np.testing.assert_allclose(moved[[fp_index("9.1"), fp_index("9.2")]], pursed[[fp_index("9.1"), fp_index("9.2")]])
    rolled = neutral.copy()
    rolled[fp_index("2.2"), 2] -= 0.008  # a roll takes the lip back: the skin above it goes back with it
    back = whole_lip_push(neutral, rolled, FACE_FRAME)
    assert np.isclose(back[fp_index("9.5"), 2] - neutral[fp_index("9.5"), 2], -0.002)


def test_a_shrug_pushes_the_lips_midline_out_inner_and_outer_and_leaves_the_rest():
    neutral = _face()
    pushed = neutral.copy()
    pushed[fp_index("2.3"), 2] += 0.002  # push_b_lip
    pushed[fp_index("2.3"), 1] += 0.003  # the lip's rise stays
    moved = deform_points("mid_lip_push", neutral, pushed, FACE_FRAME)
    np.testing.assert_allclose(moved[fp_index("8.2")], neutral[fp_index("8.2")] + [0.0, 0.0, 0.002], atol=1e-12)
    others = [k for k in range(N_FEATURE_POINTS) if k != fp_index("8.2")]
    np.testing.assert_array_equal(moved[others], pushed[others])  # corners, sides and the upper lip stay


def test_a_corner_moved_sideways_slides_on_the_face_back_going_out_and_forward_coming_in():
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    # the left inner corner between its lip (2.6, 2.8: mean x 12 mm, z 136) and its cheek (5.1: 30 mm further
    # out, 24 back): the surface falls back 0.8 mm per mm out
    neutral[fp_index("2.6")] = (0.013, -0.036, 0.137)
    neutral[fp_index("2.8")] = (0.011, -0.038, 0.135)
    neutral[fp_index("5.1")] = (0.042, -0.040, 0.112)
    # the right outer corner between 8.6, 8.8 (x -13 mm, z 138) and 5.2 (30 mm out, 30 back): 1 mm per mm
    neutral[fp_index("8.6")] = (-0.014, -0.030, 0.139)
    neutral[fp_index("8.8")] = (-0.012, -0.041, 0.137)
    neutral[fp_index("5.2")] = (-0.043, -0.040, 0.108)
    moved_by_faps = neutral.copy()
    moved_by_faps[fp_index("2.4")] += (0.004, 0.001, 0.0)  # out 4 mm (stretch_l_cornerlip) and up 1 mm
    moved_by_faps[fp_index("8.4")] += (0.005, 0.0, 0.002)  # in 5 mm, and 2 mm forward another way
    moved = corner_slide(neutral @ axes, moved_by_faps @ axes, axes) @ axes.T
    expected = moved_by_faps.copy()
    expected[fp_index("2.4"), 2] -= 0.8 * 0.004
    expected[fp_index("8.4"), 2] += 0.005
    np.testing.assert_allclose(moved, expected, atol=1e-12)  # the corners that did not move sideways stay
    # the pursed lips' corners come in and so forward, on top of the lips' push
    pucker = moved_by_faps.copy()
    pucker[fp_index("2.2"), 2] += 0.006
    pucker[fp_index("2.3"), 2] += 0.006
    pushed = whole_lip_push(neutral, pucker, FACE_FRAME)
    assert np.isclose(pushed[fp_index("8.4"), 2] - neutral[fp_index("8.4"), 2], 0.002 + 0.005 + 0.006)


def test_the_nostril_rises_with_the_upper_lip_beside_it():
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    sneer = neutral.copy()
    sneer[fp_index("8.5"), 1] += 0.003  # the left upper lip rises (lower_t_lip_lm_o < 0)
    sneer[fp_index("8.6"), 1] -= 0.002  # the right one comes down: its nostril stays
    sneer[fp_index("9.1"), 0] += 0.001  # stretch_l_nose widens the nostril: that stays too
    moved = nostril_lift(neutral @ axes, sneer @ axes, axes) @ axes.T
    for fp in ("9.1", "9.5"):
        np.testing.assert_allclose(moved[fp_index(fp)], sneer[fp_index(fp)] + [0.0, 0.003, 0.0], atol=1e-12)
    others = [k for k in range(N_FEATURE_POINTS) if k not in (fp_index("9.1"), fp_index("9.5"))]
    np.testing.assert_allclose(moved[others], sneer[others], atol=1e-12)
    np.testing.assert_array_equal(
        deform_points("nostril_lift", neutral, sneer, FACE_FRAME)[fp_index("9.5")],
        neutral[fp_index("9.5")] + [0.0, 0.003, 0.0],
    )


def test_the_nose_base_rises_with_the_upper_lip_below_it_and_the_nostril_stays():
    # AU 10 lifts the upper lip, whose upper edge is the nose's bottom edge: 9.5 rises with 8.5, 9.1 (the ala,
    # AU 9's) and the midline's 9.15 stay; a lip that comes down leaves its side's nose base where it was
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    lifted = neutral.copy()
    lifted[fp_index("8.5"), 1] += 0.005  # the left upper lip rises (lower_t_lip_lm_o < 0)
    lifted[fp_index("8.1"), 1] += 0.0025  # its middle half as far
    lifted[fp_index("8.6"), 1] -= 0.002  # the right one comes down
    moved = nose_base_lift(neutral @ axes, lifted @ axes, axes) @ axes.T
    np.testing.assert_allclose(moved[fp_index("9.5")], neutral[fp_index("9.5")] + [0.0, 0.005, 0.0], atol=1e-12)
    others = [k for k in range(N_FEATURE_POINTS) if k != fp_index("9.5")]
    np.testing.assert_allclose(moved[others], lifted[others], atol=1e-12)  # 9.1, 9.4, 9.15 among them
    np.testing.assert_array_equal(
        deform_points("nose_base_lift", neutral, lifted, FACE_FRAME),
        bow_follow(
            neutral, infraorbital_lift(neutral, nose_base_lift(neutral, lifted, FACE_FRAME), FACE_FRAME), FACE_FRAME
        ),
    )


def test_the_cupids_bow_peaks_follow_the_upper_lips_outer_contour_where_they_lie():
    # no FAP moves 8.9 / 8.10: each moves as the contour between 8.1 and the side point beside it, blended by where
    # it lies across at rest (before: pinned, every lip FAP bent the contour down to them)
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    for peak, mid, side, t in (("8.10", "8.1", "8.5", 0.25), ("8.9", "8.1", "8.6", 0.75)):
        neutral[fp_index(peak)] = (1 - t) * neutral[fp_index(mid)] + t * neutral[fp_index(side)] + [0.0, 0.002, 0.0]
    lifted = neutral.copy()
    lifted[fp_index("8.1"), 1] += 0.004  # the mid-point up 4 mm
    lifted[fp_index("8.5")] += [0.001, 0.008, -0.002]  # the left side up 8, out 1, forward 2
    lifted[fp_index("8.10")] += 0.005  # a motion a deformation gave the peak is replaced by the contour's
    moved = bow_follow(neutral @ axes, lifted @ axes, axes) @ axes.T
    np.testing.assert_allclose(
        moved[fp_index("8.10")] - neutral[fp_index("8.10")], [0.00025, 0.003 + 0.002, -0.0005], atol=1e-12
    )
    np.testing.assert_allclose(moved[fp_index("8.9")], neutral[fp_index("8.9")] + [0.0, 0.001, 0.0], atol=1e-12)
    others = [k for k in range(N_FEATURE_POINTS) if k not in (fp_index("8.9"), fp_index("8.10"))]
    np.testing.assert_allclose(moved[others], lifted[others], atol=1e-12)
    # every recipe's points end so, a uniform shift staying a shift
    np.testing.assert_allclose(
        deform_points(None, neutral, lifted, FACE_FRAME),
        bow_follow(
            neutral,
            infraorbital_lift(neutral, lifted, FACE_FRAME),
            FACE_FRAME,
        ),
    )


def test_a_recipe_without_a_point_deformation_keeps_its_points():
    neutral = _face()
    pushed = neutral + 0.001
    np.testing.assert_array_equal(deform_points(None, neutral, pushed), pushed)
    np.testing.assert_array_equal(deform_points("tongue_forward", neutral, pushed), pushed)
    np.testing.assert_array_equal(deform_points("jaw_hinge", neutral, pushed), pushed)  # it turns the skin


def test_the_lips_slide_sideways_as_far_as_both_corners_go_together():
    # mouthLeft: both corners 7 mm toward the face's left (+x); no FAP moves the rest of the lips sideways, and
    # 'whole_lip_shift' carries every other lip point as far (before: they stayed, the lips stretched between)
    neutral = _face()
    lips = ("2.2", "2.3", "8.1", "8.2", "2.6", "2.7", "2.8", "2.9", "8.5", "8.6", "8.7", "8.8", "8.9", "8.10")
    for left, right, shift in ((0.007, 0.007, 0.007), (0.006, 0.0, 0.003)):  # both corners; one corner alone
        points = neutral.copy()
        for corner, out in (("2.4", left), ("8.3", left), ("2.5", right), ("8.4", right)):
            points[fp_index(corner), 0] += out
        moved = whole_lip_shift(neutral, points, FACE_FRAME)
        slid = corner_slide(neutral, points, FACE_FRAME)
        for fp in lips:
            np.testing.assert_allclose(moved[fp_index(fp)] - slid[fp_index(fp)], [shift, 0.0, 0.0], atol=1e-12)
        others = [k for k in range(N_FEATURE_POINTS) if k not in {fp_index(fp) for fp in (*lips, "9.4", "9.5", "9.15")}]
        np.testing.assert_array_equal(moved[others], slid[others])  # the corners as corner_slide put them
        # the nose's bottom edge as `nose_base_shift` moves it with the shifted lips
        np.testing.assert_allclose(moved, nose_base_shift(neutral, moved, FACE_FRAME), atol=1e-12)


def test_a_puffed_cheek_goes_out_along_its_surface_normal_as_far_as_the_fap_moved_it():
    # cheekPuff: puff_cheek moves 5.1 / 5.2 7 mm straight sideways; a pressure pushes the cheek along its normal,
    # here 30 deg forward of sideways on each side (and a normal flipped inward is still read outward), so each
    # cheek goes 7 mm along it: 6.06 mm out and 3.5 mm forward (before: 7 mm out, none forward); the lips' push is
    # `whole_lip_push`'s, nothing else moves
    neutral, axes = _face(), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Blender: Z up
    a = np.radians(30.0)
    normals = np.full((N_FEATURE_POINTS, 3), np.nan)
    normals[fp_index("5.1")] = np.array([np.cos(a), 0.0, np.sin(a)]) @ axes
    normals[fp_index("5.2")] = -np.array([-np.cos(a), 0.0, np.sin(a)]) @ axes  # flipped: points into the head
    mesh = neutral @ axes
    puffed = neutral.copy()
    puffed[fp_index("5.1"), 0] += 0.007
    puffed[fp_index("5.2"), 0] -= 0.007
    puffed[fp_index("2.2"), 2] += 0.007  # push_t_lip
    puffed[fp_index("2.3"), 2] += 0.007  # push_b_lip
    moved = cheek_puff(mesh, puffed @ axes, normals, axes) @ axes.T
    np.testing.assert_allclose(
        moved[fp_index("5.1")] - neutral[fp_index("5.1")], 0.007 * np.array([np.cos(a), 0, np.sin(a)]), atol=1e-12
    )
    np.testing.assert_allclose(
        moved[fp_index("5.2")] - neutral[fp_index("5.2")], 0.007 * np.array([-np.cos(a), 0, np.sin(a)]), atol=1e-12
    )
    lips = whole_lip_push(mesh, puffed @ axes, axes) @ axes.T
    others = [k for k in range(N_FEATURE_POINTS) if k not in (fp_index("5.1"), fp_index("5.2"))]
    np.testing.assert_allclose(moved[others], lips[others], atol=1e-12)
    # without the normals the cheeks move as the FAPs say; a sucked cheek goes inward along the normal
    np.testing.assert_allclose(cheek_puff(mesh, puffed @ axes, None, axes), whole_lip_push(mesh, puffed @ axes, axes))
    sucked = neutral.copy()
    sucked[fp_index("5.1"), 0] -= 0.004
    moved = deform_points("cheek_puff", mesh, sucked @ axes, axes, normals) @ axes.T
    np.testing.assert_allclose(
        moved[fp_index("5.1")] - neutral[fp_index("5.1")], -0.004 * np.array([np.cos(a), 0, np.sin(a)]), atol=1e-12
    )


def test_the_surface_normal_at_a_point_is_the_mean_of_the_skins_normals_around_it():
    neutral = _face()  # ES0 63 mm: normals are the mean over 6.3 mm
    cheek = neutral[fp_index("5.1")]
    vertices = np.array([cheek + [0.002, 0.0, 0.0], cheek + [0.0, 0.004, 0.0], cheek + [0.0, 0.0, 0.02]])
    vertex_normals = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])  # the far one is left out
    normals = surface_normals(neutral, vertices, vertex_normals)
    np.testing.assert_allclose(normals[fp_index("5.1")], [np.sqrt(0.5), 0.0, np.sqrt(0.5)], atol=1e-12)
    cheeks = [fp_index(fp) for fp in ("5.1", "5.2")]
    assert np.all(np.isfinite(normals[cheeks]))  # the nearest vertex's where none lies near (5.2)
    assert np.isnan(np.delete(normals, cheeks, axis=0)).all()  # only the cheeks' are asked for by default
    assert np.all(np.isfinite(surface_normals(neutral, vertices, vertex_normals, fps=FP_IDS)))
    neutral[fp_index("3.6")] = np.nan  # no ES0
    assert np.isnan(surface_normals(neutral, vertices, vertex_normals)).all()


def test_the_cheek_bone_rises_with_the_raised_lip_below_it_by_where_it_lies():
    # 5.3 lies a quarter of the way down from the lower lid 3.3 to the lip's side point 8.5 (face y): the lip raised
    # 4 mm (the corner 8.3 2 mm) raises it 0.25 x 4 mm; its other axes and every other point stay, the right side too
    neutral = _face()
    neutral[fp_index("3.3")] = (0.03, 0.02, 0.06)
    neutral[fp_index("8.5")] = (0.015, -0.06, 0.08)
    neutral[fp_index("8.3")] = (0.025, -0.065, 0.07)
    neutral[fp_index("5.3")] = (0.035, 0.0, 0.06)
    points = neutral.copy()
    points[fp_index("8.5"), 1] += 0.004
    points[fp_index("8.3"), 1] += 0.002
    moved = infraorbital_lift(neutral, points, FACE_FRAME)
    expected = points.copy()
    expected[fp_index("5.3"), 1] += 0.25 * 0.004
    np.testing.assert_allclose(moved, expected, atol=1e-12)
    # the corner rising more than the side point: the corner's rise, by where 5.3 lies between 3.3 and 8.3
    points[fp_index("8.3"), 1] += 0.006  # 8 mm
    share = (0.02 - 0.0) / (0.02 - -0.065)
    np.testing.assert_allclose(
        infraorbital_lift(neutral, points, FACE_FRAME)[fp_index("5.3")],
        neutral[fp_index("5.3")] + (0, share * 0.008, 0),
    )
    # a lip that comes down leaves it, and so does a cheek bone a FAP moved (lift_cheek: cheekSquint)
    lowered = neutral.copy()
    lowered[fp_index("8.5"), 1] -= 0.004
    np.testing.assert_array_equal(infraorbital_lift(neutral, lowered, FACE_FRAME), lowered)
    lifted = points.copy()
    lifted[fp_index("5.3"), 1] += 0.003
    np.testing.assert_array_equal(infraorbital_lift(neutral, lifted, FACE_FRAME), lifted)
    # every recipe: deform_points ends with it
    assert deform_points(None, neutral, points, FACE_FRAME)[fp_index("5.3"), 1] > neutral[fp_index("5.3"), 1]


def test_the_nose_base_goes_sideways_with_the_shifted_lips_by_where_it_lies():
    # 9.5 lies 0.4 of the way down from the nostril's border 9.1 to the lip's point 8.5 (face y), 9.15 a quarter of
    # the way from the nose's tip 9.3 to 8.1: the lips 6 mm to the left (+x), they go 0.4 and 0.25 of it, sideways
    # only; the nostril and the tip stay, and nothing else moves
    neutral = _face()
    for fp_id, y in (("9.1", 0.0), ("9.5", -0.004), ("8.5", -0.01), ("9.3", 0.0), ("9.15", -0.003), ("8.1", -0.012)):
        neutral[fp_index(fp_id), 1] = y
    points = neutral.copy()
    points[[fp_index("8.5"), fp_index("8.1"), fp_index("8.6")], 0] += 0.006
    moved = nose_base_shift(neutral, points, FACE_FRAME)
    expected = points.copy()
    expected[fp_index("9.5"), 0] += 0.4 * 0.006
    expected[fp_index("9.15"), 0] += 0.25 * 0.006
    expected[fp_index("9.4"), 0] += 0.006 * float(
        np.clip(
            (neutral[fp_index("9.4"), 1] - neutral[fp_index("9.2"), 1])
            / (neutral[fp_index("8.6"), 1] - neutral[fp_index("9.2"), 1]),
            0,
            1,
        )
    )
    np.testing.assert_allclose(moved, expected, atol=1e-12)
    # whole_lip_shift ends with it: the mid-line's base goes with a mouth shifted by its corners
    shifted = neutral.copy()
    shifted[[fp_index("2.4"), fp_index("2.5")], 0] += 0.006
    assert whole_lip_shift(neutral, shifted, FACE_FRAME)[fp_index("9.15"), 0] - neutral[fp_index("9.15"), 0] > 0.001
