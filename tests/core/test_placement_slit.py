"""A mouth with no opening whose lips meet along a slit (`placement.slit`): on a hand-made mouth (two lip bulges
meeting on a crease, a pocket behind it that shrinks to nothing at the slit's ends, 20 mm either side of the
middle) the inner lip points go onto the crease, each on its own lip's wall, and the corners to the slit's ends,
however the head is turned; outer lip points on their own lips stay, one on the wrong lip moves with its inner
point; inner points the registration already put on their own lips stay; a crease with no pocket behind it (lips
welded shut, a fold of skin) and lips apart change nothing."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.mpeg4.feature_points import fp_index
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.slit import read_slit
from addon.placement.surface import Surface

MM = 0.001
HALF_SLIT = 20 * MM  # the slit's ends
POCKET = 10 * MM  # the pocket's depth behind the crease in the middle
GAP = 0.05 * MM  # the walls' distance where they touch
SMILE = 8.0  # the crease rises by SMILE * x**2 (metres) towards the corners
ROWS, UPPER_WALL, LOWER_WALL = 17, 5, 11  # each column of `_mouth`: its rows, the upper and lower wall's at the crease


def _depth(x):
    """The pocket's depth behind the crease at x: POCKET in the middle, nothing (a hundredth of a millimetre)
    past the slit's ends."""
    return POCKET * np.clip(1.0 - (x / HALF_SLIT) ** 2, 0.0, None) + 0.01 * MM


def _profile(x: float, pocket: bool = True, apart: float = 0.0) -> np.ndarray:
    """The section at x as (forward, up) points in metres, from above the upper lip round the pocket to below
    the lower lip; the crease at (0, SMILE x**2), the lips' fronts 5 mm in front of it."""
    d = _depth(x) if pocket else 0.01 * MM
    r = 2 * MM * d / POCKET + 0.01 * MM  # the pocket's half-height
    g = GAP / 2 + apart / 2
    rows = [(0, 20), (3, 12), (5, 6), (4, 3), (1.5, 1 + apart / MM / 2), (0, g / MM)]
    rows = [(f * MM, u * MM) for f, u in rows]
    rows += [(-d / 3, g + r), (-2 * d / 3, g + r), (-d, 0.0), (-2 * d / 3, -g - r), (-d / 3, -g - r)]
    rows += [(f * MM, -u * MM) for f, u in reversed([(0, 20), (3, 12), (5, 6), (4, 3), (1.5, 1 + apart / MM / 2)])]
    rows.insert(len(rows) - 5, (0.0, -g))
    section = np.array(rows)
    section[:, 0] -= 40.0 * x * x  # the face curves back towards the corners
    section[:, 1] += SMILE * x * x
    return section


def _mouth(pocket: bool = True, apart: float = 0.0):
    """The mouth as a sheet of triangles in the template's frame (left +x, up +z, forward -y), 40 mm either side."""
    xs = np.linspace(-0.04, 0.04, 161)
    columns = [_profile(x, pocket, apart) for x in xs]
    n = len(columns[0])
    vertices = np.vstack(
        [np.column_stack([np.full(n, x), -c[:, 0], c[:, 1]]) for x, c in zip(xs, columns, strict=True)]
    )
    triangles = []
    for i in range(len(xs) - 1):
        for k in range(n - 1):
            a, b = i * n + k, i * n + k + 1
            triangles += [(a, b, a + n), (b, b + n, a + n)]
    return vertices, np.array(triangles)


def _at(x: float, forward: float, up: float) -> np.ndarray:
    return np.array([x, -forward, up])


def _carried():
    """The registration's points as on the scan: the inner lip points on the lower lip's front, 5 mm below the
    crease, the corners 7 mm past the slit's ends; the outer lip points on their own lips."""
    points = np.zeros((84, 3))
    for fp_id, x in (("2.2", 0.0), ("2.3", 0.0), ("2.6", 0.011), ("2.8", 0.011), ("2.7", -0.011), ("2.9", -0.011)):
        points[fp_index(fp_id)] = _at(x, 5 * MM - 40 * x * x, -5 * MM + SMILE * x * x)
    points[fp_index("2.4")] = _at(0.027, -0.03, -0.004)
    points[fp_index("2.5")] = _at(-0.027, -0.03, -0.004)
    points[fp_index("8.3")] = _at(0.028, -0.03, -0.004)
    points[fp_index("8.4")] = _at(-0.028, -0.03, -0.004)
    for fp_id, x, up in (("8.1", 0.0, 1), ("8.9", -0.005, 1), ("8.10", 0.005, 1), ("8.5", 0.011, 1)):
        points[fp_index(fp_id)] = _at(x, 5 * MM - 40 * x * x, up * 6 * MM + SMILE * x * x)
    for fp_id, x, up in (("8.6", -0.011, 1), ("8.2", 0.0, -1), ("8.7", 0.011, -1), ("8.8", -0.011, -1)):
        points[fp_index(fp_id)] = _at(x, 5 * MM - 40 * x * x, up * 6 * MM + SMILE * x * x)
    return points


def _turn(seed: int) -> np.ndarray:
    """A rotation drawn from `seed` (0: none)."""
    if seed == 0:
        return np.eye(3)
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_inner_points_on_the_crease_and_corners_at_the_slits_ends(seed):
    turn = _turn(seed)
    vertices, triangles = _mouth()
    carried = _carried()
    placed = carried @ turn.T
    moved = read_slit(placed, Surface(vertices @ turn.T, triangles), TEMPLATE_AXES @ turn.T)
    placed = placed @ turn  # back in the mouth's own frame
    assert set(moved) == {"2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9", "8.3", "8.4"}
    # the inner points on the crease, each on its own wall (upper above lower), within the reading's resolution
    # (the seen profile's bands: 2 x 0.1 x the carried mouth width of 54 mm over 40, 0.27 mm)
    for upper, lower, x in (("2.2", "2.3", 0.0), ("2.6", "2.8", None), ("2.7", "2.9", None)):
        u, lo = placed[fp_index(upper)], placed[fp_index(lower)]
        x = u[0] if x is None else x
        crease = _at(x, -40 * x * x, SMILE * x * x)
        assert np.linalg.norm(u - crease) < 0.3 * MM and np.linalg.norm(lo - crease) < 0.3 * MM
        assert u[2] > lo[2]
        # and each is its own wall's vertex (the vertex nearest it, as set-up reads an FP, is on its own lip)
        rows = np.argmin(np.linalg.norm(vertices - u, axis=1)), np.argmin(np.linalg.norm(vertices - lo, axis=1))
        assert [row % ROWS for row in rows] == [UPPER_WALL, LOWER_WALL]
        assert abs(u[0] - lo[0]) < 0.5 * MM
    # 2.2 in the middle, 2.6/2.7 where the registration had them along the lip (11 of 27 mm), on the read slit
    assert abs(placed[fp_index("2.2"), 0]) < 1e-9
    assert placed[fp_index("2.6"), 0] == pytest.approx(11 / 27 * HALF_SLIT, abs=0.5 * MM)
    assert placed[fp_index("2.7"), 0] == pytest.approx(-11 / 27 * HALF_SLIT, abs=0.5 * MM)
    # the corners where the slit ends, on the crease
    for fp_id, side in (("2.4", 1.0), ("2.5", -1.0)):
        corner = placed[fp_index(fp_id)]
        assert corner[0] == pytest.approx(side * HALF_SLIT, abs=0.5 * MM)
        x = corner[0]
        assert np.linalg.norm(corner - _at(x, -40 * x * x, SMILE * x * x)) < 0.3 * MM
    # the outer corners moved with the inner ones; the outer points on their own lips stayed
    for outer, inner in (("8.3", "2.4"), ("8.4", "2.5")):
        np.testing.assert_allclose(
            placed[fp_index(outer)] - carried[fp_index(outer)], placed[fp_index(inner)] - carried[fp_index(inner)]
        )
    np.testing.assert_allclose(placed[fp_index("8.1")], carried[fp_index("8.1")], atol=1e-12)
    np.testing.assert_allclose(placed[fp_index("8.2")], carried[fp_index("8.2")], atol=1e-12)


def test_an_outer_point_on_the_wrong_lip_moves_with_its_inner_point():
    vertices, triangles = _mouth()
    carried = _carried()
    carried[fp_index("8.1")] = _at(0.0, 5 * MM, -6 * MM)  # the upper lip's outer point on the lower lip
    placed = carried.copy()
    moved = read_slit(placed, Surface(vertices, triangles), TEMPLATE_AXES)
    assert "8.1" in moved and "8.2" not in moved
    np.testing.assert_allclose(
        placed[fp_index("8.1")] - carried[fp_index("8.1")], placed[fp_index("2.2")] - carried[fp_index("2.2")]
    )


def test_inner_points_already_on_their_own_lips_stay():
    vertices, triangles = _mouth()
    carried = _carried()
    for upper, lower, x in (("2.2", "2.3", 0.0), ("2.6", "2.8", 0.011), ("2.7", "2.9", -0.011)):
        carried[fp_index(upper)] = _at(x, 1.5 * MM - 40 * x * x, 1 * MM + SMILE * x * x)
        carried[fp_index(lower)] = _at(x, 1.5 * MM - 40 * x * x, -1 * MM + SMILE * x * x)
    placed = carried.copy()
    moved = read_slit(placed, Surface(vertices, triangles), TEMPLATE_AXES)
    assert set(moved) == {"2.4", "2.5", "8.3", "8.4"}
    assert placed[fp_index("2.4"), 0] == pytest.approx(HALF_SLIT, abs=0.5 * MM)
    inner = [fp_index(f) for f in ("2.2", "2.3", "2.6", "2.7", "2.8", "2.9")]
    np.testing.assert_array_equal(placed[inner], carried[inner])


@pytest.mark.parametrize("shape", ["crease without a pocket", "lips apart"])
def test_no_slit_changes_nothing(shape):
    if shape == "lips apart":
        vertices, triangles = _mouth(apart=3 * MM)
    else:
        vertices, triangles = _mouth(pocket=False)
    placed = _carried()
    assert read_slit(placed, Surface(vertices, triangles), TEMPLATE_AXES) == []
    np.testing.assert_array_equal(placed, _carried())
