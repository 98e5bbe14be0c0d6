"""Skin passing through skin and rough lid edges, measured beside the fold count (no scene)."""

import numpy as np
import pytest

from addon.deform.overlaps import crossing_pairs, crossings, edge_chain, edge_roughness, lid_gap, seen_lid_gap


def _sheet(offset: float):
    """Two unit squares (two triangles each), the second `offset` above the first and shifted half a square."""
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    points = np.concatenate([square, square + [0.5, 0.25, offset]])
    tris = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    return points, tris


def test_sheets_apart_do_not_cross_and_a_sheet_pushed_through_does():
    points, tris = _sheet(0.1)
    assert crossings(points, tris) == 0
    points[6, 2] = -0.5  # one corner of the upper sheet pushed through the lower one
    assert crossings(points, tris) >= 1
    assert crossings(points, tris, moving=np.zeros(8, bool)) == 0  # nothing moved: nothing looked at
    neighbours = np.array([[0, 1, 2], [0, 2, 3]])  # triangles sharing vertices never count
    assert crossings(points[:4], neighbours) == 0


def _turned(points: np.ndarray, degrees: float, dtype=np.float64) -> np.ndarray:
    a = np.radians(degrees)
    turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)  # about a slanted axis: (x, y) turned, then tilted
    tilt = np.eye(3) + np.sin(0.4) * np.cross(np.eye(3), axis) + (1 - np.cos(0.4)) * (np.outer(axis, axis) - np.eye(3))
    return (points @ turn.T @ tilt.T).astype(dtype).astype(np.float64)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_surfaces_that_touch_at_rest_do_not_cross_when_turned_rigidly(dtype):
    """Layers that touch at rest (clothes on skin, a sewn seam's coincident vertices: the Rocketbox's full body) sit
    at exactly 0 in the crossing test, where the sign is the rounding's: turned rigidly by 2 degrees, the Rocketbox
    gave 691 new crossing pairs in float64 and 207 in float32, and its head turns up to 181 a frame (the body turned
    back rigidly). Here a sheet lies on another (coplanar, shifted) and a third stands on it with an edge ending on
    it: no pair crosses at rest or turned, and one pushed through still does."""
    points, tris = _sheet(0.0)
    standing = np.array([[0.3, 0.3, 0.0], [0.7, 0.3, 0.0], [0.5, 0.3, 0.5]])  # its base edge on the lower sheet
    points = np.concatenate([points, standing])
    tris = np.concatenate([tris, [[8, 9, 10]]])
    assert len(crossing_pairs(points, tris)) == 0
    for degrees in (0.5, 2.0, 7.0):
        assert len(crossing_pairs(_turned(points, degrees, dtype), tris)) == 0
    points[8:, 2] -= 0.2  # the standing triangle pushed through the lower sheet
    assert len(crossing_pairs(_turned(points, 2.0, dtype), tris)) >= 1


@pytest.mark.parametrize("scale", [1e-5, 1.0, 1e3])
def test_a_crossing_is_seen_at_any_scale(scale):
    """The sheets of `_sheet` in metres x `scale`: the same pairs cross (the test's bound on the determinant was
    absolute, 1e-12, so on a face 0.01 of a metre-sized one, `scaled_x0.01`, no crossing was ever seen)."""
    points, tris = _sheet(0.1)
    points[6, 2] = -0.5
    expected = crossing_pairs(points, tris)
    assert len(expected) >= 1
    np.testing.assert_array_equal(crossing_pairs(points * scale, tris), expected)


def test_pairs_that_cross_at_rest_are_not_charged_to_the_motion():
    """A surface that crosses itself before anything moves (a scan's closed eyes: 241 pairs on the Lee Perry-Smith
    head) counts only the pairs the motion makes: here the upper sheet pierces the lower at rest (2 pairs), and a
    third sheet pushed through the lower one adds its own."""
    points, tris = _sheet(0.1)
    points[6, 2] = -0.5
    rest_pairs = crossing_pairs(points, tris)
    assert len(rest_pairs) >= 1 and crossings(points, tris, at_rest=rest_pairs) == 0
    third = np.array([[0.2, 0.6, 0.3], [0.4, 0.6, 0.3], [0.3, 0.8, 0.3]])
    rest = np.concatenate([points, third])
    tris = np.concatenate([tris, [[8, 9, 10]]])
    at_rest = crossing_pairs(rest, tris)
    assert np.array_equal(at_rest, rest_pairs)  # the third triangle is clear of both sheets at rest
    moved = rest.copy()
    moved[10, 2] = -0.3  # its apex pushed through the lower sheet
    assert crossings(moved, tris) > len(rest_pairs)
    assert crossings(moved, tris, at_rest=at_rest) == crossings(moved, tris) - len(rest_pairs) >= 1


def test_triangles_that_only_touch_are_found_with_a_negative_touch():
    """Two triangles folded toward each other whose edges cross in one plane (z = 0) meet at a point (the Rocketbox's
    commissure at rest): no crossing by default (surfaces touching at rest are left out), a pair with touch < 0; the
    upper one lifted clear of the plane, neither."""
    points = np.array([
        [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, -1.0, -0.5],  # edge along x, its triangle below the plane
        [0.25, -0.5, 0.0], [0.25, 0.5, 0.0], [-0.5, 0.0, 0.5],  # edge along y through (0.25, 0), its triangle above
    ])  # fmt: skip
    tris = np.array([[0, 1, 2], [3, 4, 5]])
    assert len(crossing_pairs(points, tris)) == 0
    assert crossing_pairs(points, tris, touch=-1e-6).tolist() == [[0, 1]]
    points[3:, 2] += 0.01
    assert len(crossing_pairs(points, tris, touch=-1e-6)) == 0


def test_a_smooth_lid_edge_is_on_its_curve_and_a_zig_zag_is_not():
    angle = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    circle = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(40)]) * 0.015
    chain = np.arange(40)
    assert edge_roughness(circle, chain).max() < 1e-5  # a 15 mm circle at 40 vertices: a cubic to 0.01 mm
    circle[10, 2] += 0.001
    rough = edge_roughness(circle, chain)
    assert rough[10] > 0.0005 and np.argmax(rough) == 10


def _lids(opening: float):
    """Two lid margins 20 mm wide, 1 mm apart along them, the upper one `opening` above the lower in the middle
    (a sine arch, as an eye's opening) and 0.2 mm at the corners, each with a second row of vertices 2 mm behind."""
    x = np.linspace(0.0, 0.02, 21)
    arch = opening * np.sin(np.pi * x / 0.02)
    upper = np.column_stack([x, np.zeros(21), arch])
    lower = np.column_stack([x, np.zeros(21), np.full(21, -0.0002)])
    behind = np.array([0.0, 0.002, 0.0])
    return np.concatenate([upper, lower, upper + behind, lower + behind])


def test_a_lid_edge_is_found_along_its_fps_and_its_gap_measured_where_the_lids_should_meet():
    points = _lids(0.009)
    line_upper = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.009], [0.02, 0.0, 0.0]])
    upper = edge_chain(points, np.arange(len(points)), line_upper, 24)
    assert np.all(upper < 21) and np.all(np.diff(points[upper, 0]) > 0)  # the margin, in order, not the row behind
    lower = edge_chain(points, np.arange(21, 84), line_upper * [1, 1, 0], 24)
    assert np.array_equal(lower, np.arange(21, 42))  # the lower margin, from the candidates given
    # the middle half of the upper margin: its widest distance from the lower one is the opening under the mid FP
    assert lid_gap(points, upper, lower) == pytest.approx(0.0092)
    closed = _lids(0.0003)
    assert lid_gap(closed, upper, lower) == pytest.approx(0.0005)
    assert np.isnan(lid_gap(closed, upper[:0], lower))  # no edge to measure


def test_unfold_skin_takes_fewer_steps_a_frame_the_finer_the_mesh():
    from addon.deform.unfold import MAX_STEPS, MIN_FRAME_STEPS, frame_steps

    assert frame_steps(1000) == MAX_STEPS
    assert frame_steps(4278) == 935  # the sample
    assert frame_steps(53522) == 74  # the 2 mm voxel remesh: 800 steps took 0.45 s there
    assert frame_steps(10_000_000) == MIN_FRAME_STEPS


def _margins(upper_front: float, lower_front: float):
    """Two lids across x = -10..10 mm in front of an eye centred at the origin (x across, y up, z forward, mm):
    each a band of skin down (up) to a thick margin that slants back, the upper's front edge at height
    `upper_front` and 15 mm forward, its back edge 0.5 mm higher and 1 mm back; the lower's front edge at
    `lower_front` and 13.8 mm forward, its back edge 0.4 mm lower and 0.8 mm back. Returns the points (m), the
    triangles and the back edges' vertex chains, upper and lower (what `lid_gap` measures on the sample)."""
    rows = [(12.0, 15.0), (upper_front, 15.0), (upper_front + 0.5, 14.0)]  # upper: skin, front edge, back edge
    rows += [(-12.0, 13.8), (lower_front, 13.8), (lower_front - 0.4, 13.0)]  # lower: skin, front edge, back edge
    x = np.linspace(-10.0, 10.0, 11)
    points = np.array([(xi, y, z) for y, z in rows for xi in x]) * 1e-3
    triangles = []
    for first in (0, 3):  # two strips of quads per lid: skin to front edge, front edge to back edge
        for row in (first, first + 1):
            for i in range(10):
                a, b, c, d = row * 11 + i, row * 11 + i + 1, (row + 1) * 11 + i + 1, (row + 1) * 11 + i
                triangles += [(a, b, c), (a, c, d)]
    return points, np.array(triangles), np.arange(22, 33), np.arange(55, 66)


def test_the_seen_gap_is_the_opening_a_viewer_sees_however_thick_the_margins():
    eye = (np.zeros(3), 0.012, np.eye(3), (-0.01, 0.01))  # centre, eyeball radius, face axes, corners' x
    points, triangles, upper, lower = _margins(4.0, -4.0)
    assert seen_lid_gap(points, triangles, *eye) == pytest.approx(0.008)  # open: front edge to front edge
    points, triangles, upper, lower = _margins(0.5, 0.0)
    assert seen_lid_gap(points, triangles, *eye) == pytest.approx(0.0005)  # a slit between the front edges
    # closed, the upper lid over the lower one: nothing to see, though the back edges stay apart in depth
    points, triangles, upper, lower = _margins(-0.2, 0.0)
    assert seen_lid_gap(points, triangles, *eye) == pytest.approx(0.0, abs=1e-12)
    assert lid_gap(points, upper, lower) == pytest.approx(np.hypot(0.7, 1.0) * 1e-3)
    # no skin at all: the eyeball's whole height at the middle column (x = 0 among the columns)
    assert seen_lid_gap(points, triangles[:0], *eye, columns=3) == pytest.approx(0.024)
    # skin behind the eye's centre (the back of the head) hides nothing
    behind = points * [1.0, 1.0, -1.0]
    assert seen_lid_gap(behind, triangles, *eye, columns=3) == pytest.approx(0.024)
