"""Eyelids turning over the eyeball: closure, no crossing, no V, gaze follow (synthetic eye, face frame)."""

import numpy as np
import pytest

from addon.deform.eyelids import (
    EYE_FPS,
    LOWER_FOLLOWS_PITCH,
    MEET_CLEARANCE,
    UPPER_FOLLOWS_PITCH,
    apply_eyelids,
    bind_eyelids,
    elevation,
    hold_lids,
    lid_profile,
    lid_turns,
    one_row_deep,
    seen_margin_points,
    seen_margins,
    vertex_neighbours,
)
from addon.deform.overlaps import edge_roughness
from addon.mpeg4.decode import meet_at_closure
from addon.mpeg4.feature_points import fp_index

AXES = np.eye(3)  # mesh = face frame here: x left, y up, z forward
R_EYE, R_LID = 0.012, 0.013
# the opening is traced from the mesh, one margin vertex per bin, linearly between: 2 mrad (0.03 mm) off
TRACE = 0.003
CORNER = 0.011  # corners at x = +-11 mm from the eye centre, on the horizontal plane
UP0, LOW0 = np.radians(25.0), np.radians(-20.0)  # mid-lid margins at rest
CENTRES = np.array([[0.032, 0.0, 0.0], [-0.032, 0.0, 0.0]])
XS = np.linspace(-0.0125, 0.0125, 51)
INSIDE = np.abs(XS) < CORNER  # between the eye corners


def _on_shell(centre, x, angle, radius=R_LID):
    """Points at lateral offset x and elevation `angle` on a sphere of `radius` about `centre`."""
    x, angle = np.broadcast_arrays(x, angle)
    rho = np.sqrt(radius**2 - x**2)
    return centre + np.stack([x, rho * np.sin(angle), rho * np.cos(angle)], axis=-1)


def _opening_shape(arch: np.ndarray, fuller: bool) -> np.ndarray:
    return arch * (2.0 - arch) if fuller else arch


def _eye(xs=XS, shares=(1.0,) * 8, fuller=False):
    """Lids on a shell over two eyeballs: rows of vertices at `xs` from each margin outward, the rows' lid membership
    `shares` (8,) from the margin out; FPs on the margins. The opening narrows to the corners like the sine arch s
    (`lid_profile`), or if `fuller` like s (2 - s), fuller toward the corners as a real eye's outer corner."""
    verts, upper, lower, margins = [], [], [], {}
    neutral = np.full((84, 3), np.nan)
    for e, centre in enumerate(CENTRES):
        s = _opening_shape(lid_profile(xs, -CORNER, 0.0, CORNER), fuller)
        up_margin, low_margin = s * UP0, s * LOW0
        for k, (start, end, member) in enumerate(
            ((up_margin, np.radians(70), upper), (low_margin, -np.radians(70), lower))
        ):
            rows = [_on_shell(centre, xs, start + f * (end - start)) for f in np.linspace(0, 1, 8)]
            first = sum(len(v) for v in verts)
            margins[(e, k)] = np.arange(first, first + len(xs))
            for row, share in zip(rows, shares, strict=True):
                verts.append(row)
                member.append(np.full(len(row), share))
                (lower if member is upper else upper).append(np.zeros(len(row)))
        ids = (("3.1", "3.3", "3.11", "3.7", "3.5"), ("3.2", "3.4", "3.8", "3.12", "3.6"))[e]
        sign = 1.0 if e == 0 else -1.0  # inner corner toward the nose (x = 0)
        neutral[fp_index(ids[0])] = _on_shell(centre, 0.0, UP0)
        neutral[fp_index(ids[1])] = _on_shell(centre, 0.0, LOW0)
        neutral[fp_index(ids[2])] = _on_shell(centre, -sign * CORNER, 0.0)
        neutral[fp_index(ids[3])] = _on_shell(centre, sign * CORNER, 0.0)
        neutral[fp_index(ids[4])] = _on_shell(centre, 0.0, 0.0, R_EYE)
    rest = np.concatenate(verts)
    return rest, np.concatenate(upper), np.concatenate(lower), neutral, margins


REST, UPPER, LOWER, NEUTRAL, MARGINS = _eye()
RIG = bind_eyelids(REST, UPPER, LOWER, NEUTRAL, CENTRES, np.array([R_EYE, R_EYE]), AXES)


def _turned_fp(fps, fp_id, eye, angle):
    """Turn an FP about its eye centre by `angle` (radians, + up)."""
    p = fps[fp_index(fp_id)] - CENTRES[eye]
    c, s = np.cos(angle), np.sin(angle)
    fps[fp_index(fp_id)] = CENTRES[eye] + [p[0], c * p[1] + s * p[2], c * p[2] - s * p[1]]


def _pose(upper_turn=0.0, lower_turn=0.0, pitch=0.0):
    fps = NEUTRAL.copy()
    for e, (up, low, pupil) in enumerate((("3.1", "3.3", "3.5"), ("3.2", "3.4", "3.6"))):
        _turned_fp(fps, up, e, upper_turn)
        _turned_fp(fps, low, e, lower_turn)
        _turned_fp(fps, pupil, e, pitch)
    out = REST.copy()  # the deformer left everything at rest: all motion here is the lids' own
    apply_eyelids(RIG, out, fps)
    return out


def _margin_angles(out, eye, lid):
    return elevation(out[MARGINS[(eye, lid)]], CENTRES[eye])


def test_profile_by_hand():
    s = lid_profile(np.array([-2.0, -1.0, 0.0, 0.5, 1.0, 2.0]), -1.0, 0.0, 1.0)
    np.testing.assert_allclose(s, [0.0, 0.0, 1.0, np.sin(np.pi * 0.75), 0.0, 0.0], atol=1e-15)


def test_rest_stays_rest():
    np.testing.assert_array_equal(_pose(), REST)  # no turn: the vertices are not touched at all


@pytest.mark.parametrize("eye", [0, 1])
def test_full_blink_closes_along_the_whole_lid(eye):
    out = _pose(upper_turn=LOW0 - UP0)  # the upper mid-lid FP turned down onto the lower one
    up, low = _margin_angles(out, eye, 0), _margin_angles(out, eye, 1)
    # the upper lid stops MEET_CLEARANCE short of the lower one (`meet_lids`), all along the eye
    np.testing.assert_allclose(up[INSIDE], low[INSIDE] + MEET_CLEARANCE, atol=TRACE)
    assert np.all(low[INSIDE] < 0.0)  # closed where the lower lid is, not half-way


@pytest.mark.parametrize("upper_turn, lower_turn", [(-2.0, 0.0), (-1.5, 1.0), (0.1, 2.5), (-3.0, 3.0)])
def test_overlapping_values_meet_and_never_cross(upper_turn, lower_turn):
    out = _pose(upper_turn, lower_turn)
    for eye in (0, 1):
        up, low = _margin_angles(out, eye, 0), _margin_angles(out, eye, 1)
        assert np.all(up >= low - TRACE)
        # each closing lid stops MEET_CLEARANCE short of the other (`meet_lids`)
        closing = (upper_turn < 0.0) + (lower_turn > 0.0)
        np.testing.assert_allclose(up[INSIDE], low[INSIDE] + closing * MEET_CLEARANCE, atol=TRACE)


def test_half_blink_has_no_v():
    out = _pose(upper_turn=0.5 * (LOW0 - UP0))
    up = _margin_angles(out, 0, 0)
    mid = len(XS) // 2
    slope = np.diff(up) / np.diff(XS)
    # smooth at the mid-lid point: the slopes either side nearly match; a V (the mid-lid point pulled down
    # alone, the corners fixed) flips them by 2 x 22.5 deg / 11 mm; the traced opening leaves a few percent
    v_kink = 2 * np.radians(22.5) / CORNER
    assert abs(slope[mid] - slope[mid - 1]) < 0.1 * v_kink
    # the margin stays a single arch: rising to the middle, falling after it
    left = (XS[:-1] > -CORNER) & (XS[1:] < 0.0)
    right = (XS[:-1] > 0.0) & (XS[1:] < CORNER)
    assert np.all(slope[left] >= -0.05 * v_kink) and np.all(slope[right] <= 0.05 * v_kink)


def test_lids_slide_on_the_eyeball():
    out = _pose(upper_turn=-0.6, lower_turn=0.2, pitch=-0.3)
    eye = np.argmin(np.linalg.norm(REST[:, None] - CENTRES[None], axis=2), axis=1)
    np.testing.assert_allclose(
        np.linalg.norm(out - CENTRES[eye], axis=1), np.linalg.norm(REST - CENTRES[eye], axis=1), atol=1e-12
    )


def test_lids_follow_the_gaze_partly():
    pitch = np.radians(-20.0)  # looking down
    out = _pose(pitch=pitch)
    mid = len(XS) // 2
    assert _margin_angles(out, 0, 0)[mid] - UP0 == pytest.approx(UPPER_FOLLOWS_PITCH * pitch, abs=TRACE)
    assert _margin_angles(out, 0, 1)[mid] - LOW0 == pytest.approx(LOWER_FOLLOWS_PITCH * pitch, abs=TRACE)


def test_missing_lid_points_give_no_rig():
    neutral = NEUTRAL.copy()
    neutral[fp_index("3.3")] = np.nan
    assert bind_eyelids(REST, UPPER, LOWER, neutral, CENTRES, np.array([R_EYE, R_EYE]), AXES) is None


def test_hold_lids_keeps_the_mid_lid_points_at_rest_only():
    ids = ["3.1", "4.1", "3.4", "3.13"]
    rest = np.zeros((4, 3))
    points = np.arange(12.0).reshape(4, 3)
    held = hold_lids(ids, points, rest)
    np.testing.assert_array_equal(held[[0, 2]], 0.0)
    np.testing.assert_array_equal(held[[1, 3]], points[[1, 3]])
    np.testing.assert_array_equal(hold_lids(["4.1"], points[:1], rest[:1]), points[:1])


@pytest.mark.parametrize("upper_turn, lower_turn, pitch", [(-0.8, 0.0, 0.0), (-0.8, 0.8, -0.4), (0.5, -0.5, 0.4)])
def test_no_skin_folds_whatever_the_turn(upper_turn, lower_turn, pitch):
    """Along each column of the lid skin, the vertices keep their order: no row passes the one above it."""
    out = _pose(upper_turn, lower_turn, pitch)
    rows = len(XS)
    for eye in (0, 1):
        for lid in (0, 1):
            first = MARGINS[(eye, lid)][0]
            column = np.arange(first, first + 8 * rows, rows)  # 8 rows outward from the margin, one column
            for k in range(rows):
                angles = elevation(out[column + k], CENTRES[eye])
                step = np.diff(angles) * (1 if lid == 0 else -1)
                assert np.all(step > 0.0)


def _lid_turns_one_eye_at_a_time(rig, fp_positions):
    """lid_turns spelled out eye by eye, with scalar stops (what it computed before it did both eyes at once)."""
    fps = np.asarray(fp_positions, dtype=np.float64) @ rig.axes.T
    turns = np.zeros((2, 2))
    for e, (upper, lower, _inner, _outer, pupil) in enumerate(EYE_FPS):
        now = elevation(fps[[fp_index(upper), fp_index(lower), fp_index(pupil)]], rig.centres[e])
        delta = np.where(np.isfinite(now), now - rig.rest_angles[e], 0.0)
        up = delta[0] + UPPER_FOLLOWS_PITCH * delta[2]
        low = delta[1] + LOWER_FOLLOWS_PITCH * delta[2]
        down, rise = meet_at_closure(-up, low, float(rig.rest_angles[e, 0] - rig.rest_angles[e, 1]))
        turns[e] = (-float(down), float(rise))
    return turns


def test_both_eyes_at_once_equal_one_eye_at_a_time():
    rng = np.random.default_rng(5)
    for _ in range(200):
        fps = NEUTRAL + rng.normal(0.0, 0.004, NEUTRAL.shape)
        if rng.random() < 0.2:
            fps[fp_index("3.5")] = np.nan  # a missing pupil: no gaze follow
        np.testing.assert_allclose(lid_turns(RIG, fps), _lid_turns_one_eye_at_a_time(RIG, fps), rtol=0, atol=1e-12)


def test_apply_matches_a_plain_rotation_on_random_rigs():
    """apply_eyelids adds exactly R_x(angle) local - local, mapped back through the face axes, per vertex."""
    from addon.deform import eyelids as lids

    rng = np.random.default_rng(7)
    for _ in range(5):
        k = 200
        q, _r = np.linalg.qr(rng.normal(size=(3, 3)))
        rig = lids.EyelidRig(
            vertices=rng.permutation(400)[:k],
            eye=rng.integers(0, 2, k),
            upper=rng.random(k),
            lower=rng.random(k),
            local=rng.normal(size=(k, 3)),
            centres=rng.normal(size=(2, 3)),
            rest_angles=rng.normal(size=(2, 3)) * 0.3,
            axes=q,
        )
        fps = rng.normal(size=(84, 3))
        turns = lids.lid_turns(rig, fps)
        out = rng.normal(size=(400, 3))
        expected = out.copy()
        for i in range(k):
            a = rig.upper[i] * turns[rig.eye[i], 0] + rig.lower[i] * turns[rig.eye[i], 1]
            rot = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), np.sin(a)], [0.0, -np.sin(a), np.cos(a)]])
            expected[rig.vertices[i]] += (rot @ rig.local[i] - rig.local[i]) @ rig.axes
        lids.apply_eyelids(rig, out, fps)
        np.testing.assert_allclose(out, expected, rtol=0.0, atol=1e-12)


def test_opening_from_the_fps_closes_smoothly_without_crossing():
    # lid weights made from the FPs: the share of the turn along the eye a sine arch between the corners
    # (`lid_profile`), not margins traced through the weights; a full blink leaves a smooth margin that
    # meets the lower lid near the middle and never passes it
    rig = bind_eyelids(REST, UPPER, LOWER, NEUTRAL, CENTRES, np.array([R_EYE, R_EYE]), AXES, trace_opening=False)
    fps = NEUTRAL.copy()
    for e, up in enumerate(("3.1", "3.2")):
        _turned_fp(fps, up, e, LOW0 - UP0)
    out = REST.copy()
    apply_eyelids(rig, out, fps)
    for eye in (0, 1):
        up, low = _margin_angles(out, eye, 0), _margin_angles(out, eye, 1)
        assert np.all(up >= low - TRACE)
        middle = np.abs(XS) < 0.2 * CORNER
        np.testing.assert_allclose(up[middle], low[middle], atol=3 * TRACE)
        bend = np.abs(np.diff(up[INSIDE], 2))  # a smooth curve: no kink between neighbours (0.5 mm apart)
        assert bend.max() < 0.01


def test_meet_lids_stops_every_row_where_the_other_lid_is_by_hand():
    """Opening c = 0.5 rad under the mid-lid FPs; three upper-lid vertices at places whose opening is o = 1, 0.5, 0.5
    of it, with weights 1, 0.5 and 0.8 (a row behind the margin weighted above the margin's 0.5)."""
    from addon.deform import eyelids as lids

    rig = lids.EyelidRig(
        vertices=np.arange(3),
        eye=np.zeros(3, np.intp),
        upper=np.array([1.0, 0.5, 0.8]),
        lower=np.zeros(3),
        local=np.zeros((3, 3)),
        centres=np.zeros((2, 3)),
        rest_angles=np.array([[0.25, -0.25, 0.0], [0.25, -0.25, 0.0]]),
        axes=np.eye(3),
        meeting=np.array([1.0, 0.5, 0.5]),
    )
    d = MEET_CLEARANCE
    full = np.array([[-0.5, 0.0], [-0.5, 0.0]])  # the upper lid all the way down, the lower lid still
    up, low = lids.meet_lids(rig, full, rig.upper * -0.5, np.zeros(3))
    np.testing.assert_allclose(up, [-(0.5 - d), -(0.25 - d), -(0.25 - d)], atol=1e-15)  # the third: 0.4 before
    np.testing.assert_array_equal(low, 0.0)
    half = np.array([[-0.25, 0.25], [-0.25, 0.25]])  # both lids half way: each may come 0.5 o c toward the other
    up, _low = lids.meet_lids(rig, half, rig.upper * -0.25, np.zeros(3))
    np.testing.assert_allclose(up, [-(0.25 - d), -(0.125 - d), -(0.125 - d)], atol=1e-15)
    rising = np.array([[0.1, 0.0], [0.1, 0.0]])  # away from closure: nothing is stopped
    up, _low = lids.meet_lids(rig, rising, rig.upper * 0.1, np.zeros(3))
    np.testing.assert_allclose(up, rig.upper * 0.1, atol=0)


def test_meet_lids_stops_a_lid_where_the_skin_shows_the_other_lids_margin_by_hand():
    """Opening c = 0.5 rad under the mid-lid FPs; four upper-lid vertices whose place's opening (`meeting`) is 0.5 of
    it, as a painted lid's traced opening may say where the skin shows less: the other lid's margin, seen on the
    skin, lies 0.15, 0.3, 0.15 and -0.05 rad below them (`room`). The first is the upper lid's alone: stopped at the
    seen margin, not 0.25 rad down (before: the weights' opening, 0.25, the margin turned through the other lid); the
    second has room for the opening's stop; the third is skin both lids move, and the fourth lies past the other
    margin already: both keep the opening's stop."""
    from addon.deform import eyelids as lids

    rig = lids.EyelidRig(
        vertices=np.arange(4),
        eye=np.zeros(4, np.intp),
        upper=np.array([1.0, 1.0, 1.0, 1.0]),
        lower=np.array([0.0, 0.0, 0.2, 0.0]),
        local=np.zeros((4, 3)),
        centres=np.zeros((2, 3)),
        rest_angles=np.array([[0.25, -0.25, 0.0], [0.25, -0.25, 0.0]]),
        axes=np.eye(3),
        meeting=np.full(4, 0.5),
        room=lids.skin_stop_room(
            np.array([[0.15, 0.1], [0.3, 0.1], [0.15, 0.1], [-0.05, 0.1]]), np.ones(4), np.array([0.0, 0.0, 0.2, 0.0])
        ),
    )
    d = MEET_CLEARANCE
    full = np.array([[-0.5, 0.0], [-0.5, 0.0]])  # the upper lid all the way down, the lower lid still
    up, _low = lids.meet_lids(rig, full, rig.upper * -0.5, np.zeros(4))
    np.testing.assert_allclose(up, [-0.15, -(0.25 - d), -(0.25 - d), -(0.25 - d)], atol=1e-15)
    half = np.array([[-0.25, 0.25], [-0.25, 0.25]])  # the lower margin has come 0.5 o c = 0.125 rad up toward it
    up, _low = lids.meet_lids(rig, half, rig.upper * -0.25, np.zeros(4))
    np.testing.assert_allclose(up, [-(0.15 - 0.125), -(0.125 - d), -(0.125 - d), -(0.125 - d)], atol=1e-15)


def test_skin_stop_room_keeps_the_rows_the_stop_applies_to_by_hand():
    """The rows `meet_lids` stops by the skin are worked out once, at the bind: the room to the other lid's margin
    stays where the vertex is this lid's alone (the other lid's weight 0) and has room (above 0), NaN elsewhere (both
    lids' skin, skin past the other margin, no opening seen)."""
    from addon.deform import eyelids as lids

    room = np.array([[0.15, 0.1], [0.3, -0.2], [0.15, 0.1], [-0.05, 0.0], [np.nan, 0.2]])
    upper = np.array([1.0, 1.0, 1.0, 1.0, 0.0])
    lower = np.array([0.0, 0.0, 0.2, 0.0, 0.5])
    nan = np.nan
    expected = np.array([[0.15, nan], [0.3, nan], [nan, nan], [nan, nan], [nan, 0.2]])
    np.testing.assert_array_equal(lids.skin_stop_room(room, upper, lower), expected)


def _meet_lids_choosing_the_rows_each_frame(rig, turns, up, low):
    """`meet_lids` as it was before the rows of the skin's stop were chosen at the bind (each frame: the other lid's
    weight 0 and room above 0), for the equality below."""
    closure = np.maximum(rig.rest_angles[:, 0] - rig.rest_angles[:, 1], 1e-9)
    shares = (turns * np.array([-1.0, 1.0]) / closure[:, None])[rig.eye]
    opening = rig.meeting * closure[rig.eye]
    inside = opening > 0.0
    stop = (opening[:, None] * (1.0 - shares[:, ::-1]).clip(0.0) - MEET_CLEARANCE).clip(0.0)
    alone = np.stack([rig.lower <= 0.0, rig.upper <= 0.0], axis=1)
    seen = (rig.room - opening[:, None] * shares[:, ::-1].clip(0.0)).clip(0.0)
    with np.errstate(invalid="ignore"):
        stop = np.where(alone & (rig.room > 0.0), np.minimum(stop, seen), stop)
    up = np.where(inside & (up < 0.0), np.maximum(up, -stop[:, 0]), up)
    low = np.where(inside & (low > 0.0), np.minimum(low, stop[:, 1]), low)
    return up, low


@pytest.mark.parametrize("trace_opening", [True, False])
def test_meet_lids_with_the_rows_chosen_at_the_bind_is_bit_for_bit_as_before(trace_opening, monkeypatch):
    """The same stops, to the bit, as choosing the rows every frame from the whole room (bound again with
    `skin_stop_room` passing the room as it is, as the bind did before), on a bound rig (both lids, painted or made
    masks) over turns toward closure, away from it and past it."""
    from addon.deform import eyelids as lids

    triangles = _shell_triangles(len(REST), len(XS))
    radii = np.array([R_EYE, R_EYE])
    arguments = (REST, UPPER, LOWER, NEUTRAL, CENTRES, radii, AXES, triangles)
    rig = bind_eyelids(*arguments, trace_opening=trace_opening)
    with monkeypatch.context() as patch:
        patch.setattr(lids, "skin_stop_room", lambda room, _upper, _lower: room)
        whole = bind_eyelids(*arguments, trace_opening=trace_opening)
    assert np.isfinite(rig.room).any(axis=0).all() and np.isnan(rig.room).sum() > np.isnan(whole.room).sum()
    closure = UP0 - LOW0
    rng = np.random.default_rng(11)
    for _ in range(60):
        turns = np.stack([-rng.uniform(-0.2, 1.3, 2), rng.uniform(-0.2, 1.3, 2)], axis=1) * closure
        turn = turns[rig.eye]
        up, low = rig.upper * turn[:, 0], rig.lower * turn[:, 1]
        now = lids.meet_lids(rig, turns, up, low)
        before = _meet_lids_choosing_the_rows_each_frame(whole, turns, up, low)
        for a, b in zip(now, before, strict=True):
            np.testing.assert_array_equal(a, b)


def test_a_lid_whose_mask_is_blended_across_its_margin_closes_on_a_smooth_edge():
    """Lid masks blended across the margin, as decimation leaves them (the margin row 0.6 of the lid, 1 two rows
    out), at uneven spacing along the eye: a full blink brings each margin onto the other lid, along a smooth curve,
    no face turned over (before `margin_members` the margin stopped 0.6 of the way: up to 5 degrees open)."""
    xs = np.sort(np.concatenate([np.linspace(-0.0125, 0.0125, 26), np.random.default_rng(3).uniform(-0.012, 0.012, 9)]))
    rest, upper, lower, neutral, margins = _eye(xs, np.array([0.6, 0.85, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]))
    _closes_on_a_smooth_edge(xs, rest, upper, lower, neutral, margins, trace_opening=True)


def test_seen_edge_members_by_hand():
    """Five vertices along the eye: on the seen upper edge and part of the lid (made full), not on it, on it but no
    part of the lid (the mask's 0: left to the fold-free weights), on it but below the lower lid's seen margin, and
    on it and full already."""
    from addon.deform.eyelids import seen_edge_members

    rows = np.array([10, 11, 12, 13, 14])
    member = np.array([0.4, 0.4, 0.0, 0.5, 1.0])
    t = np.array([0.2, 0.4, 0.5, 0.6, 0.8])
    elev = np.array([0.1, 0.1, 0.1, -0.3, 0.1])
    seen = [(np.array([0.0, 1.0]), np.array([0.0, 0.0])), (np.array([0.0, 1.0]), np.array([-0.2, -0.2]))]
    out = seen_edge_members(rows, member, t, elev, np.array([10, 12, 13, 14, 99]), seen)
    np.testing.assert_array_equal(out, [1.0, 0.4, 0.0, 0.5, 1.0])


def test_trace_margins_leaves_the_hidden_vertices_to_the_next_lowest_member():
    """Two upper-lid members in a bin: the lower one picked, and with it hidden, the other; a bin whose only member is
    hidden picks none (the margin runs straight past it)."""
    from addon.deform.eyelids import trace_margins

    t = np.array([0.1, 0.12, 0.3, 0.5, 0.7, 0.9, 0.1, 0.3, 0.5, 0.7, 0.9])
    elev = np.array([0.2, 0.3, 0.25, 0.3, 0.25, 0.2, -0.2, -0.25, -0.3, -0.25, -0.2])
    upper = np.r_[np.ones(6), np.zeros(5)]
    lower = 1.0 - upper
    hidden = np.zeros((2, len(t)), bool)
    assert trace_margins(t, elev, upper, lower)[0][2][1] == 0  # t = 0.1: the lower of 0 and 1
    hidden[0, 0] = True
    assert trace_margins(t, elev, upper, lower, hidden)[0][2][1] == 1
    hidden[0, 3] = True
    picked = trace_margins(t, elev, upper, lower, hidden)[0][2]
    assert 3 not in picked and list(picked[picked >= 0]) == [1, 2, 4, 5]


def test_seen_picks_by_hand():
    """An upper lid whose front margin runs at 0.2 rad (vertices at x -10, -5, 0, 10 mm), a vertex of its back (a
    member of 0.5, nearer the eye's centre) at x 5 mm, 0.3 rad, where the margin's edge from 0 to 10 mm is the
    lowest skin; and a rim of neither lid hanging below the front from x -10 to -3 mm (0.1 rad at -3 mm). Picked for
    the upper margin: the back vertex is behind the lid's edge; the front vertex above the rim and the front vertex on
    the edge are not; made a member, the rim hides the front vertex above it."""
    from addon.deform.eyelids import seen_picks

    def at(x, angle, rho=0.015):
        return [x, rho * np.sin(angle), rho * np.cos(angle)]

    local = np.array(
        [at(-0.01, 0.2), at(-0.005, 0.2), at(0.0, 0.2), at(0.01, 0.2)]  # 0-3: the upper lid's front margin
        + [at(-0.01, 0.5), at(0.0, 0.5), at(0.01, 0.5)]  # 4-6: above it
        + [at(0.005, 0.3, 0.0135)]  # 7: the lid's back, nearer the centre
        + [at(-0.003, 0.1)]  # 8: a rim of neither lid below the front
        + [at(-0.01, -0.2), at(0.0, -0.2), at(0.01, -0.2), at(-0.01, -0.5), at(0.0, -0.5), at(0.01, -0.5)]  # lower
    )
    triangles = np.array(
        [[0, 1, 4], [1, 2, 5], [1, 5, 4], [2, 3, 6], [2, 6, 5], [2, 3, 7]]
        + [[0, 1, 8], [9, 10, 12], [10, 13, 12], [10, 11, 13], [11, 14, 13]]
    )
    corners = np.array([at(-0.012, 0.0), at(0.012, 0.0)])
    t = (local[:, 0] + 0.012) / 0.024
    elev = elevation(local, np.zeros(3))
    member = np.zeros((2, len(local)))
    member[0, :7], member[0, 7], member[1, 9:] = 1.0, 0.5, 1.0
    margins = [
        (np.r_[0.0, t[[1, 7, 3]], 1.0], np.zeros(5), np.array([-1, 1, 7, 3, -1])),
        (np.r_[0.0, t[[10]], 1.0], np.zeros(3), np.array([-1, 10, -1])),
    ]
    hidden = seen_picks(margins, t, elev, local, triangles, 0.012, corners, member)
    np.testing.assert_array_equal(np.flatnonzero(hidden[0]), [7])
    assert not hidden[1].any()
    member[0, 7] = member[0, 8] = 1.0  # the back a full member: behind the edge all the same; the rim a member
    hidden = seen_picks(margins, t, elev, local, triangles, 0.012, corners, member)
    np.testing.assert_array_equal(np.flatnonzero(hidden[0]), [1, 7])


def _shell_triangles(count: int, columns: int) -> np.ndarray:
    """The triangles of `_eye`'s `count` vertices: each lid's 8 rows of `columns`, two triangles per quad."""
    quads = [
        (
            base + r * columns + j,
            base + r * columns + j + 1,
            base + (r + 1) * columns + j + 1,
            base + (r + 1) * columns + j,
        )
        for base in range(0, count, 8 * columns)
        for r in range(7)
        for j in range(columns - 1)
    ]
    return np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])


def _closes_on_a_smooth_edge(xs, rest, upper, lower, neutral, margins, trace_opening, slack=2e-5):
    """A full blink of `_eye`'s lids (the upper mid-lid FPs turned onto the lower ones) brings each upper margin onto
    the lower lid all along the eye, no rougher than either margin at rest (`slack` m more), and turns no face
    over."""
    triangles = _shell_triangles(len(rest), len(xs))
    rig = bind_eyelids(
        rest, upper, lower, neutral, CENTRES, np.array([R_EYE, R_EYE]), AXES, triangles, trace_opening=trace_opening
    )
    fps = neutral.copy()
    for e, up in enumerate(("3.1", "3.2")):
        _turned_fp(fps, up, e, LOW0 - UP0)
    out = rest.copy()
    apply_eyelids(rig, out, fps)
    inside = np.abs(xs) < CORNER
    for eye in (0, 1):
        up = elevation(out[margins[(eye, 0)]], CENTRES[eye])
        low = elevation(out[margins[(eye, 1)]], CENTRES[eye])
        np.testing.assert_allclose(up[inside], low[inside] + MEET_CLEARANCE, atol=2 * TRACE)  # shut
        # smooth: no vertex of the closed margin farther off the curve through its neighbours than at rest, or than
        # the lower margin's, which it closes onto
        edge, other = margins[(eye, 0)][inside], margins[(eye, 1)][inside]
        at_rest = max(edge_roughness(rest, chain, closed=False).max() for chain in (edge, other))
        assert edge_roughness(out, edge, closed=False).max() < at_rest + slack
    chart_before = np.cross(
        rest[triangles[:, 1]] - rest[triangles[:, 0]], rest[triangles[:, 2]] - rest[triangles[:, 0]]
    )
    chart_after = np.cross(out[triangles[:, 1]] - out[triangles[:, 0]], out[triangles[:, 2]] - out[triangles[:, 0]])
    assert np.all(np.einsum("ij,ij->i", chart_before, chart_after) > 0.0)  # no face turned over


ONE_ROW = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # a lid mask that is its margin row alone (a decimated head's)


@pytest.mark.parametrize(
    ("shares", "one_row"),
    [
        (ONE_ROW, True),
        ((1.0, 1.0, 0.7, 0.0, 0.0, 0.0, 0.0, 0.0), False),
        ((0.6, 0.85, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0), False),
    ],
)
def test_a_lid_mask_of_its_margin_row_alone_is_one_row_deep(shares, one_row):
    """By hand on the shell eye: the upper lid's margin vertices' neighbours that climb farthest onto the lid are the
    next row's, members unless the mask is the margin row alone (a mask blended across the margin is still deep)."""
    rest, upper, _lower, _neutral, margins = _eye(shares=shares)
    neighbours = vertex_neighbours(_shell_triangles(len(rest), len(XS)), len(rest))
    for eye in (0, 1):
        margin = margins[(eye, 0)][INSIDE]
        assert one_row_deep(margin, neighbours, elevation(rest, CENTRES[eye]), upper, 1.0) is one_row


def test_vertex_neighbours_by_hand():
    indptr, indices = vertex_neighbours(np.array([[0, 1, 2], [2, 1, 3]]), 5)
    assert [sorted(indices[indptr[k] : indptr[k + 1]].tolist()) for k in range(5)] == [
        [1, 2],
        [0, 2, 3],
        [0, 1, 3],
        [1, 2],
        [],
    ]


def test_a_lid_one_row_deep_turns_the_rows_behind_its_margin_with_the_masks_made_from_the_fps():
    """Painted lid masks that are their margin row alone (as decimating a painted head leaves it): at a full
    blink its margin turned onto the lower lid and the next row stayed, so the face between them spanned the whole
    opening and more (51 degrees here; the decimated head's closed lid was one crumpled strip of such faces). Given
    the masks set-up would make from the FPs (`made_lids`), that lid turns by the larger of the two: the next row
    follows the margin down, the lids still shut along the eye, and no face turns over. A lid mask with rows behind
    its margin is left as painted (the sample's)."""
    rest, upper, lower, neutral, margins = _eye(shares=ONE_ROW)
    _rest, made_upper, made_lower, _neutral, _margins = _eye()
    triangles = _shell_triangles(len(rest), len(XS))
    radii = np.array([R_EYE, R_EYE])
    fps = neutral.copy()
    for e, up in enumerate(("3.1", "3.2")):
        _turned_fp(fps, up, e, LOW0 - UP0)
    spans = []
    for made in (None, (made_upper, made_lower)):
        made_lids = None if made is None else lambda made=made: made
        rig = bind_eyelids(rest, upper, lower, neutral, CENTRES, radii, AXES, triangles, made_lids=made_lids)
        out = rest.copy()
        apply_eyelids(rig, out, fps)
        for eye in (0, 1):
            up = elevation(out[margins[(eye, 0)]], CENTRES[eye])[INSIDE]
            low = elevation(out[margins[(eye, 1)]], CENTRES[eye])[INSIDE]
            np.testing.assert_allclose(up, low + MEET_CLEARANCE, atol=3 * TRACE)  # shut either way
        middle = margins[(0, 0)][len(XS) // 2]
        spans.append(np.degrees(np.diff(elevation(out[[middle, middle + len(XS)]], CENTRES[0]))[0]))
        before = np.cross(rest[triangles[:, 1]] - rest[triangles[:, 0]], rest[triangles[:, 2]] - rest[triangles[:, 0]])
        after = np.cross(out[triangles[:, 1]] - out[triangles[:, 0]], out[triangles[:, 2]] - out[triangles[:, 0]])
        assert np.all(np.einsum("ij,ij->i", before, after) > 0.0)
        assert rig.deepened == (() if made is None else ((0, 0), (0, 1), (1, 0), (1, 1)))  # both lids, both eyes
    row = np.degrees((np.radians(70.0) - UP0) / 7)  # the rows' spacing at rest in the middle
    assert spans[0] > 45.0  # the margin row alone: the next row left at rest
    assert spans[1] < 1.5 * row  # the next row turned with the margin
    # a lid with rows behind its margin keeps its own mask
    rest, upper, lower, neutral, _margins = _eye(shares=(1.0, 1.0, 0.7, 0.0, 0.0, 0.0, 0.0, 0.0))
    asked = []
    rig = bind_eyelids(
        rest,
        upper,
        lower,
        neutral,
        CENTRES,
        radii,
        AXES,
        triangles,
        made_lids=lambda: asked.append(1) or (made_upper, made_lower),
    )
    plain = bind_eyelids(rest, upper, lower, neutral, CENTRES, radii, AXES, triangles)
    assert rig.deepened == () and not asked  # not made at all: no lid needed them
    np.testing.assert_array_equal(rig.upper, plain.upper)


def test_lids_whose_masks_set_up_made_close_an_opening_fuller_than_the_sine_arch():
    """Lid masks made from the FPs (`trace_opening` False) on an eye whose opening is fuller toward the corners
    than a sine arch (s (2 - s), as a real eye's outer corner: 0.52 of the middle at 0.8 of the way out, the arch
    0.31): the opening the eye's centre sees between the skin's margins (`seen_margins`) gives each place
    along the eye its share of the turn, so a full blink shuts it all along. Before (the sine arch whatever the
    opening): up to 11 degrees open toward the corners."""
    rest, upper, lower, neutral, margins = _eye(fuller=True)
    # the opening is seen on PROFILE_BINS lines, linearly between them: the closed margin is 0.04 mm off smooth
    _closes_on_a_smooth_edge(XS, rest, upper, lower, neutral, margins, trace_opening=False, slack=5e-5)


def test_the_seen_margins_are_the_shells_margins_by_hand():
    """`_eye`'s margins lie on its shell at 25 * f(x) and -20 * f(x) degrees (f = s (2 - s), s the arch): the
    opening the eye's centre sees between the skin's triangles ends on them (within the chord between two of
    the margin's vertices), and meets at the corners' elevation (0). Past the eyeball's outline (a wider eye) no
    opening is seen: the margins meet there on the line between the corners."""
    rest, _upper, _lower, neutral, _margins = _eye(fuller=True)
    triangles = _shell_triangles(len(rest), len(XS))
    corners = neutral[[fp_index("3.11"), fp_index("3.7")]] - CENTRES[0]
    (ts, up, up_rows), (ts_low, low, _rows) = seen_margins(rest - CENTRES[0], triangles, R_EYE, corners)
    np.testing.assert_array_equal(ts, ts_low)
    x = corners[0, 0] + ts * (corners[1, 0] - corners[0, 0])
    s = _opening_shape(lid_profile(x, -CORNER, 0.0, CORNER), True)
    np.testing.assert_allclose(up, UP0 * s, atol=0.02)
    np.testing.assert_allclose(low, LOW0 * s, atol=0.02)
    assert up[0] == low[0] == up[-1] == low[-1] == 0.0
    np.testing.assert_array_equal(up_rows, -1)  # no vertex picked: the margins are where the skin ends
    wide = neutral[[fp_index("3.11"), fp_index("3.7")]] - CENTRES[0]
    wide[:, 0] *= 1.5  # corners at 16.5 mm: past the 12 mm eyeball on either side, nothing is open
    ts, up, _rows = seen_margins(rest - CENTRES[0], triangles, R_EYE, wide)[0]
    x = wide[0, 0] + ts * (wide[1, 0] - wide[0, 0])
    assert np.all(up[np.abs(x) >= R_EYE] == 0.0) and np.all(up[np.abs(x) < 0.9 * CORNER] > 0.0)


def test_seen_margins_run_straight_from_a_corner_across_the_skin_that_fills_it():
    """A patch of skin behind the inner corner (a caruncle, 0.5 mm off the eyeball, from the corner 3 mm in) fills the
    first three lines: they see no opening, and their margins run straight from the corner to the first line that
    sees one, for both lids; every other line is as without the patch. Before, those lines counted as shut (the
    margins on the corners' line), and the turn stepped from none to most across them."""
    rest, _upper, _lower, neutral, _margins = _eye(fuller=True)
    triangles = _shell_triangles(len(rest), len(XS))
    corners = neutral[[fp_index("3.11"), fp_index("3.7")]] - CENTRES[0]
    plain = seen_margins(rest - CENTRES[0], triangles, R_EYE, corners)
    x0, x1 = corners[0, 0] - 0.0005, corners[0, 0] + 0.003
    patch = [_on_shell(CENTRES[0], x, np.radians(a), 0.0125) for x in (x0, x1) for a in (-30.0, 30.0)]
    n = len(rest)
    filled = seen_margins(
        np.concatenate([rest, patch]) - CENTRES[0],
        np.concatenate([triangles, [[n, n + 2, n + 3], [n, n + 3, n + 1]]]),
        R_EYE,
        corners,
    )
    ts = plain[0][0]
    hidden = (corners[0, 0] + ts * (corners[1, 0] - corners[0, 0]) < x1) & (ts > 0.0)
    first = np.flatnonzero(hidden)[-1] + 1  # the first line that sees the opening
    assert hidden.sum() == 3
    for (_ts, seen, _rows), (_ts, bare, _rows) in zip(filled, plain, strict=True):
        np.testing.assert_allclose(seen[~hidden], bare[~hidden], atol=1e-12)
        np.testing.assert_allclose(seen[: first + 1], bare[first] * ts[: first + 1] / ts[first], atol=1e-12)
        assert np.all(np.abs(seen[hidden]) > 0.0)


def test_the_seen_margin_points_lie_on_the_shells_margins():
    """`seen_margin_points` are points of the skin on the margins `seen_margins` finds: on `_eye`'s shell, each lies on
    the chord between two neighbouring margin vertices (the triangle's edge the line crosses), on its line's x and
    at the elevation `seen_margins` gives there (within the chord's bend, 1e-3 rad: the chart's elevation is
    interpolated along the edge), weights on the triangle summing to 1; one per line that sees an opening. The lids'
    edge followed through a deformation by them is the margin itself, evenly along the eye, whatever vertices lie
    nearest the line through the lid FPs (the sample's inner corners: a vertex 1.1 mm above the margin read as the
    edge, 0.88 mm off smooth at the blink)."""
    rest, _upper, _lower, neutral, margins = _eye(fuller=True)
    triangles = _shell_triangles(len(rest), len(XS))
    local = rest - CENTRES[0]
    corners = neutral[[fp_index("3.11"), fp_index("3.7")]] - CENTRES[0]
    found = seen_margins(local, triangles, R_EYE, corners)
    ids, weights = seen_margin_points(local, triangles, R_EYE, corners)
    seen = found[0][1] != 0.0  # the lines that see an opening (the margins meet at 0 elsewhere)
    assert ids.shape == weights.shape == (2, int(seen.sum()), 3)
    np.testing.assert_allclose(weights.sum(axis=2), 1.0, atol=1e-12)
    assert np.all(weights >= -1e-12)
    for side in (0, 1):
        points = np.einsum("pk,pkc->pc", weights[side], local[ids[side]])
        x = corners[0, 0] + found[side][0][seen] * (corners[1, 0] - corners[0, 0])
        np.testing.assert_allclose(points[:, 0], x, atol=1e-12)
        np.testing.assert_allclose(elevation(points, np.zeros(3)), found[side][1][seen], atol=1e-3)
        chain = local[margins[(0, side)]]
        for p in points:  # on the polyline through the margin's vertices
            a, b = chain[:-1], chain[1:]
            u = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0.0, 1.0)
            assert np.linalg.norm(a + u[:, None] * (b - a) - p, axis=1).min() < 1e-12


def test_an_eye_shut_in_the_skin_does_not_turn_its_lids_through_each_other():
    """Lid masks made from the FPs on an eye whose skin is shut across it at rest (a strip of faces joining the two
    margins, as a scan of closed eyes has it) with the lid FPs placed apart: the eye's centre sees no opening
    (`seen_margins` None), so the lids have nowhere to close to and a full blink leaves the skin where it is. Before,
    the sine arch turned the upper lid down through the shut skin (the Lee Perry-Smith scan: up to 150 crossing
    pairs at the demo's blink)."""
    rest, upper, lower, neutral, margins = _eye()
    triangles = _shell_triangles(len(rest), len(XS))
    strip = []
    for eye in (0, 1):
        up, low = margins[(eye, 0)], margins[(eye, 1)]
        strip += [t for j in range(len(XS) - 1) for t in ((up[j], low[j + 1], up[j + 1]), (up[j], low[j], low[j + 1]))]
    triangles = np.concatenate([triangles, strip])
    assert (
        seen_margins(rest - CENTRES[0], triangles, R_EYE, neutral[[fp_index("3.11"), fp_index("3.7")]] - CENTRES[0])
        is None
    )
    rig = bind_eyelids(rest, upper, lower, neutral, CENTRES, np.array([R_EYE, R_EYE]), AXES, triangles, False)
    fps = neutral.copy()
    for e, up in enumerate(("3.1", "3.2")):
        _turned_fp(fps, up, e, LOW0 - UP0)
    out = rest.copy()
    apply_eyelids(rig, out, fps)
    np.testing.assert_array_equal(out, rest)
