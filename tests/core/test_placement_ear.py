"""The upper points of the ears 10.9/10.10 read off the skin (`landmarks.ear_top`): on a hand-made rim beside
a higher scalp the rim's top, however turned, not the scalp; a guess on the scalp itself (still climbing at
the edge of the reach) not moved; only the tops move (`ear_tops`), the contact points stay; on the sample
head with its ears' upper rims pulled up and back, the moved tops, where the registration alone leaves them
about 4 mm off, and the contact points left near their places."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import fp_index
from addon.placement.landmarks import ear_top, ear_tops
from addon.placement.pipeline import place_feature_points
from addon.placement.surface import Surface
from addon.placement.symmetry import MidPlane
from addon.placement.template import load_template
from tests.core.test_placement_subnasale import _turn

RIM_CENTRE = np.array([0.07, 0.0, 0.02])  # (outward, forward, up) in metres
RIM_RADIUS = 0.005
SCALP = 0.06  # the scalp's plane, 5 mm further in than the rim, rising 1 cm above its top


def _rim_and_scalp():
    """A half-cylinder (the helix's rim, round the forward axis) and a plane further in and higher (the
    scalp), each extruded 1 cm forward and back, as triangles; x outward, y forward, z up."""
    angles = np.linspace(0.0, np.pi, 61)
    arc = np.stack([RIM_CENTRE[0] + RIM_RADIUS * np.cos(angles), RIM_CENTRE[2] + RIM_RADIUS * np.sin(angles)], axis=1)
    wall = np.stack([np.full(11, SCALP), np.linspace(0.0, 0.035, 11)], axis=1)
    vertices, triangles = [], []
    for section in (arc, wall):
        n, base = len(section), sum(len(v) for v in vertices)
        front = np.stack([section[:, 0], np.full(n, 0.01), section[:, 1]], axis=1)
        back = front - (0.0, 0.02, 0.0)
        vertices.append(np.vstack([front, back]))
        for k in range(n - 1):
            triangles += [(base + k, base + k + 1, base + n + k), (base + k + 1, base + n + k + 1, base + n + k)]
    return np.vstack(vertices), np.array(triangles)


@pytest.mark.parametrize("degrees", [0.0, 30.0, -70.0])
def test_the_rims_top_not_the_higher_scalp_however_turned(degrees):
    turn = _turn(degrees)
    vertices, triangles = _rim_and_scalp()
    guess = _slid_guess()  # 50 degrees down the rim's inner side; the scalp lies within reach of it, higher
    found = ear_top(Surface(vertices @ turn.T, triangles), guess @ turn.T, turn[:, 2], turn[:, 0])
    top = RIM_CENTRE + (0.0, 0.0, RIM_RADIUS)
    back = found @ turn
    assert np.linalg.norm(back[[0, 2]] - top[[0, 2]]) < 0.0002  # on the rim's top line, which runs forward
    assert abs(back[1]) < 0.008


def test_no_skin_near_finds_nothing():
    vertices, triangles = _rim_and_scalp()
    far = np.array([0.5, 0.0, 0.0])
    assert ear_top(Surface(vertices, triangles), far, np.array([0.0, 0.0, 1.0]), np.eye(3)[0]) is None


def _slid_guess():
    slid = np.radians(50.0)
    return RIM_CENTRE + RIM_RADIUS * np.array([np.cos(np.pi - slid), 0.0, np.sin(np.pi - slid)])


def test_a_guess_on_the_climbing_scalp_finds_no_top():
    vertices, triangles = _rim_and_scalp()
    on_scalp = np.array([SCALP, 0.0, 0.012])  # the scalp rises 2.3 cm above it, beyond any reach
    assert ear_top(Surface(vertices, triangles), on_scalp, np.array([0.0, 0.0, 1.0]), np.array([-1.0, 0, 0])) is None


def test_only_the_top_moves_the_contact_points_stay():
    vertices, triangles = _rim_and_scalp()
    points = np.zeros((84, 3))
    points[fp_index("10.9")] = _slid_guess()
    points[fp_index("10.5")] = (SCALP, 0.0, 0.0)  # the lobe, at the scalp's foot
    points[fp_index("10.1")] = (SCALP, 0.0, 0.5 * _slid_guess()[2])  # half way up the ear, on the scalp
    points[fp_index("10.10")] = (-0.5, 0.0, 0.0)  # the other ear, no skin near it
    plane = MidPlane(np.array([1.0, 0.0, 0.0]), 0.0)
    moved = ear_tops(Surface(vertices, triangles), points, plane, np.array([0.0, 0.0, 1.0]))
    assert abs(moved[fp_index("10.9")][2] - (RIM_CENTRE[2] + RIM_RADIUS)) < 0.0002
    others = np.ones(84, bool)
    others[fp_index("10.9")] = False
    assert np.array_equal(moved[others], points[others])


def test_raised_ear_tops_are_found_on_the_sample_head():
    t = load_template()
    vertices = t.vertices.copy()
    for fp_id in ("10.9", "10.10"):
        top = t.fp_positions[fp_index(fp_id)]
        on_ear = np.abs(vertices[:, 0]) > np.abs(top[0]) - 0.012  # the ear and the head's side next to it
        bump = np.exp(-((np.linalg.norm(vertices - top, axis=1) / 0.008) ** 2)) * on_ear
        vertices += bump[:, None] * np.array([0.0, 0.004, 0.003])  # up 3 mm, back 4 mm (the face looks to -y)
    placed = place_feature_points(vertices, t.triangles).positions
    for fp_id in ("10.9", "10.10"):
        row = fp_index(fp_id)
        assert np.linalg.norm(placed[row] - vertices[t.fp_vertices[row]]) < 0.001  # 4 mm by the registration alone
    for fp_id in ("10.1", "10.2"):  # only the rims were raised: the contact points stay near their places
        row = fp_index(fp_id)
        assert np.linalg.norm(placed[row] - vertices[t.fp_vertices[row]]) < 0.002  # 4.3-4.5 mm if moved with the top
