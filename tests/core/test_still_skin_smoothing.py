"""Still Skin Around Eyes' smoothed share of the motion (`face_binding.smooth_follow`), on a sheet of skin."""

import numpy as np

from addon.deform.face_binding import bind_face, joined_share, smooth_follow
from addon.deform.planar_bones import bind, evaluate
from addon.mpeg4.control_mesh import EYES


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


def test_joined_share_is_the_widest_paths_share_from_the_sources_by_hand():
    """A path 0-1-2-3-4 and a way round 0-5-2; 6-7 a piece of its own, with no source."""
    share = np.array([0.3, 0.5, 0.9, 0.0, 0.8, 0.7, 0.4, 0.2])
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [0, 5], [5, 2], [6, 7]])
    pieces = np.array([0, 0, 0, 0, 0, 0, 1, 1])
    joined = joined_share(share, edges, np.arange(8), [0], pieces)
    # 0 is a source (whatever its own share); 2 is reached through 5 (0.7), not 1 (0.5); 3 stays still, so 4 behind
    # it is cut off however much it moves; the piece with no source is not held
    np.testing.assert_array_equal(joined, [1.0, 0.5, 0.7, 0.0, 0.0, 0.7, 1.0, 1.0])
    # a copy of vertex 2 at its place (its stand-in 2) takes its stand-in's value, and lends it its share
    same = np.array([0, 1, 2, 3, 4, 5, 6, 7, 2])
    joined = joined_share(np.append(share, 1.0), edges, same, [0], np.append(pieces, 2))
    assert joined[8] == joined[2] == 0.7


def test_an_island_of_skin_cut_off_from_the_fps_by_still_skin_stays_still():
    """The eyes' control triangles reach only the skin nearest their planes, so their share of the motion is ragged:
    on the scan, single vertices 4-8 mm from an eye's outer corner took 0.65-1.0 of a lid triangle's motion with
    every neighbour still, and the pin at the corner's FP (by the straight distance) kept it through the smoothing:
    with the cheeks' lift they rose past the still skin beside them and crossed it. Here a vertex on a flat sheet
    whose four neighbours are raised off the control triangles' plane, out of their reach: before, it kept 0.95 of
    the motion and rose 0.40 mm with the far corner's 3 mm; now it stays, and the skin joined to the FP keeps its
    pin."""
    rest, edges = _sheet()
    rest[:, 2] = 0.0
    n = 31
    island = 10 * n + 10  # at (10, 10) mm, 2.8 mm from the control FP at (8, 8)
    rest[[island - n, island + n, island - 1, island + 1], 2] = 0.003
    control = np.array([[0.008, 0.008, 0.0], [0.022, 0.008, 0.0], [0.022, 0.022, 0.0], [0.008, 0.022, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    binding = bind_face(rest, control, triangles, es0=0.06, triangle_parts=[EYES, EYES], edges=edges)
    share = _share(binding)
    assert share[island - 1] == 0.0 and share[island + 1] == 0.0  # its neighbours are out of reach
    moved = control.copy()
    moved[2, 2] += 0.003
    played = evaluate(binding, moved)
    assert np.abs(played[island] - rest[island]).max() < 1e-12
    # on the plane, joined to the FP at (8, 8): its pin (1 - (d / 12 mm)²) still holds
    beside = 9 * n + 9  # (9, 9) mm: 1.4 mm from the FP
    assert share[beside] >= 1.0 - 2 * (0.001 / 0.012) ** 2 - 1e-12
    assert played[beside, 2] > 0.0
