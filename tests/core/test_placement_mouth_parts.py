"""Teeth and tongue points read off their pieces (`mouth_parts`): the teeth pieces told apart by height, the
ends on the mid-plane at the front of each, a single piece given to the pair whose estimates are nearer its
ends; the tongue's tip by the sample's rule on the piece the estimate of 6.2 reached, its middle and borders
carried from their estimates with the tip."""

import numpy as np

from addon.mpeg4.feature_points import fp_index
from addon.placement.mouth_parts import READ_CONFIDENCE, TONGUE, mouth_ends, teeth_ends, tongue_points
from addon.placement.pipeline import LOW_CONFIDENCE
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.symmetry import MidPlane

PLANE = MidPlane(np.array([1.0, 0.0, 0.0]), 0.0)


def _row(bottom: float, top: float) -> np.ndarray:
    """A row of teeth as a grid of points: 4 cm wide (4 mm apart), 1 cm deep (front at y = -0.05)."""
    x, y, z = np.meshgrid(np.linspace(-0.02, 0.02, 11), np.linspace(-0.05, -0.04, 6), np.linspace(bottom, top, 11))
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


UPPER, LOWER = _row(0.0005, 0.0105), _row(-0.0105, -0.0005)
NO_TRIANGLES = np.zeros((0, 3), dtype=np.int64)


def _tongue(n=48):
    """An ellipsoid tongue: 4 cm wide, 7 cm long (tip at y = -0.07), 2.4 cm thick, centred at (0, -0.035, 0)."""
    theta, phi = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 2 * n, endpoint=False))
    unit = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
    vertices = unit * [0.02, 0.035, 0.012] + [0.0, -0.035, 0.0]
    index = np.arange(len(vertices)).reshape(2 * n, n)
    a, b = index, np.roll(index, -1, axis=0)
    quads = np.stack([a[:, :-1], b[:, :-1], b[:, 1:], a[:, 1:]], -1).reshape(-1, 4)
    return vertices, np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


TONGUE_TRUTH = np.array([[0.0, -0.07, 0.0], [0.0, -0.035, 0.012], [0.02, -0.035, 0.0], [-0.02, -0.035, 0.0]])


def test_the_ends_are_the_top_and_bottom_of_the_front_on_the_mid_plane():
    top, bottom = teeth_ends(UPPER, PLANE, TEMPLATE_AXES[1], TEMPLATE_AXES[2])
    assert np.allclose(top, [0.0, -0.05, 0.0105]) and np.allclose(bottom, [0.0, -0.05, 0.0005])
    assert teeth_ends(UPPER + [0.05, 0.0, 0.0], PLANE, TEMPLATE_AXES[1], TEMPLATE_AXES[2]) is None


def test_closed_teeth_the_upper_points_go_on_the_higher_piece_whichever_their_estimates_reached():
    placed = np.zeros((84, 3))
    # with the teeth closed the upper edge's estimate reached the lower teeth first
    reached = {"9.8": 0, "9.10": 1, "9.11": 1, "9.9": 1}
    on_piece, _read = mouth_ends(
        placed, placed.copy(), reached, [(UPPER, NO_TRIANGLES), (LOWER, NO_TRIANGLES)], PLANE, TEMPLATE_AXES
    )
    assert on_piece == {"9.8", "9.9", "9.10", "9.11"}
    assert np.allclose(placed[fp_index("9.8")], [0.0, -0.05, 0.0105])
    assert np.allclose(placed[fp_index("9.10")], [0.0, -0.05, 0.0005])
    assert np.allclose(placed[fp_index("9.11")], [0.0, -0.05, -0.0005])
    assert np.allclose(placed[fp_index("9.9")], [0.0, -0.05, -0.0105])


def test_one_piece_goes_to_the_pair_whose_estimates_are_nearer_its_ends():
    estimates = np.zeros((84, 3))
    estimates[fp_index("9.8")], estimates[fp_index("9.10")] = [0, -0.05, 0.012], [0, -0.05, 0.001]
    estimates[fp_index("9.11")], estimates[fp_index("9.9")] = [0, -0.05, -0.001], [0, -0.05, -0.012]
    placed = estimates.copy()
    reached = {"9.10": 0, "9.11": 0}  # both biting edges reached the only piece, the lower teeth
    on_piece, read = mouth_ends(placed, estimates, reached, [(LOWER, NO_TRIANGLES)], PLANE, TEMPLATE_AXES)
    assert on_piece == {"9.10", "9.11", "9.9"}  # 9.8 stays an estimate
    assert read == {"9.11", "9.9"}  # 9.10 only snapped onto the lower teeth: its confidence stays the fit's
    assert np.allclose(placed[fp_index("9.11")], [0.0, -0.05, -0.0005])
    assert np.allclose(placed[fp_index("9.9")], [0.0, -0.05, -0.0105])
    assert np.allclose(placed[fp_index("9.8")], estimates[fp_index("9.8")])


def test_the_tongue_points_are_its_tip_and_the_others_estimates_moved_with_it():
    estimates = TONGUE_TRUTH + [0.001, 0.008, -0.002]  # all four 8 mm off together
    found = tongue_points(*_tongue(), PLANE, TEMPLATE_AXES, estimates)
    assert np.abs(found - TONGUE_TRUTH).max() < 0.0006


def test_the_tongue_middle_keeps_its_estimates_offset_from_the_tip_on_the_piece():
    """6.2 estimated 5 mm behind the middle of the length stays 5 mm behind it (no rule moves it along the
    tongue), on the tongue's top: (0, -0.04, 0.012 sqrt(1 - (5 / 35)^2)) = (0, -0.04, 0.011877)."""
    estimates = TONGUE_TRUTH + [0.0, 0.01, 0.0]
    estimates[1] += [0.0, -0.005, 0.0]
    found = tongue_points(*_tongue(), PLANE, TEMPLATE_AXES, estimates)
    assert np.abs(found[0] - TONGUE_TRUTH[0]).max() < 0.0006
    assert np.abs(found[1] - [0.0, -0.04, 0.011877]).max() < 0.0006
    assert np.abs(found[2:] - TONGUE_TRUTH[2:]).max() < 0.0006


def test_the_tongue_points_go_on_the_piece_the_estimate_of_its_centre_reached():
    estimates = np.zeros((84, 3))
    estimates[[fp_index(f) for f in TONGUE]] = TONGUE_TRUTH + [0.0, 0.006, -0.003]  # the estimates 7 mm off
    placed = estimates.copy()
    reached = {"6.1": 0, "6.2": 0, "9.11": 1}
    on_piece, _read = mouth_ends(placed, estimates, reached, [_tongue(), (LOWER, NO_TRIANGLES)], PLANE, TEMPLATE_AXES)
    assert set(TONGUE) <= on_piece
    assert np.abs(placed[[fp_index(f) for f in TONGUE]] - TONGUE_TRUTH).max() < 0.0006


def test_a_teeth_piece_no_estimate_reached_is_found_by_its_ends():
    estimates = np.zeros((84, 3))
    estimates[fp_index("9.8")] = [0.0, -0.05, 0.018]  # 7.5 mm above the upper teeth's top: out of snapping reach
    estimates[fp_index("9.10")], estimates[fp_index("9.11")] = [0, -0.05, -0.001], [0, -0.05, -0.001]
    estimates[fp_index("9.9")] = [0.0, -0.05, -0.011]
    placed = estimates.copy()
    reached = {"9.10": 1, "9.11": 1, "9.9": 1}  # a closed bite: every estimate that snapped took the lower teeth
    pieces = [(UPPER, NO_TRIANGLES), (LOWER, NO_TRIANGLES)]
    on_piece, _read = mouth_ends(placed, estimates, reached, pieces, PLANE, TEMPLATE_AXES)
    assert on_piece == {"9.8", "9.9", "9.10", "9.11"}
    assert np.allclose(placed[fp_index("9.8")], [0.0, -0.05, 0.0105])
    assert np.allclose(placed[fp_index("9.10")], [0.0, -0.05, 0.0005])


def test_the_piece_the_estimate_of_6_2_reached_is_the_tongue_not_teeth():
    estimates = np.zeros((84, 3))
    estimates[[fp_index(f) for f in TONGUE]] = TONGUE_TRUTH + [0.0, 0.006, -0.003]
    estimates[fp_index("9.11")] = TONGUE_TRUTH[0] + [0.0, -0.004, 0.0]  # a lower tooth's estimate near the tip
    placed = estimates.copy()
    reached = {"6.2": 0, "9.11": 0}
    on_piece, read = mouth_ends(placed, estimates, reached, [_tongue()], PLANE, TEMPLATE_AXES)
    assert set(TONGUE) <= on_piece
    assert set(TONGUE) <= read
    assert np.abs(placed[[fp_index(f) for f in TONGUE]] - TONGUE_TRUTH).max() < 0.0006
    assert np.allclose(placed[fp_index("9.11")], estimates[fp_index("9.11")])


def test_with_both_rows_reached_no_other_piece_near_the_estimates_is_taken_for_teeth():
    estimates = np.zeros((84, 3))
    for fp_id, height in (("9.8", 0.0105), ("9.10", 0.0005), ("9.11", -0.0005), ("9.9", -0.0105)):
        estimates[fp_index(fp_id)] = [0.0, -0.05, height]
    placed = estimates.copy()
    floor = LOWER - [0.0, 0.0, 0.004]  # a piece under the lower teeth (the mouth's floor), as near the estimates
    reached = {"9.8": 0, "9.9": 1}
    pieces = [(UPPER, NO_TRIANGLES), (LOWER, NO_TRIANGLES), (floor, NO_TRIANGLES)]
    _on, _read = mouth_ends(placed, estimates, reached, pieces, PLANE, TEMPLATE_AXES)
    assert np.allclose(placed[fp_index("9.11")], [0.0, -0.05, -0.0005])
    assert np.allclose(placed[fp_index("9.9")], [0.0, -0.05, -0.0105])


def test_points_read_off_a_piece_get_their_definitions_confidence():
    """The teeth ends and the tongue tip (extremes of their piece) are the surest; 6.2-6.4, carried from the
    tip by the shape the skin predicts, less so but not listed."""
    assert all(READ_CONFIDENCE[f] == 0.9 for f in ("9.8", "9.9", "9.10", "9.11", "6.1"))
    assert all(LOW_CONFIDENCE < READ_CONFIDENCE[f] < 0.9 for f in ("6.2", "6.3", "6.4"))
