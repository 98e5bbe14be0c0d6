"""A mesh cut into pieces whose copies of a vertex coincide is bound as the one surface it shows
(`face_binding.welded`): what is measured along the skin runs across the seam, and a vertex's copies move alike."""

import numpy as np

from addon.deform.face_binding import MOUTH_REACH_PER_ES0, fall_from_mouth, smooth_follow, welded
from addon.deform.planar_bones import bind, evaluate


def _grid(n: int, step: float, bump: bool):
    """An n x n grid `step` apart in z = 0 (a bump in its middle with `bump`) and its edges, whole and cut along the
    column x = n // 2 into two pieces: that column's vertices copied at the end, the right piece's edges on the
    copies (as a character's face sewn to its scalp by coincident vertices). Returns rest, edges, the cut rest,
    its edges, the seam's vertices and their copies."""
    x, y = np.meshgrid(np.arange(n) * step, np.arange(n) * step, indexing="ij")
    centre = (n - 1) * step / 2
    z = 0.002 * np.exp(-((x - centre) ** 2 + (y - centre) ** 2) / (6 * step) ** 2) if bump else np.zeros_like(x)
    rest = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    index = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.column_stack([index[:-1].ravel(), index[1:].ravel()]),
                            np.column_stack([index[:, :-1].ravel(), index[:, 1:].ravel()])])  # fmt: skip
    seam = index[n // 2]
    copies = n * n + np.arange(n)
    cut_index = index.copy()
    cut_index[n // 2] = copies  # the right piece's own copy of the seam (rows n // 2 and on)
    piece = cut_index[n // 2 :]
    across = np.column_stack([piece[:-1].ravel(), piece[1:].ravel()])
    right = np.concatenate([across, np.column_stack([piece[:, :-1].ravel(), piece[:, 1:].ravel()])])
    left = edges[(edges < n * n).all(axis=1) & (np.max(edges // n, axis=1) <= n // 2)]
    left = left[~((left // n == n // 2).all(axis=1))]  # the seam's own edges go with the right piece
    return rest, edges, np.concatenate([rest, rest[seam]]), np.concatenate([left, right]), seam, copies


def _share(binding) -> np.ndarray:
    return np.bincount(binding.pair_vertex, binding.pair_weight, minlength=len(binding.rest_vertices))


def test_the_stand_ins_are_the_first_copies_and_a_whole_mesh_keeps_its_edges():
    rest, edges, cut, cut_edges, seam, copies = _grid(5, 0.001, False)
    same, joined = welded(cut, cut_edges)
    assert np.array_equal(same[copies], seam) and np.array_equal(same[: len(rest)], np.arange(len(rest)))
    assert {tuple(e) for e in joined.tolist()} == {tuple(sorted(e)) for e in edges.tolist()}
    same, kept = welded(rest, edges)
    assert np.array_equal(same, np.arange(len(rest))) and kept is not None and np.array_equal(kept, edges)


def test_a_seam_of_coincident_copies_smooths_the_share_of_the_motion_as_the_whole_skin():
    """Still Skin's smoothing across a seam: each copy takes the share the uncut sheet gives that vertex. Smoothed on
    each piece alone (before), the copies took 0.35 and 0.50 of the motion by the Rocketbox male's ear, moved apart
    and their faces crossed in every frame of joy.fap; on this grid by up to 0.056."""
    rest, edges, cut, cut_edges, seam, copies = _grid(31, 0.001, True)
    control = np.array([[0.008, 0.008, 0.0], [0.022, 0.008, 0.0], [0.022, 0.022, 0.0], [0.008, 0.022, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])

    def smoothed(points, mesh_edges):
        binding = bind(points, control, triangles, radius_fraction=0.3, cover=np.zeros(len(points), bool),
                       fade_below=0.2)  # fmt: skip
        return smooth_follow(binding, mesh_edges, 0.004, np.zeros(len(points)))

    whole, cut_binding = _share(smoothed(rest, edges)), smoothed(cut, cut_edges)
    share = _share(cut_binding)
    np.testing.assert_array_equal(share[copies], share[seam])
    np.testing.assert_allclose(share[: len(rest)], whole, atol=1e-12)
    moved = control + [0.0, 0.0, 0.003]
    played = evaluate(cut_binding, moved)
    np.testing.assert_array_equal(played[copies], played[seam])  # the copies move as one vertex


def test_the_mouths_falloff_runs_across_a_seam_of_coincident_copies():
    """The distance from the lips along the skin crosses the seam as it crosses any edge: skin past it falls off as
    on the uncut sheet (before: unreached, so still)."""
    n, step, es0 = 41, 0.001, 0.06
    rest, edges, cut, cut_edges, seam, copies = _grid(n, step, False)
    control = np.array([[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.04, 0.04, 0.0], [0.0, 0.04, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    moved = control.copy()
    moved[0, 0] -= 0.01

    def played(points, mesh_edges):
        binding = bind(points, control, triangles, cover=np.zeros(len(points), bool), fade_below=0.2)
        return evaluate(fall_from_mouth(binding, np.array([True, True]), [0], es0, mesh_edges), moved)

    whole, cut_played = played(rest, edges), played(cut, cut_edges)
    np.testing.assert_allclose(cut_played[: len(rest)], whole, atol=1e-15)
    np.testing.assert_array_equal(cut_played[copies], cut_played[seam])
    past = int(np.argmin(np.linalg.norm(rest - [0.03, 0.0, 0.0], axis=1)))  # 30 mm from the lips, past the seam
    assert 0.03 < MOUTH_REACH_PER_ES0 * es0 and np.linalg.norm(cut_played[past] - rest[past]) > 1e-3
