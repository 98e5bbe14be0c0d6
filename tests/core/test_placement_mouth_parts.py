"""Teeth points read off the teeth pieces (`mouth_parts`): the pieces told apart by height, the ends on the
mid-plane at the front of each, a single piece given to the pair whose estimates are nearer its ends."""

import numpy as np

from addon.mpeg4.feature_points import fp_index
from addon.placement.mouth_parts import mouth_ends, teeth_ends
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.symmetry import MidPlane

PLANE = MidPlane(np.array([1.0, 0.0, 0.0]), 0.0)


def _row(bottom: float, top: float) -> np.ndarray:
    """A row of teeth as a grid of points: 4 cm wide (4 mm apart), 1 cm deep (front at y = -0.05)."""
    x, y, z = np.meshgrid(np.linspace(-0.02, 0.02, 11), np.linspace(-0.05, -0.04, 6), np.linspace(bottom, top, 11))
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


UPPER, LOWER = _row(0.0005, 0.0105), _row(-0.0105, -0.0005)


def test_the_ends_are_the_top_and_bottom_of_the_front_on_the_mid_plane():
    top, bottom = teeth_ends(UPPER, PLANE, TEMPLATE_AXES[1], TEMPLATE_AXES[2])
    assert np.allclose(top, [0.0, -0.05, 0.0105]) and np.allclose(bottom, [0.0, -0.05, 0.0005])
    assert teeth_ends(UPPER + [0.05, 0.0, 0.0], PLANE, TEMPLATE_AXES[1], TEMPLATE_AXES[2]) is None


def test_closed_teeth_the_upper_points_go_on_the_higher_piece_whichever_their_estimates_reached():
    placed = np.zeros((84, 3))
    # with the teeth closed the upper edge's estimate reached the lower teeth first
    reached = {"9.8": 0, "9.10": 1, "9.11": 1, "9.9": 1}
    on_piece = mouth_ends(placed, placed.copy(), reached, [UPPER, LOWER], PLANE, TEMPLATE_AXES)
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
    on_piece = mouth_ends(placed, estimates, reached, [LOWER], PLANE, TEMPLATE_AXES)
    assert on_piece == {"9.10", "9.11", "9.9"}  # 9.8 stays an estimate
    assert np.allclose(placed[fp_index("9.11")], [0.0, -0.05, -0.0005])
    assert np.allclose(placed[fp_index("9.9")], [0.0, -0.05, -0.0105])
    assert np.allclose(placed[fp_index("9.8")], estimates[fp_index("9.8")])
