"""The subnasale 9.15 read off the skin's mid-plane section by the sample's rule (`subnasale`): on a
hand-made profile the corner furthest inside the chord 9.3-8.1 (a notch next to the nose, which an outline
seen from the ears drops), however the head is turned; a piece behind the lip (the mouth's inside) not
taken; the sample head's own 9.15 back from its mesh."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import fp_index
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.subnasale import subnasale
from addon.placement.template import load_template

# a mid-line profile (forward, up) in metres: forehead, nose tip, the columella's underside, the corner,
# the upper lip, its middle, the chin; the corner (0.128, -0.014) lies 10.6 mm inside the chord tip-lip,
# its neighbours 6.5 and 7.6 mm
PROFILE = [(0.10, 0.06), (0.15, 0.0), (0.14, -0.008), (0.128, -0.014), (0.135, -0.022), (0.145, -0.032), (0.12, -0.07)]
CORNER = 3


def _ribbon():
    """The profile extruded 1 cm to each side of the mid-plane (x = 0), as triangles; in the template's
    frame (left +x, up +z, forward -y)."""
    section = np.array([(0.0, -f, u) for f, u in PROFILE])
    vertices = np.vstack([section + (-0.01, 0.0, 0.0), section + (0.01, 0.0, 0.0)])
    n = len(PROFILE)
    triangles = []
    for k in range(n - 1):
        triangles += [(k, k + 1, n + k), (k + 1, n + k + 1, n + k)]
    return vertices, np.array(triangles)


def _points():
    points = np.zeros((84, 3))  # the ears' mean at the origin, behind the face
    for k in range(1, 11):
        points[fp_index(f"10.{k}")] = ((-1) ** k * 0.07, 0.0, 0.0)
    points[fp_index("9.3")] = (0.0, -0.15, 0.0)
    points[fp_index("8.1")] = (0.0, -0.145, -0.032)
    points[fp_index("9.15")] = (0.0, -0.14, -0.02)  # a carried guess off the corner
    return points


def _turn(degrees: float) -> np.ndarray:
    """A turn about the axis (1, 1, 1) / sqrt(3), which tilts the mid-plane too."""
    k = np.ones(3) / np.sqrt(3.0)
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    a = np.radians(degrees)
    return np.eye(3) + np.sin(a) * cross + (1.0 - np.cos(a)) * cross @ cross


@pytest.mark.parametrize("degrees", [0.0, 12.0, -40.0])
def test_corner_furthest_inside_the_chord_however_turned(degrees):
    turn = _turn(degrees)
    vertices, triangles = _ribbon()
    placed = subnasale(vertices @ turn.T, triangles, _points() @ turn.T, turn @ TEMPLATE_AXES[0])
    f, u = PROFILE[CORNER]
    np.testing.assert_allclose(placed[fp_index("9.15")], turn @ (0.0, -f, u), atol=1e-9)
    others = np.ones(84, dtype=bool)
    others[fp_index("9.15")] = False
    np.testing.assert_allclose(placed[others], _points()[others] @ turn.T, atol=1e-12)


def test_a_piece_behind_the_lip_is_not_the_corner():
    vertices, triangles = _ribbon()
    inner = vertices + (0.0, 0.03, 0.0)  # the same profile 3 cm further back, a separate piece
    placed = subnasale(
        np.vstack([vertices, inner]), np.vstack([triangles, triangles + len(vertices)]), _points(), TEMPLATE_AXES[0]
    )
    f, u = PROFILE[CORNER]
    np.testing.assert_allclose(placed[fp_index("9.15")], (0.0, -f, u), atol=1e-9)


def test_a_plane_missing_the_mesh_leaves_the_points():
    vertices, triangles = _ribbon()
    points = _points()
    placed = subnasale(vertices + (0.05, 0.0, 0.0), triangles, points, TEMPLATE_AXES[0])
    np.testing.assert_array_equal(placed, points)


def test_sample_head_gives_its_own_subnasale_back():
    t = load_template()
    placed = subnasale(t.vertices, t.triangles, t.fp_positions, TEMPLATE_AXES[0])
    assert np.linalg.norm(placed[fp_index("9.15")] - t.fp_positions[fp_index("9.15")]) < 1e-4
