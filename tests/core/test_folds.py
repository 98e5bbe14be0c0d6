"""Fold-over count: faces whose normal turns against the rest normal."""

import numpy as np
import pytest

from addon.deform.folds import count_inverted, fan_triangles, inverted_faces
from addon.deform.inputs import DeformError

# a unit square as a quad (0, 1, 2, 3) and a triangle (1, 4, 2) beside it, in the z = 0 plane, facing +z
REST = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0.5, 0]], dtype=float)
SIZES = np.array([4, 3])
CORNERS = np.array([0, 1, 2, 3, 1, 4, 2])


def test_fans_split_polygons_from_their_first_corner():
    triangles, owner = fan_triangles(SIZES, CORNERS)
    assert triangles.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]
    assert owner.tolist() == [0, 0, 1]


def test_rigid_motion_and_stretch_fold_nothing():
    triangles, owner = fan_triangles(SIZES, CORNERS)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    for moved in (REST @ turn.T + [3, 4, 5], REST * [2.0, 0.5, 1.0]):
        assert count_inverted(REST, moved, triangles, owner) == 0


def test_a_vertex_pushed_across_the_opposite_edge_folds_its_faces():
    triangles, owner = fan_triangles(SIZES, CORNERS)
    moved = REST.copy()
    moved[4] = [0.5, 0.5, 0.0]  # across edge 1-2: the triangle turns over, the quad does not
    assert inverted_faces(REST, moved, triangles, owner).tolist() == [False, True]
    moved[3] = [0.5, -1.0, 0.0]  # across 0-2 in the quad's second fan triangle: the quad counts once
    assert inverted_faces(REST, moved, triangles, owner).tolist() == [True, True]
    assert count_inverted(REST, moved, triangles, owner) == 2


def test_a_half_turn_about_an_in_plane_axis_counts_every_face():
    triangles, owner = fan_triangles(SIZES, CORNERS)
    mirrored = REST * [1.0, -1.0, 1.0]  # a mirror turns every normal over
    assert count_inverted(REST, mirrored, triangles, owner) == 2
    assert count_inverted(REST, mirrored, triangles) == 3  # counted per triangle without owners


def test_zero_area_rest_faces_are_never_counted():
    rest = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], dtype=float)
    assert count_inverted(rest, rest[::-1].copy(), [[0, 1, 2]]) == 0


@pytest.mark.parametrize(
    ("sizes", "corners"),
    [([2], [0, 1]), ([3], [0, 1]), ([[3]], [0, 1, 2])],
)
def test_bad_polygons_are_refused(sizes, corners):
    with pytest.raises(DeformError):
        fan_triangles(np.array(sizes), np.array(corners))


def test_bad_indices_and_shapes_are_refused():
    with pytest.raises(DeformError, match="indices"):
        inverted_faces(REST, REST, [[0, 1, 9]])
    with pytest.raises(DeformError, match="shape"):
        inverted_faces(REST, REST[:4], [[0, 1, 2]])
    with pytest.raises(DeformError, match="owner"):
        inverted_faces(REST, REST, [[0, 1, 2]], owner=[0, 1])
