"""Placement's faster paths give what the plain ones gave: the trimming quantile, the edges and borders by one
integer key, the width profile read off runs of sorted heights, and closest points with each candidate triangle
measured once."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.placement.nicp import border_vertices, edges_of
from addon.placement.rigid import SLABS, _widest, linear_quantile, trimmed
from addon.placement.surface import Surface, _repeated, closest_on_triangles


def test_trimmed_keeps_what_numpys_quantile_keeps_with_ties_and_any_length():
    rng = np.random.default_rng(0)
    for n in [*range(1, 40), 299, 1295, 4000]:
        for values in (rng.normal(size=n), np.round(rng.normal(size=n), 1), np.full(n, 0.25)):
            for share in (0.0, 0.02, 0.25, 0.5, 0.8, 0.95, 0.98, 1.0):
                assert linear_quantile(values, share) == np.quantile(values, share)
                assert np.array_equal(trimmed(values, share), values <= np.quantile(values, share))


def test_trimmed_on_a_hand_worked_case():
    # sorted 1, 3, 4, 10, 20: the 0.8 quantile is at position 0.8 * 4 = 3.2, between 10 and 20: 12; the 0.5
    # quantile is the middle value, 4; four equal values at the top: all kept
    values = np.array([10.0, 1.0, 4.0, 3.0, 20.0])
    assert trimmed(values, 0.8).tolist() == [True, True, True, True, False]
    assert trimmed(values, 0.5).tolist() == [False, True, True, True, False]
    assert trimmed(np.array([2.0, 1.0, 2.0, 2.0, 2.0]), 0.8).all()


def test_edges_and_border_of_two_triangles_by_hand():
    triangles = np.array([[0, 1, 2], [2, 1, 3]], dtype=np.int32)
    assert edges_of(triangles).tolist() == [[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]
    assert border_vertices(triangles, 5).tolist() == [True, True, True, True, False]  # 1-2 shared; 4 unused


def test_edges_and_border_equal_the_row_wise_unique_on_a_random_mesh():
    rng = np.random.default_rng(1)
    triangles = rng.integers(0, 300, size=(2000, 3))
    pairs = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(pairs, axis=0, return_counts=True)
    border = np.zeros(300, dtype=bool)
    border[unique[counts == 1].ravel()] = True
    assert np.array_equal(edges_of(triangles), unique)
    assert np.array_equal(border_vertices(triangles, 300), border)


def test_repeated_marks_every_later_copy_in_its_row():
    rows = np.array([[3, -1, 3, 5, 5, -1], [7, 6, 5, 4, 3, 2]])
    assert _repeated(rows).tolist() == [[False, False, True, False, True, True], [False] * 6]


def test_locate_finds_the_closest_point_of_all_triangles_on_a_bumpy_grid():
    """Each query's closest point among the triangles around its nearest vertices, the repeated ones measured
    once, is the closest point over every triangle (points near a fine mesh), and lies on the triangle named."""
    u, v = np.meshgrid(np.linspace(0, 1, 15), np.linspace(0, 1, 15))
    vertices = np.stack([u.ravel(), v.ravel(), 0.05 * np.sin(6 * u.ravel()) * np.cos(5 * v.ravel())], axis=1)
    index = np.arange(225).reshape(15, 15)
    quads = np.stack([index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]], axis=-1).reshape(-1, 4)
    triangles = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    rng = np.random.default_rng(2)
    points = np.c_[rng.uniform(0.1, 0.9, (300, 2)), rng.uniform(-0.02, 0.02, 300)]
    found, triangle, weights = Surface(vertices, triangles).locate(points)
    every = np.stack(
        [closest_on_triangles(points, *(np.tile(vertices[t], (300, 1)) for t in tri)) for tri in triangles]
    )
    best = np.sqrt(((every - points) ** 2).sum(2)).min(0)
    assert np.allclose(np.linalg.norm(found - points, axis=1), best, atol=1e-12)
    assert np.allclose(np.einsum("kj,kjd->kd", weights, vertices[triangles[triangle]]), found, atol=1e-12)


def _widest_by_masks(across, height, head_height):
    """The width profile as it was first written: each slab a mask over all the points."""
    top = height.max()
    step = head_height / SLABS
    widest = 0.0
    for k in range(2 * SLABS):
        inside = (height <= top - k * step) & (height > top - (k + 1) * step)
        if inside.sum() < 3:
            continue
        width = float(np.percentile(across[inside], 98) - np.percentile(across[inside], 2))
        if widest and width < 0.7 * widest and k > SLABS // 3:
            break
        widest = max(widest, width)
    return widest


def test_the_width_profile_from_sorted_heights_is_the_one_from_masks():
    rng = np.random.default_rng(3)
    for _trial in range(20):
        height = rng.uniform(0.0, 0.3, 400)
        across = rng.normal(size=400) * (0.1 + (height > 0.15))  # a wide head over a narrow neck
        height[:40] = np.round(height[:40], 2)  # heights on slab boundaries
        assert _widest(across, height, 0.2) == _widest_by_masks(across, height, 0.2)
