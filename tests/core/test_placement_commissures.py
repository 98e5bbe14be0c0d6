"""A welded mouth's height from its corners' pits (`placement.commissures`): on a hand-made face (a sheet curving
back towards the cheeks, with a pit 2 mm deep at each mouth corner) a mouth carried 3 mm too high is moved down
to the pits' height as a whole, each point by the same amount and back on the skin; a sheet without pits, or
pits further from the carried corners than the reach, moves nothing."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import FP_IDS, fp_index
from addon.placement.commissures import MOUTH, REACH, commissure, mouth_height
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.surface import Surface

MM = 0.001
CORNER_X = 25 * MM  # the pits' distance from the mid-plane
PIT_DEPTH, PIT_WIDTH = 2 * MM, 2.5 * MM  # a Gaussian dent


def _forward(x, z, pits: bool = True):
    """How far forward the skin is at (x, z): a face curving back to the sides and up and down, and the pits."""
    depth = -8.0 * x * x - 4.0 * z * z
    if pits:
        for cx in (CORNER_X, -CORNER_X):
            depth = depth - PIT_DEPTH * np.exp(-((x - cx) ** 2 + z * z) / (2 * PIT_WIDTH**2))
    return depth


def _face(pits: bool = True) -> Surface:
    """The sheet as triangles in the template's frame (left +x, up +z, forward -y), 0.5 mm apart."""
    xs, zs = np.linspace(-0.045, 0.045, 181), np.linspace(-0.03, 0.03, 121)
    gx, gz = np.meshgrid(xs, zs, indexing="ij")
    vertices = np.column_stack([gx.ravel(), -_forward(gx, gz, pits).ravel(), gz.ravel()])
    n = len(zs)
    triangles = []
    for i in range(len(xs) - 1):
        for k in range(n - 1):
            a, b = i * n + k, i * n + k + 1
            triangles += [(a, a + n, b), (b, a + n, b + n)]  # facing forward (-y)
    return Surface(vertices, np.array(triangles))


def _carried(high: float) -> np.ndarray:
    """Every FP on the sheet; the mouth's `high` above where the pits put it: the corners beside the pits (1 mm
    further out), the lip points spread between them above and below the mouth's line."""
    points = np.zeros((84, 3))
    k = np.arange(len(FP_IDS))
    points[:, 0], points[:, 2] = 0.03 * np.cos(k), 0.02 * np.sin(k)  # the rest of the face, anywhere on the sheet
    for k, fp_id in enumerate(MOUTH):
        x = CORNER_X * (k % 5 - 2) / 2.0
        points[fp_index(fp_id)] = (x, 0.0, (4 if k % 2 else -4) * MM)
    points[fp_index("2.4")] = (CORNER_X + 1 * MM, 0.0, 0.0)
    points[fp_index("2.5")] = (-CORNER_X - 1 * MM, 0.0, 0.0)
    points[:, 2] += np.isin(np.arange(84), [fp_index(i) for i in MOUTH]) * high
    points[:, 1] = -_forward(points[:, 0], points[:, 2])  # on the sheet (between its vertices, within 1e-6 m)
    return points


def test_the_pit_is_found_at_the_corner():
    surface = _face()
    x, z = CORNER_X + 2 * MM, 2 * MM
    pit = commissure(surface, np.array([x, -_forward(x, z), z]))
    assert pit is not None
    np.testing.assert_allclose(pit[[0, 2]], [CORNER_X, 0.0], atol=0.4 * MM)


def test_a_mouth_carried_high_is_moved_down_to_its_corners_pits():
    surface = _face()
    carried = _carried(3 * MM)
    placed, shift = mouth_height(carried, surface, TEMPLATE_AXES[1])
    assert shift == pytest.approx(-3 * MM, abs=0.4 * MM)
    mouth = [fp_index(i) for i in MOUTH]
    for row in (fp_index("2.4"), fp_index("2.5")):
        assert abs(placed[row, 2]) < 0.4 * MM  # at the pits' height
    # the mouth moved as a whole, down by the shift (the snap back onto the skin moves a point near a pit along
    # the pit's sloping normal by a few tenths), and is back on the skin
    np.testing.assert_allclose(placed[mouth, 2] - carried[mouth, 2], shift, atol=0.4 * MM)
    on_skin, _n = surface.closest(placed[mouth])
    np.testing.assert_allclose(placed[mouth], on_skin, atol=1e-9)
    others = np.setdiff1d(np.arange(84), mouth)
    np.testing.assert_array_equal(placed[others], carried[others])
    # mirror images stay mirror images: the same shift on both sides
    assert placed[fp_index("2.4"), 2] == pytest.approx(placed[fp_index("2.5"), 2], abs=0.01 * MM)


def test_no_pit_no_move():
    surface = _face(pits=False)
    carried = _carried(3 * MM)
    placed, shift = mouth_height(carried, surface, TEMPLATE_AXES[1])
    assert shift is None
    np.testing.assert_array_equal(placed, carried)


def test_a_pit_beyond_the_reach_moves_nothing():
    surface = _face()
    carried = _carried(1.2 * REACH)  # the deepest skin looked at lies at the looked-at ball's edge
    placed, shift = mouth_height(carried, surface, TEMPLATE_AXES[1])
    assert shift is None
    np.testing.assert_array_equal(placed, carried)
