"""Automatic placement on what the template is not: mirror pairs made mirror images across the face's own
mid-plane, the skin's plane of symmetry found from a turned start, a head found on a T-pose body, and the
template on a body and on a bust placed with its own points."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import FEATURE_POINTS, fp_index
from addon.placement.body import head_region
from addon.placement.landmarks import spine_top
from addon.placement.openings import boundary_loops
from addon.placement.pipeline import place_feature_points
from addon.placement.rigid import TEMPLATE_AXES, Similarity
from addon.placement.surface import area_samples
from addon.placement.symmetry import MidPlane, _pairs, surface_mid_plane, symmetrise
from addon.placement.template import load_template


def _yaw(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def test_symmetrise_makes_pairs_mirror_images_and_finds_the_plane():
    t = load_template()
    turn = _yaw(25.0)
    truth = t.fp_positions @ turn.T + np.array([0.03, -0.01, 0.02])
    noisy = truth + np.random.default_rng(0).normal(scale=0.002, size=truth.shape)
    result, plane = symmetrise(noisy, np.arange(len(noisy)))
    assert np.degrees(np.arccos(plane.normal @ turn[:, 0])) < 1.0  # the template's left, turned
    left, right = _pairs()
    assert np.abs(result[right] - plane.reflect(result[left])).max() < 1e-12
    mid = [fp_index(fp.id) for fp in FEATURE_POINTS if fp.side == "mid"]
    assert np.abs(result[mid] @ plane.normal - plane.offset).max() < 1e-12
    # averaging each pair with its mirror image brings it nearer the truth than the noisy points were
    pairs = np.concatenate([left, right])
    before = np.linalg.norm(noisy[pairs] - truth[pairs], axis=1).mean()
    after = np.linalg.norm(result[pairs] - truth[pairs], axis=1).mean()
    assert after < 0.8 * before


@pytest.mark.parametrize("degrees", [10.0, 25.0])
def test_the_skin_plane_of_symmetry_is_found_from_a_turned_start(degrees):
    t = load_template()
    points, normals = area_samples(t.vertices, t.triangles, 4000)
    left = np.array([1.0, 0.0, 0.0])
    start = MidPlane(_yaw(degrees) @ left, 0.01)
    plane = surface_mid_plane(points, normals, start)
    assert np.degrees(np.arccos(plane.normal @ left)) < 0.5
    assert abs(plane.offset) < 0.0005


def _box(centre, size):
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = np.array(
        [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]], dtype=np.int64
    )
    return np.asarray(centre) + corners * np.asarray(size), np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])


def _joined(pieces):
    vertices, triangles, offset = [], [], 0
    for v, f in pieces:
        vertices.append(v)
        triangles.append(f + offset)
        offset += len(v)
    return np.vstack(vertices), np.vstack(triangles)


def _body():
    """The template head (1.8 m tall, Z up) on a box torso with T-pose arms from the shoulders and legs."""
    t = load_template()
    torso = _box([0.0, -0.05, -0.40], [0.36, 0.22, 0.60])
    arms = _box([0.0, -0.05, -0.16], [1.70, 0.09, 0.09])
    legs = [_box([x, -0.05, -1.15], [0.14, 0.16, 0.90]) for x in (-0.1, 0.1)]
    return _joined([(t.vertices, t.triangles), torso, arms, *legs])


def test_a_head_is_found_on_a_t_pose_body_and_the_arms_are_cut_away():
    vertices, triangles = _body()
    t = load_template()
    points, _normals = area_samples(vertices, triangles, 20000)
    region = head_region(points)
    assert region is not None
    assert region.up @ np.array([0.0, 0.0, 1.0]) > 0.99
    skin_fps = t.fp_positions[t.fp_vertices >= 0]
    assert region.contains(skin_fps).all()
    assert not region.contains(np.array([[0.8, -0.05, -0.16], [-0.8, -0.05, -0.16], [0.1, -0.05, -1.5]])).any()


def test_a_head_alone_is_not_taken_for_a_body():
    t = load_template()
    points, _normals = area_samples(t.vertices, t.triangles, 20000)
    assert head_region(points) is None


def test_the_template_on_a_turned_body_gets_its_own_points():
    vertices, triangles = _body()
    t = load_template()
    turn = Similarity(_yaw(30.0), 1.0, np.array([0.5, 0.2, 1.0]))
    placement = place_feature_points(turn.apply(vertices), triangles)
    errors = np.linalg.norm(placement.positions - turn.apply(t.fp_positions), axis=1) * 1000.0
    assert errors[t.fp_vertices >= 0].mean() < 1.0
    assert np.allclose(placement.axes, TEMPLATE_AXES @ turn.rotation.T, atol=0.02)


def test_a_bust_does_not_turn_the_fit():
    t = load_template()
    shoulders = _box([0.0, -0.02, -0.17], [0.40, 0.20, 0.08])
    vertices, triangles = _joined([(t.vertices, t.triangles), shoulders])
    placement = place_feature_points(vertices, triangles)
    assert np.allclose(placement.axes, TEMPLATE_AXES, atol=0.02)
    left, right = _pairs()
    plane = MidPlane(placement.axes[0], 0.0)
    assert np.abs(placement.positions[right] - plane.reflect(placement.positions[left])).max() < 1e-3


def _with_eye_holes():
    """The template with an elliptic hole cut around each eye (the triangles whose centre lies inside),
    and each hole's true corners: its boundary's extreme vertices along the face's left."""
    t = load_template()
    keep = np.ones(len(t.triangles), dtype=bool)
    centres = t.vertices[t.triangles].mean(axis=1)
    corners = {}
    for outer, inner in (("3.7", "3.11"), ("3.12", "3.8")):
        a, b = t.fp_positions[fp_index(outer)], t.fp_positions[fp_index(inner)]
        middle, half = 0.5 * (a + b), 0.4 * abs(a[0] - b[0])
        inside = ((centres[:, 0] - middle[0]) / half) ** 2 + ((centres[:, 2] - middle[2]) / (0.5 * half)) ** 2 < 1
        keep &= ~(inside & (np.abs(centres[:, 1] - middle[1]) < 0.006))
    triangles = t.triangles[keep]
    loops = boundary_loops(len(t.vertices), triangles)
    for outer, inner in (("3.7", "3.11"), ("3.12", "3.8")):
        middle = 0.5 * (t.fp_positions[fp_index(outer)] + t.fp_positions[fp_index(inner)])
        loop = min(loops, key=lambda edges: np.linalg.norm(t.vertices[np.unique(edges)].mean(0) - middle))
        ring = t.vertices[np.unique(loop)]
        ends = ring[[np.argmax(ring[:, 0]), np.argmin(ring[:, 0])]]
        corners[outer], corners[inner] = (ends if outer == "3.7" else ends[::-1])[[0, 1]]
    return t.vertices, triangles, corners


def test_eye_corners_are_the_corners_of_the_eye_openings():
    vertices, triangles, corners = _with_eye_holes()
    assert len(boundary_loops(len(vertices), triangles)) == 3  # the neck and the two eyes
    turn = Similarity(_yaw(-20.0), 2.0, np.array([0.0, 1.0, 0.0]))
    placement = place_feature_points(turn.apply(vertices), triangles)
    for fp_id, corner in corners.items():
        assert np.linalg.norm(placement.positions[fp_index(fp_id)] - turn.apply(corner)) < 1e-6
    # the lid middles lie on the opening's edge, the upper one above the lower
    lids = placement.positions[[fp_index(f) for f in ("3.1", "3.3", "3.2", "3.4")]]
    up = placement.axes[1]
    assert lids[0] @ up > lids[1] @ up and lids[2] @ up > lids[3] @ up
    edge = turn.apply(vertices[np.unique(np.vstack(boundary_loops(len(vertices), triangles)))])
    assert all(np.min(np.linalg.norm(edge - lid, axis=1)) < 2.0 * 0.006 for lid in lids)


def test_an_opening_hidden_behind_the_lids_is_not_taken_for_their_edge():
    vertices, triangles, corners = _with_eye_holes()
    tucked = vertices.copy()
    rims = np.unique(np.vstack(boundary_loops(len(vertices), triangles)))
    rims = rims[vertices[rims, 1] < -0.1]  # the eye holes' rims (the face looks along -Y), not the neck
    # lids tucked round an eyeball: each rim 6 mm back and a third wider, under the skin around it
    for side in (rims[vertices[rims, 0] > 0], rims[vertices[rims, 0] < 0]):
        centre = vertices[side].mean(axis=0)
        tucked[side] = centre + (vertices[side] - centre) * np.array([1.35, 1.0, 1.35]) + [0.0, 0.006, 0.0]
    placement = place_feature_points(tucked, triangles)
    ring = tucked[rims]
    for fp_id in corners:
        assert np.linalg.norm(ring - placement.positions[fp_index(fp_id)], axis=1).min() > 0.002


def test_the_top_of_the_spine_is_placed_between_the_ear_lobes():
    t = load_template()
    lobes = t.fp_positions[[fp_index("10.5"), fp_index("10.6")]]
    assert np.allclose(spine_top(t.fp_positions), [0.0, -0.041835, -0.015205], atol=1e-5)  # 0.5 (10.5 + 10.6)
    placement = place_feature_points(t.vertices, t.triangles)
    spine = placement.positions[fp_index("7.1")]
    assert np.allclose(spine, 0.5 * placement.positions[[fp_index("10.5"), fp_index("10.6")]].sum(axis=0))
    # the sample's own marker (the template's origin) is 44 mm away; the rule is within 2 mm of the lobes' midpoint
    assert np.linalg.norm(spine - lobes.mean(axis=0)) < 0.002
    assert np.linalg.norm(spine - t.fp_positions[fp_index("7.1")]) > 0.04
