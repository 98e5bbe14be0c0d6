"""Still Skin Around Eyes' smoothed share of the motion (`face_binding.smooth_follow`), on a sheet of skin."""

import numpy as np

from addon.deform.face_binding import smooth_follow
from addon.deform.planar_bones import bind, evaluate


def _sheet(n: int = 31, step: float = 0.001):
    """An n x n grid of vertices `step` apart in z = 0, a gentle bump in its middle, and its edges."""
    x, y = np.meshgrid(np.arange(n) * step, np.arange(n) * step, indexing="ij")
    centre = (n - 1) * step / 2
    z = 0.002 * np.exp(-((x - centre) ** 2 + (y - centre) ** 2) / (6 * step) ** 2)
    rest = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    index = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.column_stack([index[:-1].ravel(), index[1:].ravel()]),
                            np.column_stack([index[:, :-1].ravel(), index[:, 1:].ravel()])])  # fmt: skip
    return rest, edges


def _share(binding) -> np.ndarray:
    return np.bincount(binding.pair_vertex, binding.pair_weight, minlength=len(binding.rest_vertices))


def test_the_share_of_the_motion_is_smoothed_over_the_skin_never_raised():
    rest, edges = _sheet()
    control = np.array([[0.008, 0.008, 0.0], [0.022, 0.008, 0.0], [0.022, 0.022, 0.0], [0.008, 0.022, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])  # a square over the sheet's middle; a local radius, 3 mm
    binding = bind(rest, control, triangles, radius_fraction=0.3, cover=np.zeros(len(rest), bool), fade_below=0.2)
    before = _share(binding)
    smoothed = smooth_follow(binding, edges, 0.004, np.zeros(len(rest)))
    after = _share(smoothed)
    assert np.all(after <= before + 1e-12)  # no vertex takes more of the motion than the paper's weights give it
    jump = np.abs(np.diff(before[edges], axis=1)).max()
    assert jump > 0.9  # the local radius: a vertex off the plane (the bump) falls out almost at once
    assert np.abs(np.diff(after[edges], axis=1)).max() < 0.5 * jump
    assert after.max() > 0.9 and after[before == 1.0].mean() > 0.7  # inside, the skin still follows (most of) it
    # only the weights change: at rest the sheet stays where it is, the moved pairs are the same pairs
    np.testing.assert_allclose(evaluate(smoothed, control), rest, atol=1e-12)
    assert np.array_equal(smoothed.pair_vertex, binding.pair_vertex)
    assert (
        smooth_follow(binding, np.zeros((0, 2), int), 0.004, np.zeros(len(rest))) is binding
    )  # nothing to smooth along
    # pinned skin (at the control FPs) keeps its share wherever the pin is above the smoothed share
    pinned = np.where(np.linalg.norm(rest[:, :2] - control[0, :2], axis=1) < 0.002, 1.0, 0.0)
    kept = _share(smooth_follow(binding, edges, 0.004, pinned))
    np.testing.assert_allclose(kept[pinned == 1.0], before[pinned == 1.0])
    np.testing.assert_allclose(kept[pinned == 0.0], after[pinned == 0.0])
