"""Smoothing over a mesh's edges (`addon.geometry.surface_smoothing`), worked by hand."""

import numpy as np

from addon.geometry.surface_smoothing import MAX_STEPS, smooth_over_edges, smoothing_steps


def test_smoothing_over_edges_by_hand():
    """Path 0-1-2 and a lone vertex 3: each step moves a value halfway to its neighbours' mean; a vertex with no
    edge keeps its value; a constant stays constant; nothing crosses a missing (cut) edge."""
    edges = np.array([[0, 1], [1, 2]])
    values = np.array([[1.0, 2.0], [0.0, 2.0], [0.0, 2.0], [5.0, 2.0]])
    once = smooth_over_edges(values, edges, 1)
    np.testing.assert_allclose(once, [[0.5, 2.0], [0.25, 2.0], [0.0, 2.0], [5.0, 2.0]])
    np.testing.assert_allclose(smooth_over_edges(values, edges, 2)[:, 0], [0.375, 0.25, 0.125, 5.0])
    cut = smooth_over_edges(values, np.array([[1, 2]]), 3)
    assert cut[0, 0] == 1.0 and cut[2, 0] == 0.0  # vertex 0 has no edge left: it keeps its value


def test_smoothing_steps_spread_over_the_same_width_at_any_resolution():
    assert smoothing_steps(0.005, 0.0035) == 4  # the sample head's edges: 4 steps
    assert smoothing_steps(0.005, 0.0035 / 4) == 65  # a 16 times denser mesh: (4 x)² as many
    assert smoothing_steps(0.005, 0.01) == 0 and smoothing_steps(0.0, 0.001) == 0
    assert smoothing_steps(0.005, 1e-9) == MAX_STEPS


def test_smoothing_one_column_as_many():
    edges = np.array([[0, 1], [1, 2], [2, 0], [2, 3]])
    values = np.array([1.0, 0.0, 0.5, 0.25])
    np.testing.assert_allclose(smooth_over_edges(values, edges, 7), smooth_over_edges(values[:, None], edges, 7)[:, 0])
    assert np.array_equal(smooth_over_edges(values, edges, 0), values)
