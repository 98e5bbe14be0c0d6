"""The mouth and jaw's triangles move the cheek less away from the lips and jaw (`face_binding.fall_from_mouth`)."""

import numpy as np

from addon.deform.face_binding import MOUTH_REACH_PER_ES0, fall_from_mouth
from addon.deform.planar_bones import bind, evaluate


def _two_mouth_triangles():
    """A 40 mm square of skin (1 mm grid) under two mouth-and-jaw triangles: a lip corner (row 0, the one mouth FP)
    and three cheek FPs 40-57 mm away; its binding, the binding with the mouth's falloff, and ES0 (60 mm)."""
    n, step, es0 = 41, 0.001, 0.06
    x, y = np.meshgrid(np.arange(n) * step, np.arange(n) * step, indexing="ij")
    rest = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    control = np.array([[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.04, 0.04, 0.0], [0.0, 0.04, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    binding = bind(rest, control, triangles, cover=np.zeros(len(rest), bool), fade_below=0.2)
    return rest, control, binding, fall_from_mouth(binding, np.array([True, True]), [0], es0), es0


def test_a_lip_corner_moves_fully_and_the_cheek_toward_the_cheekbone_less():
    rest, control, binding, fallen, es0 = _two_mouth_triangles()
    moved = control.copy()
    moved[0, 0] -= 0.01  # the lip corner pulled 10 mm out
    before = np.linalg.norm(evaluate(binding, moved) - rest, axis=1)
    after = np.linalg.norm(evaluate(fallen, moved) - rest, axis=1)
    corner = int(np.argmin(np.linalg.norm(rest - [0.0, 0.0, 0.0], axis=1)))  # at it
    cheek = int(np.argmin(np.linalg.norm(rest - [0.02, 0.02, 0.0], axis=1)))  # 28 mm from the corner
    np.testing.assert_allclose(after[corner], before[corner], rtol=1e-9)  # at the lip: as the paper moves it
    assert before[corner] > 0.0099
    d = np.linalg.norm(rest[cheek] - control[0])
    expected = 1.0 - (d / (MOUTH_REACH_PER_ES0 * es0)) ** 2
    assert after[cheek] < 0.9 * before[cheek]  # the old linear interpolation moved it fully
    np.testing.assert_allclose(after[cheek], expected * before[cheek], rtol=1e-6)
    assert np.all(after <= before + 1e-12)  # never more than the paper's weights
    np.testing.assert_allclose(evaluate(fallen, control), rest, atol=1e-12)  # at rest, the skin stays
    # pairs on other triangles are untouched
    assert (
        fall_from_mouth(binding, np.array([False, False]), [0], es0).pair_weight.tolist()
        == binding.pair_weight.tolist()
    )


def test_skin_at_a_cheek_fp_of_a_mouth_triangle_still_follows_it_fully():
    # FAPs 39-42 (puff and lift the cheeks) move the cheek FPs that corner the mouth and jaw's triangles: the skin at
    # them follows as at every control FP; the falloff from the lips alone had moved it 1.1 of 10 mm
    rest, control, binding, fallen, es0 = _two_mouth_triangles()
    moved = control.copy()
    moved[2, 2] += 0.01  # the cheek FP puffed 10 mm out
    at_fp = int(np.argmin(np.linalg.norm(rest - control[2], axis=1)))
    np.testing.assert_allclose(evaluate(fallen, moved)[at_fp], evaluate(binding, moved)[at_fp], atol=1e-12)
    assert np.linalg.norm(evaluate(fallen, moved)[at_fp] - rest[at_fp]) > 0.0099


def _grid_edges(n: int, cut_below: int = 0) -> np.ndarray:
    """The edges of the n x n grid of `_two_mouth_triangles` (vertex i * n + j at x = i mm, y = j mm), without
    those across x = 10.5 mm for y < `cut_below` mm: a slit in the skin, as the mouth's opening is."""
    index = np.arange(n * n).reshape(n, n)
    along_x = np.column_stack([index[:-1].ravel(), index[1:].ravel()])
    along_y = np.column_stack([index[:, :-1].ravel(), index[:, 1:].ravel()])
    slit = (along_x[:, 0] // n == 10) & (along_x[:, 0] % n < cut_below)
    return np.concatenate([along_x[~slit], along_y])


def test_the_falloff_follows_the_skin_not_the_straight_line():
    """With the mesh's edges the distance from the lips is measured along the skin (over the edges and steps
    across two of them). On the flat grid it is the straight one at a vertex 15 mm along x and one 15 mm along the
    diagonal (the steps across two edges run diagonally): the falloff is as without edges, 1 - (d / R)². Across
    a slit from y = 0 to 38 mm at x = 10.5 mm, a vertex 15 mm from the lip corner in a straight line is more than
    2 x 38 mm away along the skin, around the slit's end, beyond R = 1.2 ES0 = 72 mm: it stays still, where the
    straight distance moved it by 1 - (15 / 72)² = 0.96 of the paper's motion. A vertex on the lip's side of the
    slit is as before."""
    rest, control, binding, fallen, es0 = _two_mouth_triangles()
    moved = control.copy()
    moved[0, 0] -= 0.01
    along_skin = fall_from_mouth(binding, np.array([True, True]), [0], es0, _grid_edges(41))
    straight = evaluate(fallen, moved)
    for point in ([0.015, 0.0, 0.0], [0.015, 0.015, 0.0]):
        k = int(np.argmin(np.linalg.norm(rest - point, axis=1)))
        np.testing.assert_allclose(evaluate(along_skin, moved)[k], straight[k], atol=1e-12)
    slit = evaluate(fall_from_mouth(binding, np.array([True, True]), [0], es0, _grid_edges(41, 38)), moved)
    beyond = int(np.argmin(np.linalg.norm(rest - [0.015, 0.0, 0.0], axis=1)))
    paper = np.linalg.norm(evaluate(binding, moved)[beyond] - rest[beyond])
    assert 2 * 0.038 > MOUTH_REACH_PER_ES0 * es0
    falloff = 1.0 - (0.015 / (MOUTH_REACH_PER_ES0 * es0)) ** 2
    np.testing.assert_allclose(np.linalg.norm(straight[beyond] - rest[beyond]), falloff * paper, rtol=1e-9)
    np.testing.assert_allclose(slit[beyond], rest[beyond], atol=1e-15)
    near = int(np.argmin(np.linalg.norm(rest - [0.005, 0.0, 0.0], axis=1)))
    np.testing.assert_allclose(slit[near], straight[near], atol=1e-12)
