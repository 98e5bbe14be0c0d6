"""The membranes, the jaw's share and the fall-off profile `scripts.bench.arkit_spread` measures, on hand-worked
meshes (metres; a flat grid of right triangles, where the cotangent Laplacian reproduces linear functions)."""

import numpy as np

from scripts.bench.arkit_spread import (
    MANDIBLE_FPS,
    carried_by,
    cotangent_laplacian,
    extend_share,
    membrane,
    mixed_motion,
    reach_profile,
    rig_weight,
    spread_key,
    turn_about_x,
    vertex_areas,
)


def grid(columns: int = 11, rows: int = 3, step: float = 0.001):
    """A flat strip in the xy plane: (columns * rows, 3) points, x = column * step, and its right triangles."""
    x, y = np.meshgrid(np.arange(columns) * step, np.arange(rows) * step)
    points = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    index = np.arange(columns * rows).reshape(rows, columns)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
    return points, np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])


def test_the_harmonic_membrane_between_a_moved_edge_and_an_anchored_one_is_linear():
    points, triangles = grid()
    column = np.round(points[:, 0] / 0.001).astype(int)
    offsets = np.zeros_like(points)
    offsets[:, 2] = 0.004  # the key lifts the strip's first column 4 mm
    moved = membrane(cotangent_laplacian(points, triangles), offsets, column == 0, column == 10)
    assert np.allclose(moved[:, 2], 0.004 * (1.0 - column / 10.0), atol=1e-12)
    assert np.allclose(moved[:, :2], 0.0)


def test_the_screened_membrane_dies_out_faster_and_stays_positive():
    points, triangles = grid()
    column = np.round(points[:, 0] / 0.001).astype(int)
    offsets = np.zeros_like(points)
    offsets[:, 2] = 0.004
    laplacian = cotangent_laplacian(points, triangles)
    screened = membrane(laplacian, offsets, column == 0, column == 10, vertex_areas(points, triangles), ell=0.002)
    inner = (column > 0) & (column < 10)
    assert np.all(screened[inner, 2] > 0.0)
    assert np.all(screened[inner, 2] < 0.004 * (1.0 - column[inner] / 10.0))
    assert np.all(np.diff(screened[points[:, 1] == 0.0, 2]) < 0.0)  # falls all the way along


def test_vertex_areas_share_each_triangle_in_thirds():
    points, triangles = grid(columns=3, rows=2)
    assert np.isclose(vertex_areas(points, triangles).sum(), 0.002 * 0.001)


def test_spread_key_never_takes_motion_away_and_leaves_the_skull_s_skin():
    points, triangles = grid()
    column = np.round(points[:, 0] / 0.001).astype(int)
    key = np.zeros_like(points)
    key[column <= 2, 2] = 0.004  # the engine moves three columns and stops
    key[column == 3, 2] = 0.0005
    free = column <= 8  # the last two columns are fixed to the skull
    spread = spread_key(cotangent_laplacian(points, triangles), key, free, share=0.0)
    assert np.all(np.linalg.norm(spread, axis=1) >= np.linalg.norm(key, axis=1) - 1e-15)
    assert np.allclose(spread[~free], key[~free])
    # beyond the engine's reach (columns 4-8) the membrane falls from column 3's motion to the anchors at column 9
    assert np.all(spread[(column >= 4) & free, 2] > 0.0)
    assert np.allclose(spread[column == 4, 2], 0.0005 * 5.0 / 6.0)


def test_the_jaw_share_membrane_fills_only_what_the_engine_leaves_or_the_larger_share():
    points, triangles = grid()
    column = np.round(points[:, 0] / 0.001).astype(int)
    laplacian = cotangent_laplacian(points, triangles)
    share = np.where(column <= 1, 1.0, np.where(column == 2, 0.2, 0.0))  # the engine: two columns wholly, one at 0.2
    free = column <= 6  # the mandible's skin; the rest is the skull's
    beyond = extend_share(laplacian, share, free)
    assert np.array_equal(beyond[column <= 2], share[column <= 2])  # the engine's shares kept
    assert np.allclose(beyond[column == 3], 0.2 * 4.0 / 5.0)  # from column 2's 0.2 down to the anchors at 7
    assert np.all(beyond[column >= 7] == 0.0)
    wholly = extend_share(laplacian, share, free, wholly=True)
    # from the wholly carried column 1 to the anchors at column 7: 5/6 at column 2, above the engine's 0.2
    assert np.allclose(wholly[column == 2], 5.0 / 6.0)
    assert np.all(wholly >= share)
    assert np.all(wholly[column >= 7] == 0.0)


def test_reach_profile_bins_the_motion_by_distance_from_the_moving_feature_point():
    rest = np.array([[0.0, 0.0, 0.0], [0.002, 0.0, 0.0], [0.012, 0.0, 0.0], [0.05, 0.0, 0.0]])
    control = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]])
    generated = np.zeros((4, 3))
    generated[[0, 1, 2], 2] = [0.003, 0.002, 0.0005]  # the FP at 0 moves, the one at 50 mm stays
    sculpted = np.zeros((4, 3))
    sculpted[[0, 1, 2], 2] = [0.003, 0.002, 0.001]
    profile = reach_profile([(generated, sculpted)], rest, control)
    assert np.isclose(profile["key_over_sculpt"][0], 1.0)  # 0-5 mm: as far as the sculpt
    assert np.isclose(profile["key_over_sculpt"][2], 0.5)  # 10-15 mm: half
    assert np.isclose(profile["sculpt_share"][0], 5.0 / 6.0)
    assert np.isclose(profile["error_share"][2], 1.0)  # all the error lies 12 mm out


def test_a_jaw_turn_takes_the_front_down_and_back():
    # a point 1 m in front of (-y) the pivot, turned 90 degrees, ends 1 m below it
    offset = turn_about_x(np.array([[0.0, -1.0, 0.0]]), np.zeros(3), 90.0)
    assert np.allclose(offset, [[0.0, 1.0, -1.0]])


def test_rig_weights_sum_over_the_bones_a_turn_carries():
    rig = {"jaw": {"parent": "head"}, "lip": {"parent": "jaw"}, "tip": {"parent": "lip"}, "nose": {"parent": "head"}}
    assert sorted(carried_by(rig, "jaw")) == ["jaw", "lip", "tip"]
    weights = {"jaw": [[5, 0.5]], "lip": [[5, 0.25], [7, 1.0]], "nose": [[7, 1.0]]}
    # the head's vertices are base-mesh vertices 7, 5 and 9
    assert np.allclose(rig_weight(weights, carried_by(rig, "jaw"), np.array([7, 5, 9])), [1.0, 0.75, 0.0])


def test_the_mandible_s_feature_points_are_the_jaw_riders_on_the_skin_and_the_jaw_s_angles():
    assert {"2.1", "2.13", "2.14", "2.10", "8.2", "2.4", "5.1"} <= set(MANDIBLE_FPS)
    assert not {"9.11", "6.1", "8.1", "2.2", "5.3"} & set(MANDIBLE_FPS)  # teeth, tongue, upper lip, cheek bone


def test_mixed_motion_takes_the_sculpt_s_motion_where_asked():
    ours = np.array([[0.0, 0.0, 0.002], [0.0, 0.0, 0.0001], [0.0, 0.0, 0.0]])  # one moved FP, two held (< 0.5 mm)
    sculpt = np.array([[0.0, 0.0, 0.003], [0.0, 0.001, 0.0], [0.0, 0.0, -0.001]])
    assert np.array_equal(mixed_motion(ours, sculpt, "none"), ours)
    assert np.array_equal(mixed_motion(ours, sculpt, "all"), sculpt)
    assert np.array_equal(mixed_motion(ours, sculpt, "held"), [ours[0], sculpt[1], sculpt[2]])
    assert np.array_equal(mixed_motion(ours, sculpt, "moved"), [sculpt[0], ours[1], ours[2]])
