"""A plane's section of a mesh (`placement.section`): one segment per cut triangle, a vertex exactly on the plane
counted on the plane's positive side (a corner on the plane, or an edge lying in it, gives the section's true
piece there once), and the section seen from in front: per band of height the most forward point."""

import numpy as np

from addon.placement.section import front, section

X = np.array([1.0, 0.0, 0.0])


def _pieces(vertices, triangles, level):
    crossings, edges, segments = section(vertices, triangles, X, level)
    assert len(crossings) == len(edges)
    return sorted(sorted(map(tuple, np.round(crossings[s], 9).tolist())) for s in segments)


def test_a_plane_cuts_a_triangle_in_one_segment():
    vertices = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [3.0, 0.0, 0.0]])
    triangles = np.array([[0, 1, 2], [1, 3, 2]])  # the second lies wholly on the plane's far side
    assert _pieces(vertices, triangles, 0.5) == [[(0.5, 0.0, 0.0), (0.5, 1.5, 0.0)]]


def test_a_corner_on_the_plane_starts_the_segment_across_the_triangle():
    # the plane x = 0 through corner 0; corners 1 and 2 on either side: the section runs from the corner to the
    # middle of the opposite edge (not a segment of no length at the corner)
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 0.0], [-1.0, 2.0, 0.0]])
    for triangles in (np.array([[0, 1, 2]]), np.array([[1, 2, 0]]), np.array([[2, 0, 1]])):
        assert _pieces(vertices, triangles, 0.0) == [[(0.0, 0.0, 0.0), (0.0, 2.0, 0.0)]]


def test_an_edge_lying_in_the_plane_is_the_section_once():
    # a strip symmetric about x = 0 whose middle edge lies in the plane (a mid-plane through mid-line vertices):
    # the section is that edge, once, however the triangles are wound
    vertices = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.5, 0.0], [-1.0, 0.5, 0.0]])
    for triangles in (np.array([[0, 2, 1], [0, 1, 3]]), np.array([[1, 0, 2], [3, 1, 0]])):
        assert _pieces(vertices, triangles, 0.0) == [[(0.0, 0.0, 0.0), (0.0, 1.0, 0.0)]]


def test_seen_from_in_front_the_most_forward_point_of_each_band():
    # two segments in the plane x = 0 (up = y, forward = z): a slope from (y 0, z 0) to (y 1, z 1) and, in front
    # of its lower half, a vertical piece at z 2 from y 0 to y 0.45; bands of 0.25 from the centre 0.5 within
    # 0.5; each segment sampled at 6 points (its rise over a band, and 2)
    segments = np.array([[[0.0, 0.0, 0.0], [0.0, 1.0, 1.0]], [[0.0, 0.0, 2.0], [0.0, 0.45, 2.0]]])
    axes = np.eye(3)
    points, heights, depths = front(segments, axes[1], axes[2], 0.5, 0.5, 0.25)
    assert len(points) == 4 and np.all(np.diff(heights) > 0)
    assert np.allclose(points @ axes[1] - 0.5, heights)
    assert np.allclose(depths[:2], 2.0)  # the bands below the centre: the vertical piece in front
    assert np.allclose(depths[2:], [0.6, 0.8])  # above it the slope's most forward sample in each band
    assert np.all(np.floor(heights / 0.25) == [-2, -1, 0, 1])  # the bands' edges on the centre
