"""The corner's pit of a welded mouth (`scripts.bench.welded_mouth.pit`): on a hand-made face (a sheet curving back
to the cheeks with a dent 2 mm deep at the mouth's corner) the skin's most concave point near the corner is the
dent's bottom, at any scale of the head."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from scripts.bench.welded_mouth import pit, skin

MM = 0.001
CORNER = np.array([25 * MM, 2 * MM])  # the dent's (left, up)


def _forward(x, z):
    """How far forward the skin is at (left x, up z): curving back to the sides, the dent at the corner."""
    dent = 2 * MM * np.exp(-((x - CORNER[0]) ** 2 + (z - CORNER[1]) ** 2) / (2 * (2.5 * MM) ** 2))
    return -8.0 * x * x - 4.0 * z * z - dent


def _face(size: float):
    """The sheet, 0.5 mm apart, in axes left x, up y, forward z, scaled by `size`."""
    xs, zs = np.linspace(0.0, 0.05, 101), np.linspace(-0.02, 0.025, 91)
    gx, gz = np.meshgrid(xs, zs, indexing="ij")
    vertices = np.column_stack([gx.ravel(), gz.ravel(), _forward(gx, gz).ravel()]) * size
    n = len(zs)
    triangles = []
    for i in range(len(xs) - 1):
        for k in range(n - 1):
            a, b = i * n + k, i * n + k + 1
            triangles += [(a, a + n, b), (b, a + n, b + n)]  # facing forward (+z)
    return vertices, np.array(triangles)


@pytest.mark.parametrize("size", [1.0, 10.0])
def test_the_pit_is_the_dent_at_the_corner(size):
    vertices, triangles = _face(size)
    x, z = CORNER[0] + 2 * MM, CORNER[1] + 3 * MM  # a corner placed 3.6 mm from the dent
    found = pit(skin(vertices, triangles), np.array([x, z, _forward(x, z)]) * size, size)
    np.testing.assert_allclose(found[:2] / size, CORNER, atol=0.4 * MM)
