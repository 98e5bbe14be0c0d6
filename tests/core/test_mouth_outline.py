"""The mouth and jaw's triangles stop at the outline other parts' FPs hold (`face_binding.stop_at_held_outline`)."""

import numpy as np

from addon.deform.face_binding import stop_at_held_outline
from addon.deform.planar_bones import bind, evaluate
from addon.deform.regions import APEX, EDGE, FACE

LIP, WING_L, WING_R, TIP = 0, 1, 2, 3  # control rows: a lip FP (group 8) and three of the nose's (group 9)


def _lip_under_nose():
    """A flat sheet (1 mm grid, x -40..40 mm, y -10..60 mm) under a mouth triangle (the lip FP at the origin, the
    nose's wings 30 mm above it) and the nose's triangle over it (the wings and the tip 20 mm higher). The mouth
    triangle's §3 radius is 20 mm (the tip's distance from its edge between the wings): it reaches 20 mm onto the
    nose. Returns the rest, the control points, the binding and the binding stopped at the held outline."""
    x, y = np.meshgrid(np.arange(-40, 41) * 1e-3, np.arange(-10, 61) * 1e-3, indexing="ij")
    rest = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    control = np.array([[0.0, 0.0, 0.0], [0.02, 0.03, 0.0], [-0.02, 0.03, 0.0], [0.0, 0.05, 0.0]])
    triangles = np.array([[LIP, WING_L, WING_R], [WING_R, WING_L, TIP]])
    binding = bind(rest, control, triangles, cover=np.zeros(len(rest), bool), fade_below=0.2)
    return rest, control, binding, stop_at_held_outline(binding, np.array([True, False]), [LIP])


def _at(rest, point):
    return int(np.argmin(np.linalg.norm(rest - point, axis=1)))


def test_the_mouth_triangles_pairs_past_the_nose_edge_and_corners_go_and_no_other():
    rest, control, binding, stopped = _lip_under_nose()
    on_mouth = binding.pair_triangle == 0
    region = binding.pair_region
    past_nose = on_mouth & (
        (region == EDGE + 1)  # the edge from the left wing (V_1) to the right (V_2)
        | (region == APEX + 1)
        | (region == APEX + 2)
    )
    assert np.count_nonzero(past_nose & (region == EDGE + 1)) > 50 and np.count_nonzero(past_nose & (region >= APEX))
    kept = ~past_nose
    assert stopped.n_pairs == np.count_nonzero(kept)
    # the rest, pair for pair: the mouth triangle's face region and its regions past the lip's edges and corner, and
    # all of the nose triangle's pairs (past its own edge down onto the lip's side too)
    for name in ("pair_vertex", "pair_triangle", "pair_region", "pair_weight", "pair_face_local"):
        np.testing.assert_array_equal(getattr(stopped, name), getattr(binding, name)[kept])
    assert set(np.unique(stopped.pair_region[stopped.pair_triangle == 0])) == {FACE, EDGE + 0, EDGE + 2, APEX + 0}
    # nothing goes when every FP is the mouth's, or no triangle is
    for mouth, rows in ((np.array([True, False]), [LIP, WING_L, WING_R, TIP]), (np.array([False, False]), [LIP])):
        assert stop_at_held_outline(binding, mouth, rows) is binding


def test_a_lip_pushed_out_no_longer_swings_the_nose_it_does_not_move():
    """The lip FP pushed 10 mm out of the sheet turns the mouth triangle about the wings' edge by atan(10 / 30) =
    18.4°. A vertex 5 mm past that edge on the nose was carried by eq. 12 with the edge's frame, 5 mm x 2 sin(9.2°)
    = 1.6 mm times the mouth triangle's share of its weights; stopped, only the nose's triangle moves it, whose FPs
    are still: it stays at rest. Skin inside the mouth triangle moves exactly as before."""
    rest, control, binding, stopped = _lip_under_nose()
    moved = control.copy()
    moved[LIP, 2] += 0.01
    before, after = evaluate(binding, moved), evaluate(stopped, moved)
    nose = _at(rest, [0.0, 0.035, 0.0])
    mouth_share = binding.pair_weight[(binding.pair_vertex == nose) & (binding.pair_triangle == 0)].sum()
    assert 0.0 < mouth_share < 1.0
    swing = np.linalg.norm(before[nose] - rest[nose])
    np.testing.assert_allclose(swing, mouth_share * 0.005 * 2.0 * np.sin(0.5 * np.arctan(1.0 / 3.0)), rtol=1e-6)
    np.testing.assert_allclose(after[nose], rest[nose], atol=1e-12)
    lip_side = _at(rest, [0.0, 0.01, 0.0])
    np.testing.assert_array_equal(after[lip_side], before[lip_side])
    assert np.linalg.norm(after[lip_side] - rest[lip_side]) > 0.003
    np.testing.assert_allclose(evaluate(stopped, control), rest, atol=1e-12)  # at rest, the skin stays


def test_a_vertex_on_the_held_edge_keeps_its_pair_whatever_rounding_files_it_under():
    """A vertex on the mouth triangle's nose edge, or at the wing FP itself, is on the triangle: rounding that puts
    it 1e-12 m past the edge (a mesh turned Y-up) must not take its pair away, where 0.1 mm past does."""
    control = np.array([[0.0, 0.0, 0.0], [0.02, 0.03, 0.0], [-0.02, 0.03, 0.0], [0.0, 0.05, 0.0]])
    triangles = np.array([[LIP, WING_L, WING_R], [WING_R, WING_L, TIP]])
    rest = np.array(
        [
            [0.0, 0.03 + 1e-12, 0.0],  # on the nose edge, rounded past it
            [0.02, 0.03 + 1e-12, 0.0],  # at the wing FP, rounded past its corner
            [0.0, 0.0301, 0.0],  # 0.1 mm past the edge: the nose's skin
            [0.0, 0.01, 0.0],  # inside the mouth triangle
        ]
    )
    binding = bind(rest, control, triangles, cover=np.zeros(len(rest), bool), fade_below=0.2)
    mouth = binding.pair_triangle == 0
    assert np.all(binding.pair_region[mouth & (binding.pair_vertex < 3)] != FACE)  # filed past the edge or corner
    stopped = stop_at_held_outline(binding, np.array([True, False]), [LIP])
    kept = set(stopped.pair_vertex[stopped.pair_triangle == 0].tolist())
    assert kept == {0, 1, 3}
