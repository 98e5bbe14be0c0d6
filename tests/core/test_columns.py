"""Vertical lines through triangles seen from the front (`geometry.columns`), worked by hand."""

import numpy as np

from addon.geometry.columns import column_cuts, column_gaps

# three triangles (x, y, depth): one from y 0 to 2 at x = 1, one from 3 to 4, one from 3.5 to 6 (overlapping the
# second), and one the line at x = 1 misses
TRIANGLES = np.array(
    [
        [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [1.0, 2.0, 3.0]],
        [[0.0, 3.0, 0.0], [2.0, 3.0, 0.0], [1.0, 4.0, 2.0]],
        [[0.0, 3.5, 5.0], [2.0, 3.5, 5.0], [1.0, 6.0, 5.0]],
        [[5.0, 0.0, 0.0], [6.0, 0.0, 0.0], [5.5, 9.0, 0.0]],
    ]
)


def test_the_line_crosses_each_triangle_it_meets_from_its_lowest_to_its_highest_point():
    lows, highs = column_cuts(TRIANGLES, 1.0)
    np.testing.assert_allclose(lows, [[0.0, 1.0], [3.0, 0.0], [3.5, 5.0]])
    np.testing.assert_allclose(highs, [[2.0, 3.0], [4.0, 2.0], [6.0, 5.0]])
    lows, highs = column_cuts(TRIANGLES, 0.5)  # half way up the first triangle's left edge
    np.testing.assert_allclose(lows[0], [0.0, 1.0])
    np.testing.assert_allclose(highs[0], [1.0, 2.0])


def test_the_gaps_are_bounded_by_the_crossings_either_side():
    below, above = column_gaps(*column_cuts(TRIANGLES, 1.0))
    # one gap, y 2 to 3: the first triangle's top below it, the second's bottom above it; the third overlaps the
    # second, so there is none between them
    np.testing.assert_allclose(below, [[2.0, 3.0]])
    np.testing.assert_allclose(above, [[3.0, 0.0]])
    below, above = column_gaps(*column_cuts(TRIANGLES[[2, 0]], 1.0))  # any order
    np.testing.assert_allclose(below, [[2.0, 3.0]])
    np.testing.assert_allclose(above, [[3.5, 5.0]])


def test_a_gap_below_a_tall_crossing_is_bounded_by_its_top():
    # a tall triangle from y 0 to 5 and a short one inside it from 1 to 2, then one from 7: the gap is 5 to 7,
    # its floor the tall triangle's top, not the short one's
    tall = [[0.0, 0.0, 9.0], [2.0, 0.0, 9.0], [1.0, 5.0, 8.0]]
    short = [[0.0, 1.0, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]]
    top = [[0.0, 7.0, 4.0], [2.0, 7.0, 4.0], [1.0, 8.0, 4.0]]
    below, above = column_gaps(*column_cuts(np.array([tall, short, top]), 1.0))
    np.testing.assert_allclose(below, [[5.0, 8.0]])
    np.testing.assert_allclose(above, [[7.0, 4.0]])
