"""Planar Bones / SoFFD deformer: invariants, hand-worked regions, masks, radii, degenerate input."""

import io

import numpy as np
import pytest

from addon.deform import planar_bones
from addon.deform.planar_bones import (
    CHUNK,
    DeformError,
    bind,
    cover_over_control_mesh,
    evaluate,
    load_binding,
    save_binding,
)
from addon.deform.regions import APEX, EDGE, FACE, deformation_basis, locate, triangle_frames

MODES = ("planar_bones", "soffd")


def icosahedron(radius: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    g = (1.0 + 5.0**0.5) / 2.0
    points = np.array(
        [
            [-1, g, 0],
            [1, g, 0],
            [-1, -g, 0],
            [1, -g, 0],
            [0, -1, g],
            [0, 1, g],
            [0, -1, -g],
            [0, 1, -g],
            [g, 0, -1],
            [g, 0, 1],
            [-g, 0, -1],
            [-g, 0, 1],
        ],
        dtype=float,
    )
    triangles = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ]
    )
    return radius * points / np.linalg.norm(points[0]), triangles


def sphere_points(n: int, radius: float = 0.1, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    directions = rng.standard_normal((n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return radius * directions * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, (n, 1)))


def random_rigid(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q)), rng.standard_normal(3)


@pytest.fixture(scope="module")
def sphere():
    control, triangles = icosahedron()
    rest = sphere_points(3000)
    return rest, control, triangles, bind(rest, control, triangles)


@pytest.mark.parametrize("mode", MODES)
def test_identity_reproduces_rest_pose(sphere, mode):
    rest, control, _, binding = sphere
    assert binding.n_static == 0
    assert np.abs(evaluate(binding, control, mode) - rest).max() < 1e-9


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_rigid_motion_moves_every_vertex_rigidly(sphere, mode, seed):
    rest, control, _, binding = sphere
    rotation, translation = random_rigid(seed)
    moved = evaluate(binding, control @ rotation.T + translation, mode)
    assert np.abs(moved - (rest @ rotation.T + translation)).max() < 1e-6


@pytest.mark.parametrize("mode", MODES)
def test_float32_output_matches_float64(sphere, mode):
    _, control, _, binding = sphere
    deformed = control + 0.01 * np.sin(50.0 * control)
    single = evaluate(binding, deformed, mode, out=np.empty((binding.n_vertices, 3), np.float32))
    assert np.abs(single - evaluate(binding, deformed, mode)).max() < 1e-6


def test_planar_bones_and_soffd_differ_under_stretch(sphere):
    _, control, _, binding = sphere
    stretched = control * np.array([1.5, 1.0, 0.7])
    difference = np.abs(evaluate(binding, stretched) - evaluate(binding, stretched, "soffd")).max()
    assert difference > 1e-4


def reference_evaluate(binding, control: np.ndarray, mode: str) -> np.ndarray:
    """Eq. 8 pair by pair, straight from the `Binding` fields and eq. 1 / 12 / 13 (d_j as a norm)."""
    rows = deformation_basis(control[binding.triangles])[binding.pair_triangle]  # (P, 7, 3)
    corners, normal, edge_normals = rows[:, :3], rows[:, 3], rows[:, 4:]
    alpha, beta, h = binding.pair_face_local.T
    images = (1 - alpha - beta)[:, None] * corners[:, 0] + alpha[:, None] * corners[:, 1]
    images += beta[:, None] * corners[:, 2] + h[:, None] * normal
    if mode == "planar_bones":
        pairs = np.arange(binding.n_pairs)
        j = (binding.pair_region.astype(int) - 1) % 3
        x, y, h_region = binding.pair_region_local.T
        common = corners[pairs, j] + h_region[:, None] * normal
        edge = common + x[:, None] * (corners[pairs, (j + 1) % 3] - corners[pairs, j])
        edge += y[:, None] * edge_normals[pairs, j]
        in_plane = x[:, None] * edge_normals[pairs, j] + y[:, None] * edge_normals[pairs, (j + 2) % 3]
        d = np.linalg.norm(in_plane, axis=1)
        scale = np.divide(binding.pair_apex_distance, d, out=np.zeros_like(d), where=d > 0)
        apex = common + in_plane * scale[:, None]
        region = binding.pair_region[:, None]
        images = np.where(region == FACE, images, np.where(region >= APEX, apex, edge))
    result = binding.rest_vertices.copy()
    moved = np.unique(binding.pair_vertex)
    result[moved] = 0.0
    np.add.at(result, binding.pair_vertex, binding.pair_weight[:, None] * images)
    return result


@pytest.mark.parametrize("mode", MODES)
def test_evaluate_matches_pair_by_pair_reference(mode):
    # Runs of many sizes around the chunk length, all three region kinds, static vertices.
    control, triangles = icosahedron()
    near, far = sphere_points(9 * CHUNK + 7, seed=3), sphere_points(CHUNK - 1, radius=0.2, seed=4)
    rest = np.concatenate([near, far])
    binding = bind(rest, control, triangles, radius_fraction=0.6, cover=np.arange(len(rest)) < 9 * CHUNK)
    assert binding.n_static > 0 and len(np.unique(binding.pair_region)) == 7
    assert np.bincount(binding.pair_triangle).max() > CHUNK
    rng = np.random.default_rng(11)
    for _ in range(3):
        deformed = control + rng.normal(0.0, 0.02, control.shape)
        expected = reference_evaluate(binding, deformed, mode)
        np.testing.assert_allclose(evaluate(binding, deformed, mode), expected, rtol=0, atol=1e-15)
        single = evaluate(binding, deformed, mode, out=np.empty((len(rest), 3), np.float32))
        np.testing.assert_allclose(single, expected, rtol=0, atol=1e-7)


def test_repeated_evaluation_does_not_depend_on_the_previous_frame(sphere):
    _, control, _, binding = sphere
    first, second = control * 1.2, control + 0.01 * np.sin(20.0 * control)
    expected = evaluate(binding, second)
    evaluate(binding, first)
    evaluate(binding, first, "soffd")
    assert np.array_equal(evaluate(binding, second), expected)


def test_binding_with_no_pairs_returns_the_rest_pose():
    rest = np.array([[1.0, 1.0, 1.0], [2.0, 0.0, 0.0]])
    binding = bind(rest, np.array([O, P, Q]), np.array([[0, 1, 2]]), cover=np.zeros(2, bool))
    assert binding.n_pairs == 0 and binding.n_static == 2
    for mode in MODES:
        assert evaluate(binding, np.array([o, p, q]), mode).tobytes() == rest.tobytes()


# ---------------------------------------------------------------- hand-worked single triangle

O, P, Q = np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])  # noqa: E741
o, p, q = np.array([0.0, 0.0, 0.0]), np.array([4.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0])
FACE_POINT = np.array([0.5, 0.25, 0.3])
EDGE_POINT = np.array([1.0, -0.5, 0.2])
APEX_POINT = np.array([3.0, -1.0, 0.1])


@pytest.fixture(scope="module")
def single_triangle():
    rest = np.array([FACE_POINT, EDGE_POINT, APEX_POINT])
    binding = bind(rest, np.array([O, P, Q]), np.array([[0, 1, 2]]))
    return binding, evaluate(binding, np.array([o, p, q])), evaluate(binding, np.array([o, p, q]), "soffd")


def test_hand_worked_regions(single_triangle):
    binding, _, _ = single_triangle
    assert binding.pair_region.tolist() == [FACE, EDGE + 0, APEX + 1]
    # No other control point: the radius starts at 0 and is raised to cover all three points.
    assert binding.n_raised == 1
    assert binding.affection_radius[0] == pytest.approx(1.1 * np.hypot(np.hypot(1.0, 1.0), 0.1), rel=1e-8)


def test_hand_worked_face_region(single_triangle):
    _, planar, soffd = single_triangle
    # A rows (2,0,0), (0,1,0), (0,0,1): (α, β, h) = (0.5/2, 0.25/1, 0.3); eq. 1 with n' = (0,0,1).
    expected = o + 0.25 * (p - o) + 0.25 * (q - o) + 0.3 * np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(planar[0], [1.25, 0.25, 0.3], atol=1e-12)
    np.testing.assert_allclose(planar[0], expected, atol=1e-12)
    np.testing.assert_allclose(soffd[0], expected, atol=1e-12)


def test_hand_worked_edge_region(single_triangle):
    _, planar, soffd = single_triangle
    # Edge 0 = OP, e_0 = (2,0,0), b_0 = unit(e_0 × n) = (0,-1,0); S − O = (1,-0.5,0.2):
    # x = 1/2, y = 0.5, h = 0.2. Deformed: e_0' = (4,0,0), b_0' = (0,-1,0), n' = (0,0,1). Eq. 12:
    expected = o + 0.5 * np.array([4.0, 0.0, 0.0]) + 0.5 * np.array([0.0, -1.0, 0.0]) + 0.2 * np.array([0, 0, 1])
    np.testing.assert_allclose(planar[1], [2.0, -0.5, 0.2], atol=1e-12)
    np.testing.assert_allclose(planar[1], expected, atol=1e-12)
    # SoFFD (eq. 1): (α, β, h) = (0.5, -0.5, 0.2) → 0.5 p − 0.5 q + 0.2 n' shears the point.
    np.testing.assert_allclose(soffd[1], [1.5, -0.5, 0.2], atol=1e-12)


def test_hand_worked_apex_region(single_triangle):
    _, planar, _ = single_triangle
    # Apex 1 = P. c_0 = 3 > ‖e_0‖ = 2 → R_C,1 (eq. 5). C_1 rows: b_1 = unit((-2,1,0) × n) = (1,2,0)/√5,
    # b_0 = (0,-1,0), n. S − P = (1,-1,0.1) = a b_1 + b b_0 + h n → a = √5, b = 3, h = 0.1; D = √2.
    # Deformed: e_1' = q − p = (-3,1,0) → b_1' = (1,3,0)/√10, b_0' = (0,-1,0).
    a, b, h, big_d = 5.0**0.5, 3.0, 0.1, 2.0**0.5
    mapped = a * np.array([1.0, 3.0, 0.0]) / 10.0**0.5 + b * np.array([0.0, -1.0, 0.0])
    small_d = (mapped[0] ** 2 + mapped[1] ** 2) ** 0.5  # eq. 14
    expected = p + mapped * big_d / small_d + h * np.array([0.0, 0.0, 1.0])  # eq. 13
    np.testing.assert_allclose(planar[2], expected, atol=1e-12)
    np.testing.assert_allclose(planar[2], [4.886631, -1.101764, 0.1], atol=1e-6)
    assert np.linalg.norm(planar[2] - p) == pytest.approx(np.linalg.norm(APEX_POINT - P), rel=1e-12)


def obtuse_triangle_distance(point: np.ndarray, corners: np.ndarray) -> float:
    """Brute-force reference: min over the inside projection and the three clamped segments."""
    origin, edge_1, edge_2 = corners[0], corners[1] - corners[0], corners[2] - corners[0]
    normal = np.cross(edge_1, edge_2)
    normal /= np.linalg.norm(normal)
    height = (point - origin) @ normal
    gram = np.array([[edge_1 @ edge_1, edge_1 @ edge_2], [edge_1 @ edge_2, edge_2 @ edge_2]])
    u, v = np.linalg.solve(gram, [(point - origin) @ edge_1, (point - origin) @ edge_2])
    best = abs(height) if (u >= 0 and v >= 0 and u + v <= 1) else np.inf
    for j in range(3):
        start, end = corners[j], corners[(j + 1) % 3]
        t = np.clip((point - start) @ (end - start) / ((end - start) @ (end - start)), 0.0, 1.0)
        best = min(best, np.linalg.norm(point - (start + t * (end - start))))
    return best


def test_region_distance_is_point_triangle_distance_for_obtuse_triangles():
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.1, 0.05]])  # ~174° at V_0
    frames = triangle_frames(corners[None])
    points = np.random.default_rng(4).uniform(-12.0, 12.0, (4000, 3))
    points = np.concatenate([points, [[-10.0, 0.0, 0.3]]])  # behind the obtuse apex, beyond V_2
    location = locate(frames, 0, points)
    reference = np.array([obtuse_triangle_distance(s, corners) for s in points])
    np.testing.assert_allclose(location.distance, reference, rtol=1e-9, atol=1e-12)
    assert location.region[-1] == APEX + 2


# ---------------------------------------------------------------- continuity


def sheet(spacing: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """A bumpy 4 × 4 control grid, 18 triangles."""
    x, y = np.meshgrid(np.arange(4) * spacing, np.arange(4) * spacing, indexing="ij")
    z = 0.3 * spacing * np.sin(x / spacing * 1.7) * np.cos(y / spacing * 1.3)
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    triangles = []
    for i in range(3):
        for j in range(3):
            a, b, c, d = 4 * i + j, 4 * (i + 1) + j, 4 * (i + 1) + j + 1, 4 * i + j + 1
            triangles += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return points, np.array(triangles)


@pytest.mark.parametrize("mode", MODES)
def test_deformation_is_continuous_across_regions_and_triangles(mode):
    control, triangles = sheet()
    rng = np.random.default_rng(5)
    steps = np.linspace(0.0, 1.0, 1501)
    step_length = []
    walks = []
    for _ in range(12):
        start = np.r_[rng.uniform(0.005, 0.055, 2), rng.uniform(-0.006, 0.006)]
        end = np.r_[rng.uniform(0.005, 0.055, 2), rng.uniform(-0.006, 0.006)]
        walks.append(start + steps[:, None] * (end - start))
        step_length.append(np.linalg.norm(end - start) / (len(steps) - 1))
    rest = np.concatenate(walks)
    binding = bind(rest, control, triangles)
    deformed = control + rng.normal(0.0, 0.004, control.shape)
    moved = evaluate(binding, deformed, mode).reshape(len(walks), len(steps), 3)
    jumps = np.linalg.norm(np.diff(moved, axis=1), axis=2)
    assert (jumps.max(axis=1) <= 50.0 * np.array(step_length)).all()
    # The walks do cross regions and enter and leave affection volumes.
    for walk in range(len(walks)):
        on_walk = binding.pair_vertex // len(steps) == walk
        assert len(np.unique(binding.pair_region[on_walk])) >= 5
        assert len(np.unique(binding.pair_triangle[on_walk])) >= 6


# ---------------------------------------------------------------- masks and radii


def lips() -> tuple[np.ndarray, np.ndarray]:
    upper = [[0.0, 0.005, 0.0], [0.04, 0.005, 0.0], [0.02, 0.025, 0.0]]
    lower = [[0.0, -0.005, 0.0], [0.04, -0.005, 0.0], [0.02, -0.025, 0.0]]
    return np.array(upper + lower), np.array([[0, 1, 2], [3, 5, 4]])


def test_mask_keeps_lower_lip_still_when_upper_lip_moves():
    control, triangles = lips()
    rest = np.array([[0.02, -0.0045, 0.001], [0.02, -0.015, 0.0], [0.02, 0.01, 0.0]])  # lower ×2, upper
    moved = control.copy()
    moved[:3] += [0.0, 0.004, 0.001]  # only the upper-lip feature points
    unmasked = bind(rest, control, triangles, radius_fraction=2.0)
    assert np.linalg.norm(evaluate(unmasked, moved)[0] - rest[0]) > 1e-4  # upper lip pulls lower lip
    upper_lip = np.array([0.0, 0.0, 1.0])  # mask weight of the upper-lip triangle per vertex
    masked = bind(
        rest,
        control,
        triangles,
        radius_fraction=2.0,
        vertex_masks={"upper": upper_lip},
        triangle_masks=["upper", None],
    )
    result = evaluate(masked, moved)
    np.testing.assert_allclose(result[:2], rest[:2], atol=1e-12)
    assert np.linalg.norm(result[2] - rest[2]) > 1e-3


def test_affection_radius_is_distance_to_nearest_other_feature_point():
    control, triangles = lips()
    binding = bind(np.zeros((1, 3)), control, triangles, radius_fraction=0.5, cover=np.zeros(1, bool))
    np.testing.assert_allclose(binding.affection_radius, [0.005, 0.005], rtol=1e-12)  # 0.5 × 0.01
    assert binding.n_raised == 0


def test_radius_fraction_per_triangle():
    control, triangles = lips()
    binding = bind(np.zeros((1, 3)), control, triangles, radius_fraction=np.array([0.5, 2.0]), cover=np.zeros(1, bool))
    np.testing.assert_allclose(binding.affection_radius, [0.005, 0.02], rtol=1e-12)
    rest = sphere_points(200, radius=0.02)
    one, same = (
        bind(rest, control, triangles, radius_fraction=0.7),
        bind(rest, control, triangles, radius_fraction=[0.7] * 2),
    )
    for name in ("pair_vertex", "pair_triangle", "pair_weight", "affection_radius"):
        assert getattr(one, name).tobytes() == getattr(same, name).tobytes()
    for bad in ([0.5], [0.5, 0.0], [0.5, np.nan], [[0.5, 0.5]]):
        with pytest.raises(DeformError, match="radius_fraction"):
            bind(rest, control, triangles, radius_fraction=bad)


def test_far_vertex_raises_nearest_triangle_radius():
    control, triangles = lips()
    far = np.array([[0.02, 0.2, 0.0]])  # 0.175 above the upper lip's apex
    binding = bind(far, control, triangles)
    assert binding.n_raised == 1
    assert binding.affection_radius[0] == pytest.approx(0.175 * 1.1, rel=1e-6)
    assert binding.affection_radius[1] == pytest.approx(0.01)
    assert binding.n_static == 0
    shifted = evaluate(binding, control + [0.0, 0.0, 0.003])
    np.testing.assert_allclose(shifted, far + [0.0, 0.0, 0.003], atol=1e-12)


def test_only_raisable_triangles_are_raised_to_cover():
    control, triangles = lips()
    far = np.array([[0.02, 0.2, 0.0]])  # nearest the upper lip's triangle 0
    binding = bind(far, control, triangles, raisable=np.array([False, True]))
    assert binding.affection_radius[0] == pytest.approx(0.01)
    assert binding.affection_radius[1] == pytest.approx(0.205 * 1.1, rel=1e-6)  # to the lower lip's upper edge
    assert binding.pair_triangle.tolist() == [1]


def test_small_radius_fraction_still_covers_every_vertex(sphere):
    rest, control, triangles, _ = sphere
    binding = bind(rest, control, triangles, radius_fraction=0.05)
    assert binding.n_raised > 0
    assert binding.n_static == 0
    assert np.abs(evaluate(binding, control) - rest).max() < 1e-9


def test_vertices_outside_cover_stay_bit_identical():
    control, triangles = lips()
    rest = np.array([[0.02, 0.01, 0.0], [0.5, 0.5, 0.5]])
    binding = bind(rest, control, triangles, cover=np.array([True, False]))
    assert binding.n_static == 1
    result = evaluate(binding, control * 1.3 + 0.01)
    assert result[1].tobytes() == rest[1].tobytes()


def test_cover_over_control_mesh_keeps_vertices_over_the_inside():
    # Unit square of two triangles in z = 0; the diagonal (0, 0)-(1, 1) is their shared edge.
    control = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    rest = np.array(
        [
            [0.7, 0.2, 0.05],  # over a triangle's inside
            [0.5, 0.5, 0.08],  # over the shared diagonal
            [0.7, 0.2, 0.2],  # over the inside, too far
            [0.5, -0.05, 0.01],  # beside a border edge
            [-0.03, -0.03, 0.0],  # beyond a border corner
            [0.5, 0.5, -0.099],  # under the inside, just near enough
        ]
    )
    covered = cover_over_control_mesh(rest, control, triangles, max_distance=0.1)
    assert covered.tolist() == [True, True, False, False, False, True]


def test_cover_over_control_mesh_keeps_the_rims_of_holes():
    # a 3 x 3 square frame around a 1 x 1 hole (the mouth of a control mesh): 8 quads, 16 triangles in z = 0
    grid = np.array([[x, y, 0.0] for y in range(4) for x in range(4)])
    quads = [(x + 4 * y, x + 1 + 4 * y, x + 5 + 4 * y, x + 4 + 4 * y) for y in range(3) for x in range(3)]
    triangles = np.array([t for i, (a, b, c, d) in enumerate(quads) if i != 4 for t in ((a, b, c), (a, c, d))])
    rest = np.array(
        [
            [1.5, 1.05, -0.05],  # just inside the hole, beside its rim: the lips' inner side
            [1.5, 1.5, 0.0],  # in the middle of the hole, 0.5 from the rim
            [1.5, -0.05, 0.01],  # beside the outline
            [1.5, 0.5, 0.05],  # over the inside
        ]
    )
    covered = cover_over_control_mesh(rest, grid, triangles, max_distance=0.1)
    assert covered.tolist() == [True, False, False, True]


# ---------------------------------------------------------------- degenerate input


def test_zero_area_triangle_is_excluded():
    control, triangles = icosahedron()
    control = np.concatenate([control, [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.02, 0.0, 0.0]]])
    triangles = np.concatenate([triangles, [[12, 13, 14], [0, 0, 1]]])
    rest = sphere_points(500)
    binding = bind(rest, control, triangles)
    assert binding.n_excluded == 2
    assert not np.isin(binding.pair_triangle, [20, 21]).any()
    assert np.abs(evaluate(binding, control) - rest).max() < 1e-9


def test_coincident_feature_points_do_not_shrink_the_radius():
    # Closed mouth: the inner-lip points of both lips coincide.
    upper = [[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.02, 0.02, 0.0]]
    lower = [[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.02, -0.02, 0.0]]
    control = np.array(upper + lower + [[0.1, 0.0, 0.0]])
    triangles = np.array([[0, 1, 2], [3, 5, 4]])
    rest = np.array([[0.02, 0.005, 0.001], [0.02, -0.005, 0.001]])
    binding = bind(rest, control, triangles)
    np.testing.assert_allclose(binding.affection_radius, [0.02, 0.02], rtol=1e-9)  # to the other lip's apex
    assert np.isfinite(evaluate(binding, control * 1.1)).all()


@pytest.mark.parametrize("mode", MODES)
def test_vertices_exactly_on_plane_edge_and_apex(mode):
    rest = np.array([O, P, Q, (O + P) / 2, (P + Q) / 2, [0.5, 0.25, 0.0], [2.0, 0.0, 0.3], [1.0, 0.0, -0.2]])
    binding = bind(rest, np.array([O, P, Q]), np.array([[0, 1, 2]]))
    assert np.abs(evaluate(binding, np.array([O, P, Q]), mode) - rest).max() < 1e-12
    result = evaluate(binding, np.array([o, p, q]), mode)
    assert np.isfinite(result).all()
    np.testing.assert_allclose(result[:3], [o, p, q], atol=1e-12)
    np.testing.assert_allclose(result[6], p + [0.0, 0.0, 0.3], atol=1e-12)  # above the apex: d = D = 0
    rotation, translation = random_rigid(7)
    rigid = evaluate(binding, np.array([O, P, Q]) @ rotation.T + translation, mode)
    np.testing.assert_allclose(rigid, rest @ rotation.T + translation, atol=1e-12)


@pytest.mark.parametrize("mode", MODES)
def test_collapsed_control_triangle_gives_finite_output(mode):
    rest = np.array([FACE_POINT, EDGE_POINT, APEX_POINT])
    binding = bind(rest, np.array([O, P, Q]), np.array([[0, 1, 2]]))
    for collapsed in (np.zeros((3, 3)), np.array([O, P, 2 * P])):
        assert np.isfinite(evaluate(binding, collapsed, mode)).all()


@pytest.mark.parametrize(
    ("rest", "control", "triangles", "message"),
    [
        (np.array([[np.nan, 0, 0]]), np.array([O, P, Q]), [[0, 1, 2]], "rest_vertices has non-finite"),
        (np.zeros((1, 3)), np.array([O, P, [np.inf, 0, 0]]), [[0, 1, 2]], "control_rest has non-finite"),
        (np.zeros((1, 3)), np.array([O, P, Q]), [[0, 1, 3]], "index outside"),
        (np.zeros((1, 3)), np.array([O, P, Q]), [[0, 1, -1]], "index outside"),
        (np.zeros((1, 3)), np.array([O, P, Q]), [[0.0, 1.0, 2.0]], "integer"),
        (np.zeros((1, 2)), np.array([O, P, Q]), [[0, 1, 2]], "shape"),
    ],
)
def test_bad_input_raises_deform_error(rest, control, triangles, message):
    with pytest.raises(DeformError, match=message):
        bind(rest, control, np.asarray(triangles))


def test_bad_evaluate_input_raises_deform_error(single_triangle):
    binding, _, _ = single_triangle
    with pytest.raises(DeformError, match="non-finite"):
        evaluate(binding, np.array([o, p, [np.nan, 0.0, 0.0]]))
    with pytest.raises(DeformError, match="shape"):
        evaluate(binding, np.array([o, p]))
    with pytest.raises(DeformError, match="unknown mode"):
        evaluate(binding, np.array([o, p, q]), "bones")


def test_bad_masks_raise_deform_error():
    control, triangles = lips()
    rest = np.zeros((2, 3))
    with pytest.raises(DeformError, match="not among"):
        bind(rest, control, triangles, vertex_masks={}, triangle_masks=["upper", None])
    with pytest.raises(DeformError, match=r"\[0, 1\]"):
        bind(rest, control, triangles, vertex_masks={"m": np.array([0.0, 2.0])}, triangle_masks=["m", None])


# ---------------------------------------------------------------- save / load


def test_save_load_round_trip(sphere):
    _, control, _, binding = sphere
    buffer = io.BytesIO()
    save_binding(binding, buffer)
    buffer.seek(0)
    loaded = load_binding(buffer)
    deformed = control + 0.01 * np.cos(30.0 * control)
    for mode in MODES:
        assert np.array_equal(evaluate(loaded, deformed, mode), evaluate(binding, deformed, mode))
    assert loaded.n_raised == binding.n_raised
    np.testing.assert_array_equal(loaded.affection_radius, binding.affection_radius)


def test_load_rejects_other_format_version(sphere, tmp_path):
    path = tmp_path / "binding.npz"
    np.savez_compressed(path, format_version=np.int64(99))
    with pytest.raises(DeformError, match="version 99"):
        load_binding(path)
    with pytest.raises(DeformError, match="cannot read"):
        load_binding(tmp_path / "missing.npz")


def test_fade_below_has_no_tear_at_the_edge_of_the_affection_volumes():
    # two triangles lifted by (0, 0, 1); points walk straight out from one edge to beyond every radius
    control = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 2, 0]])
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    walk = np.stack([np.full(400, 0.3), -np.linspace(0.01, 4.0, 400), np.zeros(400)], axis=1)
    moved = control + [0, 0, 1]
    for fade in (0.0, 0.05, 0.5):
        binding = bind(walk, control, triangles, cover=np.zeros(len(walk), bool), fade_below=fade)
        lift = evaluate(binding, moved)[:, 2]
        total = np.bincount(binding.pair_vertex, binding.pair_weight, minlength=len(walk))
        reached = total > 0
        assert 0 < reached.sum() < len(walk) and np.all(lift[~reached] == 0.0)
        if fade:
            # a pure lift moves each vertex by s(Σw / τ) of the raw weights (s = smoothstep, 1 from Σw = τ up),
            # 0 at the volumes' edge
            raw = np.zeros(len(walk))
            for t, r in enumerate(binding.affection_radius):
                d = locate(triangle_frames(control[triangles[[t]]]), 0, walk).distance
                raw += np.where(d < r, (0.5 * (1 + np.cos(np.pi * d / r))) ** 2, 0.0)  # eq. 9, n = 2
            x = np.minimum(raw / fade, 1.0)
            np.testing.assert_allclose(lift, x * x * (3 - 2 * x), atol=1e-12)
            np.testing.assert_allclose(total, lift, atol=1e-12)
            step = np.abs(np.diff(lift))
            assert step.max() < 0.3  # continuous: no step of the full motion
            # and smooth: no kink where the fade starts (at Σw = τ); the linear ramp Σw / τ changes its step
            # there by 0.6 (τ = 0.05) and 0.77 (τ = 0.5) of the largest step, the smoothstep by 0.24 and 0.09
            assert np.abs(np.diff(np.diff(lift))).max() < 0.3 * step.max()
        else:
            np.testing.assert_allclose(lift[reached], 1.0, atol=1e-12)  # eq. 8 alone: full motion, then a jump
            assert np.max(np.abs(np.diff(lift))) == pytest.approx(1.0)


def test_fade_below_is_eq_8_where_the_weights_reach_it(sphere):
    rest, control, triangles, _ = sphere
    nothing = np.zeros(len(rest), bool)  # no raised radii: both bindings have the same volumes
    plain = bind(rest, control, triangles, cover=nothing)
    faded = bind(rest, control, triangles, fade_below=0.5, cover=nothing)
    total = np.bincount(faded.pair_vertex, faded.pair_weight, minlength=len(rest))
    full = np.isclose(total, 1.0, rtol=0, atol=1e-12)
    assert full.sum() > len(rest) // 2
    moved = control * 1.2 + [0.01, 0.02, 0.0]
    np.testing.assert_allclose(evaluate(faded, moved)[full], evaluate(plain, moved)[full], atol=1e-12)


def test_fade_below_raises_radii_until_covered_vertices_reach_it():
    control = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    far = np.array([[0.2, 0.2, 0.8], [0.2, 0.2, 3.0]])
    binding = bind(far, control, np.array([[0, 1, 2]]), fade_below=0.05)
    total = np.bincount(binding.pair_vertex, binding.pair_weight, minlength=2)
    np.testing.assert_allclose(total, 1.0)  # both reach Σw >= 0.05, so both take the full motion
    assert binding.affection_radius[0] >= 3.0 * np.pi / np.arccos(2 * 0.05**0.5 - 1) * (1 - 1e-9)
    with pytest.raises(DeformError, match="fade_below"):
        bind(far, control, np.array([[0, 1, 2]]), fade_below=1.5)


def test_radius_raising_does_not_depend_on_triangle_order_and_keeps_mirror_symmetry():
    # two mirror-image pairs of triangles; the vertex on the mid-line is equally near the apex (±1, 0, 0) of
    # all four, outside their plain radii, so every one of them is raised (not the first found)
    left = np.array([[-3.0, 0, 0], [-1.0, 0, 0], [-2.0, 1.0, 0], [-2.2, -0.6, 0]])
    control = np.concatenate([left, left * [-1, 1, 1]])
    mirror = np.array([4, 5, 6, 7, 0, 1, 2, 3])  # control point of each point's mirror image
    triangles = np.array([[0, 1, 2], [0, 3, 1], [4, 6, 5], [4, 5, 7]])
    rest = np.array([[0.0, 0.3, 0.2], [-2.0, 0.4, 0.1], [2.0, 0.4, 0.1], [-1.5, -0.2, -0.3], [1.5, -0.2, -0.3]])
    plain = bind(rest, control, triangles, cover=np.zeros(len(rest), bool))
    assert np.all(plain.affection_radius < np.linalg.norm(rest[0] - [1.0, 0, 0]))
    for order in ([0, 1, 2, 3], [2, 3, 0, 1], [3, 1, 0, 2]):
        binding = bind(rest, control, triangles[order])
        assert binding.n_raised == 4
        np.testing.assert_allclose(binding.affection_radius, binding.affection_radius[0], rtol=1e-12)
        flip = np.array([-1.0, 1.0, 1.0])
        motion = np.array([[0.1, 0.3, -0.2], [0.0, 0.2, 0.4], [0.3, -0.1, 0.0], [-0.2, 0.0, 0.1]] * 2)
        motion[4:] = 0.0
        moved = evaluate(binding, control + motion)
        mirrored = evaluate(binding, control + motion[mirror] * flip)
        np.testing.assert_allclose(mirrored, moved[[0, 2, 1, 4, 3]] * flip, atol=1e-12)


def test_faint_pairs_are_dropped_and_each_vertex_keeps_its_weight_sum(monkeypatch):
    """Pairs under FAINT_PAIR go; the rest of the vertex's weights grow to the same sum, so rigid motion stays
    exact, and the pose moves by no more than the dropped share of the motion."""
    control, triangles = icosahedron()
    rest = sphere_points(3000)
    dropped = bind(rest, control, triangles, fade_below=0.2)
    monkeypatch.setattr(planar_bones, "FAINT_PAIR", 0.0)
    every = bind(rest, control, triangles, fade_below=0.2)
    assert dropped.n_pairs < every.n_pairs
    assert dropped.pair_weight.min() >= planar_bones.FAINT_PAIR or dropped.n_pairs == 0
    sums = [np.bincount(b.pair_vertex, b.pair_weight, minlength=len(rest)) for b in (dropped, every)]
    np.testing.assert_allclose(sums[0], sums[1], rtol=1e-12, atol=1e-15)
    rotation, translation = random_rigid(4)
    rigid = control @ rotation.T + translation
    moved = evaluate(dropped, rigid)
    covered = sums[0] > 1.0 - 1e-12  # vertices with their whole weight on the control mesh move rigidly
    np.testing.assert_allclose(moved[covered], (rest @ rotation.T + translation)[covered], atol=1e-9)
    stretched = control * np.array([1.2, 0.9, 1.1])
    shift = np.abs(evaluate(dropped, stretched) - evaluate(every, stretched)).max()
    assert shift <= 1e-3 * np.abs(stretched - control).max() * 10  # the dropped share of a few triangles' spread
