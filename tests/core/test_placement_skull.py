"""The skull points 11.1-11.6 read off the head's mid-plane outline by their definitions (`skull`): the
sample's own points back from its mesh, the same points on a turned and scaled copy (the rules live in the
head's own frame, not the world's), a hand-worked crossing, and placement on a head whose skull the
template does not have (stretched upwards) putting them where the rules say."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import fp_index
from addon.placement.nicp import edges_of
from addon.placement.pipeline import place_feature_points
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.skull import _level, frankfurt_axes, outline, read_skull
from addon.placement.template import load_template

SKULL = [fp_index(f"11.{k}") for k in range(1, 7)]


def _read(vertices, triangles, points, left, up):
    t = load_template()
    return read_skull(vertices, triangles, points, left, up, t.fp_positions, TEMPLATE_AXES)


def _pitch(degrees: float) -> np.ndarray:
    """A turn about the template's left axis (x)."""
    a = np.radians(degrees)
    return np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])


def test_the_sample_gets_its_own_skull_points_back():
    t = load_template()
    read = _read(t.vertices, t.triangles, t.fp_positions, TEMPLATE_AXES[0], TEMPLATE_AXES[1])
    errors = np.linalg.norm(read[SKULL] - t.fp_positions[SKULL], axis=1)
    # 11.4-11.6 lie on the rays the template defines, so exactly; 11.1-11.3 are the sample's rules on
    # its vertices, here interpolated along the outline
    assert errors[3:].max() < 1e-6
    assert errors[:3].max() < 0.001
    others = np.setdiff1d(np.arange(len(read)), SKULL)
    assert np.array_equal(read[others], t.fp_positions[others])


def test_the_rules_turn_and_scale_with_the_head():
    t = load_template()
    turn = _pitch(12.0) @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    move = np.array([0.3, -0.2, 1.0])
    vertices = 100.0 * t.vertices @ turn.T + move
    points = 100.0 * t.fp_positions @ turn.T + move
    read = _read(vertices, t.triangles, points, turn @ TEMPLATE_AXES[0], turn @ TEMPLATE_AXES[1])
    expected = 100.0 * _read(t.vertices, t.triangles, t.fp_positions, TEMPLATE_AXES[0], TEMPLATE_AXES[1])
    assert np.abs(read[SKULL] - (expected[SKULL] @ turn.T + move)).max() < 1e-6 * 100.0


def test_frankfurt_forward_runs_from_the_ears_to_the_lower_lids():
    points = np.zeros((84, 3))
    for k in range(1, 11):
        points[fp_index(f"10.{k}")] = [0.07 if k % 2 else -0.07, 0.0, 0.0]
    points[fp_index("3.9")] = [0.03, 0.01, 0.08]
    points[fp_index("3.10")] = [-0.03, 0.01, 0.08]
    axes = frankfurt_axes(points, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    tilt = np.arctan2(0.01, 0.08)
    assert np.allclose(axes[2], [0.0, np.sin(tilt), np.cos(tilt)])
    assert np.allclose(axes[1], [0.0, np.cos(tilt), -np.sin(tilt)])


def test_a_level_crossing_is_interpolated_and_an_angle_wrapping_round_is_not_one():
    path = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 2.0, 2.0]])
    assert np.allclose(_level(path, np.array([0.0, 1.0, 2.0]), 1.5), [[0.0, 1.5, 1.0]])
    assert len(_level(path, np.array([3.0, -3.0, -2.9]), 0.0, gap=np.pi)) == 0


def test_the_outline_is_the_outer_skin_not_what_lies_inside():
    t = load_template()
    centre = 0.5 * (t.fp_positions[fp_index("10.3")] + t.fp_positions[fp_index("10.4")])
    centre[0] = 0.0
    profile = outline(t.vertices, edges_of(t.triangles), TEMPLATE_AXES, centre)
    assert len(profile) > 50 and np.abs(profile[:, 0]).max() < 1e-12
    top = profile[np.argmax(profile @ TEMPLATE_AXES[1])] @ TEMPLATE_AXES[1]
    assert top == pytest.approx((t.vertices @ TEMPLATE_AXES[1]).max(), abs=0.003)
    # a piece inside the head (the skin shrunk to half about the centre: a mouth's inside, teeth) changes nothing
    inner = centre + 0.5 * (t.vertices - centre)
    vertices = np.vstack([t.vertices, inner])
    triangles = np.vstack([t.triangles, t.triangles + len(t.vertices)])
    assert np.array_equal(outline(vertices, edges_of(triangles), TEMPLATE_AXES, centre), profile)


def test_placement_puts_the_skull_points_where_the_rules_say_on_a_taller_skull():
    """The sample with everything above its brows stretched 35 % upwards: a skull the template's shapes do
    not have, so the registration slides over it, where the rules read it off the mesh."""
    t = load_template()
    up = TEMPLATE_AXES[1]
    brow = t.fp_positions[fp_index("4.3")] @ up

    def stretch(x):
        height = x @ up
        return x + np.maximum(height - brow, 0.0)[:, None] * 0.35 * up

    vertices, points = stretch(t.vertices), stretch(t.fp_positions)
    truth = _read(vertices, t.triangles, points, TEMPLATE_AXES[0], up)
    placed = place_feature_points(vertices, t.triangles).positions
    errors = np.linalg.norm(placed[SKULL] - truth[SKULL], axis=1)
    assert errors.max() < 0.0015  # 5.7 mm (11.1) when the registration carried them


# --- the rigid fit's other facing, and a sealed mouth's meeting line (the same session's changes) ---


def test_a_fit_turned_about_up_faces_the_other_way_about_the_same_centre():
    from addon.placement.rigid import Similarity, _turned_about_up

    rotation = _pitch(20.0)
    fit = Similarity(rotation, 2.0, np.array([1.0, 2.0, 3.0]))
    centre = np.array([0.01, -0.02, 0.1])
    turned = _turned_about_up(fit, centre)
    assert np.allclose(turned.apply(centre[None]), fit.apply(centre[None]))
    axes = TEMPLATE_AXES @ turned.rotation.T  # rows: the turned face's left, up, forward in the world
    before = TEMPLATE_AXES @ rotation.T
    assert np.allclose(axes[1], before[1]) and np.allclose(axes[2], -before[2]) and np.allclose(axes[0], -before[0])
    assert np.isclose(np.linalg.det(turned.rotation), 1.0) and turned.scale == 2.0


def test_the_notch_between_lips_that_meet_is_the_bottom_of_their_groove():
    from addon.placement.openings import _notch

    # a section across closed lips (metres; up = y, forward = z): the upper lip's front comes down and
    # back to where the lips touch at (y 0.0005, z 0.006), the lower lip's goes from there down and out;
    # behind the touching point the two lips' inner sides run back to the mouth's opening
    upper = [(0.008, 0.010), (0.004, 0.012), (0.002, 0.009), (0.0005, 0.006), (0.001, 0.003), (0.004, 0.0)]
    lower = [(0.0005, 0.006), (-0.002, 0.010), (-0.006, 0.011), (-0.010, 0.009)]
    inner = [(0.0, 0.006), (-0.0005, 0.003), (-0.004, 0.0)]
    segments = []
    for line in (upper, lower, inner):
        points = [np.array([0.0, y, z]) for y, z in line]
        segments += [np.stack([a, b]) for a, b in zip(points[:-1], points[1:], strict=False)]
    axes = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    notch = _notch(np.array(segments), np.array([0.0, 0.0, -0.001]), axes, 0.012)
    assert np.allclose(notch, [0.0, 0.0005, 0.006], atol=0.0003)
