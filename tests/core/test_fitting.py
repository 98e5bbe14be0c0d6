"""Fitting the generic face to a person (Escher et al.): missing FPs, Dirichlet FFD, texture, calibration."""

import dataclasses
import sys

import numpy as np
import pytest

from addon.fitting.affine_fit import robust_affine_fit
from addon.fitting.calibration import fit_to_calibration_mesh
from addon.fitting.dffd import DffdBinding, bind_dffd, deform_dffd
from addon.fitting.errors import (
    BindingError,
    CalibrationError,
    CoincidentFeaturePointsError,
    FeaturePointError,
    FittingError,
    FoldError,
    ScipyMissingError,
    TextureCoordinateError,
)
from addon.fitting.expansion import COPIES, Band, ExpandedTriangulation
from addon.fitting.fit import fit_to_feature_points
from addon.fitting.missing_points import complete_feature_points
from addon.fitting.texture import texture_coordinates
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.feature_points import FEATURE_POINTS

FACE_FRAME = np.eye(3)  # tests that work in the face frame itself: x left, y up, z forward
SKIN = [fp.id for fp in FEATURE_POINTS if fp.surface == "skin"]
RADII = np.array([0.08, 0.1, 0.12])  # an egg-shaped head: half width, half depth, half height (m)


def surface_point(latitude: float, longitude: float, scale: np.ndarray = RADII) -> np.ndarray:
    """A point of the ellipsoid head in Blender's frame (left +X, forward -Y, up +Z); longitude 0 = front."""
    lat, lon = np.radians(latitude), np.radians(longitude)
    return np.array(
        [scale[0] * np.cos(lat) * np.sin(lon), -scale[1] * np.cos(lat) * np.cos(lon), scale[2] * np.sin(lat)]
    )


def head_mesh(rings: int = 13, segments: int = 32, reach: float = 66.0) -> tuple[np.ndarray, np.ndarray]:
    """An ellipsoid band (latitudes -reach..reach, open at the poles): vertices and triangles."""
    latitudes = np.linspace(-reach, reach, rings)
    longitudes = np.arange(segments) * 360.0 / segments - 180.0
    vertices = np.array([surface_point(a, o) for a in latitudes for o in longitudes])
    triangles = []
    for r in range(rings - 1):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            c, d = a + segments, b + segments
            triangles += [(a, b, d), (a, d, c)]
    return vertices, np.array(triangles)


def head_fps() -> dict[str, np.ndarray]:
    """24 skin FPs on the egg (4 heights x 6 angles round the head) and 7.1 and 9.8 inside it."""
    grid = [(a, o) for a in (-45.0, -15.0, 15.0, 45.0) for o in (-150.0, -90.0, -30.0, 30.0, 90.0, 150.0)]
    fps = {fp_id: surface_point(a, o) for fp_id, (a, o) in zip(SKIN, grid, strict=False)}
    fps["7.1"] = np.array([0.0, 0.01, -0.06])
    fps["9.8"] = np.array([0.0, -0.06, -0.03])
    return fps


@pytest.fixture(scope="module")
def generic():
    vertices, triangles = head_mesh()
    rng = np.random.default_rng(11)
    inner = rng.uniform(-0.6, 0.6, (200, 3)) * RADII  # the volume inside the head deforms too
    fps = head_fps()
    everything = np.vstack([vertices, inner, np.array(list(fps.values()))])  # FPs last: exactness checks
    return {"vertices": everything, "triangles": triangles, "fps": fps, "binding": bind_dffd(everything, fps)}


# --- Dirichlet FFD (§3.1) --------------------------------------------------------------------------


def test_an_fp_moved_to_x_lands_at_x(generic):
    rng = np.random.default_rng(0)
    target = {fp_id: p + rng.normal(0.0, 0.01, 3) for fp_id, p in generic["fps"].items()}
    moved = deform_dffd(generic["binding"], target)
    np.testing.assert_allclose(moved[-len(target) :], np.array(list(target.values())), atol=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_any_affine_map_of_all_fps_moves_every_vertex_by_that_map(generic, seed):
    rng = np.random.default_rng(seed)
    matrix = np.eye(3) + 0.4 * rng.normal(size=(3, 3))
    shift = rng.normal(0.0, 0.2, 3)
    target = {fp_id: matrix @ p + shift for fp_id, p in generic["fps"].items()}
    moved = deform_dffd(generic["binding"], target)
    expected = generic["vertices"] @ matrix.T + shift
    reach = np.linalg.norm(np.ptp(expected, axis=0))
    assert np.max(np.abs(moved - expected)) <= 1e-9 * reach


def test_the_fps_not_moved_move_nothing(generic):
    moved = deform_dffd(generic["binding"], generic["fps"])
    np.testing.assert_array_equal(moved, generic["vertices"])


def natural_neighbours_of(binding, fp_id: str) -> np.ndarray:
    """(N,) whether each vertex has the FP among its natural neighbours."""
    coordinates = binding.coordinates
    used = np.arange(coordinates.indices.shape[1])[None, :] < coordinates.counts[:, None]
    return np.any(used & (coordinates.indices == binding.fp_ids.index(fp_id)), axis=1)


def test_locality_a_vertex_follows_its_natural_neighbours_only(generic):
    binding = generic["binding"]
    moving = SKIN[0]
    follows = natural_neighbours_of(binding, moving)
    assert 0 < follows.sum() < len(follows) / 2  # a neighbourhood, not the whole head
    target = dict(generic["fps"])
    target[moving] = target[moving] + np.array([0.0, 0.0, 0.02])
    moved = deform_dffd(binding, target)
    # one FP's motion is no affine motion of the face: the auxiliary sites stay, and so does every other vertex
    np.testing.assert_array_equal(moved[~follows], generic["vertices"][~follows])
    assert np.all(np.linalg.norm(moved[follows] - generic["vertices"][follows], axis=1) > 0)


def test_a_local_motion_on_top_of_an_affine_one_moves_the_rest_by_the_affine_map(generic):
    binding = generic["binding"]
    matrix, shift = np.diag([1.1, 0.95, 1.05]) + 0.05 * np.eye(3)[::-1], np.array([0.01, -0.02, 0.005])
    local = SKIN[:3]  # three FPs side by side on the lowest ring of the egg, say a chin pushed forward
    target = {fp_id: matrix @ p + shift for fp_id, p in generic["fps"].items()}
    for fp_id in local:
        target[fp_id] = target[fp_id] + np.array([0.0, -0.015, 0.0])
    moved = deform_dffd(binding, target)
    elsewhere = ~np.any([natural_neighbours_of(binding, fp_id) for fp_id in local], axis=0)
    expected = generic["vertices"] @ matrix.T + shift
    reach = np.linalg.norm(np.ptp(expected, axis=0))
    assert np.max(np.abs(moved[elsewhere] - expected[elsewhere])) <= 1e-9 * reach
    assert np.all(np.linalg.norm(moved[~elsewhere] - expected[~elsewhere], axis=1) > 0)


def test_the_robust_affine_fit():
    rng = np.random.default_rng(3)
    rest = rng.normal(0.0, 0.05, (40, 3))
    assert not np.any(robust_affine_fit(rest, np.zeros((40, 3))))
    affine = np.vstack([np.eye(3) + 0.3 * rng.normal(size=(3, 3)), rng.normal(0.0, 0.02, 3)])
    homogeneous = np.column_stack([rest, np.ones(40)])
    motion = homogeneous @ affine
    np.testing.assert_allclose(robust_affine_fit(rest, motion), affine, atol=1e-12)
    outliers = motion.copy()
    outliers[:12] += rng.normal(0.0, 0.02, (12, 3))  # 12 of 40 FPs moved on their own
    np.testing.assert_allclose(robust_affine_fit(rest, outliers), affine, atol=1e-12)
    least_squares, *_ = np.linalg.lstsq(homogeneous, outliers, rcond=None)
    assert np.max(np.abs(least_squares - affine)) > 1e-3  # what the least-squares fit would have given


def test_the_binding_saves_and_loads_as_plain_arrays_bit_for_bit(generic):
    arrays = generic["binding"].to_arrays()
    assert all(isinstance(a, np.ndarray) and a.dtype != object for a in arrays.values())
    loaded = DffdBinding.from_arrays({name: a.copy() for name, a in arrays.items()})
    target = {fp_id: p * 1.1 for fp_id, p in generic["fps"].items()}
    np.testing.assert_array_equal(deform_dffd(loaded, target), deform_dffd(generic["binding"], target))


@pytest.mark.parametrize(
    ("name", "change", "message"),
    [
        ("format_version", lambda a: np.array(1, np.int64), "format version"),  # 8 box corners, least squares
        ("rest_auxiliary", lambda a: a[:8], "shape"),
        ("indices", lambda a: np.where(a == 0, 10_000, a).astype(np.int32), "site indices"),
        ("weights", lambda a: a * 1.01, "sum to"),
        ("weights", lambda a: np.where(a > 0.5, np.nan, a), "finite"),
        ("fp_ids", lambda a: np.array(["99.9", *a[1:]], dtype="U8"), "unknown"),
        ("counts", lambda a: a.astype(np.int64), "int32"),
        ("rest_fps", lambda a: a[:-1], "shape"),
    ],
)
def test_a_damaged_binding_is_refused_naming_the_array(generic, name, change, message):
    arrays = generic["binding"].to_arrays()
    arrays[name] = change(arrays[name])
    with pytest.raises(BindingError, match=message):
        DffdBinding.from_arrays(arrays)


def test_coincident_fps_of_the_generic_face_are_one_site_and_must_move_together():
    vertices, _ = head_mesh(7, 12)
    fps = head_fps()
    fps["11.5"] = fps["7.1"].copy()  # like the sample head's 11.4 and 11.5
    binding = bind_dffd(vertices, fps)
    assert binding.merged == (("11.5", "7.1"),)
    together = {**fps, "7.1": fps["7.1"] + 0.01, "11.5": fps["7.1"] + 0.01}
    without = {fp_id: p for fp_id, p in together.items() if fp_id != "11.5"}
    np.testing.assert_array_equal(deform_dffd(binding, together), deform_dffd(binding, without))
    apart = {**fps, "11.5": fps["7.1"] + 0.01}
    with pytest.raises(CoincidentFeaturePointsError, match=r"7\.1 and 11\.5 .* apart"):
        deform_dffd(binding, apart)


def test_dffd_refuses_bad_fp_sets():
    vertices, _ = head_mesh(7, 12)
    fps = head_fps()
    with pytest.raises(FeaturePointError, match="at least 4"):
        bind_dffd(vertices, {fp_id: fps[fp_id] for fp_id in list(fps)[:3]})
    flat = {fp_id: p * [1.0, 1.0, 0.0] for fp_id, p in list(fps.items())[:10]}
    with pytest.raises(FeaturePointError, match="one plane"):
        bind_dffd(vertices, flat)
    with pytest.raises(FeaturePointError, match=r"unknown MPEG-4 feature point.*'12\.1'"):
        bind_dffd(vertices, {**fps, "12.1": np.zeros(3)})
    with pytest.raises(FeaturePointError, match=r"FP 2\.1 is not finite"):
        bind_dffd(vertices, {**fps, "2.1": np.array([0.0, np.inf, 0.0])})
    with pytest.raises(FeaturePointError, match=r"FP 2\.1 has shape \(2,\)"):
        bind_dffd(vertices, {**fps, "2.1": np.zeros(2)})
    with pytest.raises(FittingError, match="vertex 3 is not finite"):
        bind_dffd(np.where(np.arange(len(vertices))[:, None] == 3, np.nan, vertices), fps)
    binding = bind_dffd(vertices, fps)
    with pytest.raises(FeaturePointError, match=r"missing: .*9\.8"):
        deform_dffd(binding, {fp_id: p for fp_id, p in fps.items() if fp_id != "9.8"})


@pytest.mark.parametrize("call", ["bind", "complete", "texture"])
def test_without_scipy_fitting_refuses_with_a_message(generic, monkeypatch, call):
    fps = generic["fps"]
    moved = {fp_id: p for fp_id, p in fps.items() if fp_id != "9.8"}
    calls = {
        "bind": lambda: bind_dffd(generic["vertices"], fps),
        "complete": lambda: complete_feature_points(fps, moved, BLENDER_FACE_AXES),
        "texture": lambda: texture_coordinates(generic["vertices"], fps, front_uvs(fps)),
    }
    monkeypatch.setitem(sys.modules, "scipy.spatial", None)  # what `import scipy.spatial` meets without scipy
    with pytest.raises(ScipyMissingError, match=r"fitting needs scipy \(Qhull\), which Blender does not ship"):
        calls[call]()


# --- Missing feature points (§3.1.1) ----------------------------------------------------------------

R = 2.0 / np.pi  # a cylinder of this radius unrolls 90 degrees to an arc length of 1


def on_cylinder(angle_degrees: float, height: float) -> np.ndarray:
    """In the face frame (x left, y up, z forward): unrolls to (R * angle, height) exactly."""
    angle = np.radians(angle_degrees)
    return np.array([R * np.sin(angle), height, R * np.cos(angle)])


def test_missing_fps_by_the_papers_formula_a_worked_example():
    # Unrolled (u, v), shifted by the cylinder's centre height: A (0, 0), B (1, 0), C (0, 1), D (-1, 0),
    # E (2, 0) at the back, F (0, -1). M = (0.5, 0.25) lies in triangle ABC with barycentric weights
    # W_A = 1 - 0.5 - 0.25 = 0.25, W_B = 0.5, W_C = 0.25 (the Delaunay triangle: A, B, C's circumcircle,
    # centre (0.5, 0.5), radius^2 0.5, holds none of D, E, F, all at distance^2 2.5).
    # N = (0, 2) lies above the given FPs' hull, whose nearest point is C.
    a, b, c, d, e, f, m, n = "2.1", "2.10", "2.11", "2.12", "2.13", "2.14", "5.1", "5.2"
    generic = {
        a: on_cylinder(0, 0),
        b: on_cylinder(90, 0),
        c: on_cylinder(0, 1),
        d: on_cylinder(-90, 0),
        e: on_cylinder(180, 0),
        f: on_cylinder(0, -1),
        m: on_cylinder(45, 0.25),
        n: on_cylinder(0, 2),
    }
    moves = {a: [0.0, 0.0, 0.1], b: [0.2, 0.0, 0.0], c: [0.0, 0.4, 0.0], d: [0, 0, 0], e: [0, 0, 0], f: [0, 0, 0]}
    given = {fp_id: generic[fp_id] + np.array(move) for fp_id, move in moves.items()}
    completed = complete_feature_points(generic, given, FACE_FRAME)
    # Xf = Xi + 0.25 (0, 0, 0.1) + 0.5 (0.2, 0, 0) + 0.25 (0, 0.4, 0) = Xi + (0.1, 0.1, 0.025)
    np.testing.assert_allclose(completed.positions[m] - generic[m], [0.1, 0.1, 0.025], atol=1e-15)
    np.testing.assert_allclose(completed.positions[n] - generic[n], [0.0, 0.4, 0.0], atol=1e-15)
    assert completed.interpolated == (m, n)
    assert completed.outside == (n,)
    for fp_id in given:
        np.testing.assert_array_equal(completed.positions[fp_id], given[fp_id])


@pytest.mark.parametrize("local_motion", [0.0, 0.02])
def test_missing_fps_off_the_unrolled_surface_follow_the_affine_fit(local_motion):
    fps = head_fps()
    matrix, shift = np.diag([1.1, 0.9, 1.2]), np.array([0.01, 0.0, -0.02])
    given = {fp_id: matrix @ p + shift for fp_id, p in fps.items() if fp_id not in ("7.1", "9.8")}
    given[SKIN[0]] = given[SKIN[0]] + local_motion  # one FP of its own does not carry the FPs inside
    completed = complete_feature_points(fps, given)
    assert completed.affine == ("7.1", "9.8")  # inside the head: no cylinder sees them
    for fp_id in ("7.1", "9.8"):
        np.testing.assert_allclose(completed.positions[fp_id], matrix @ fps[fp_id] + shift, atol=1e-15)


def test_fit_to_some_fps_completes_them_then_deforms(generic):
    given = {fp_id: p * 1.05 for fp_id, p in list(generic["fps"].items())[::2]}
    fit = fit_to_feature_points(generic["binding"], generic["fps"], given)
    assert set(fit.completion.positions) == set(generic["fps"])
    n = len(generic["fps"])
    fitted_fps = dict(zip(generic["fps"], fit.vertices[-n:], strict=True))
    for fp_id, p in given.items():
        np.testing.assert_allclose(fitted_fps[fp_id], p, atol=1e-15)


def test_missing_fps_refuses_bad_input():
    fps = head_fps()
    with pytest.raises(FeaturePointError, match=r"2 on the face surface \(2\.1, 2\.2\); at least 3"):
        complete_feature_points(fps, {"2.1": fps["2.1"], "2.2": fps["2.2"]})
    line = {fp_id: on_cylinder(a, 0) for fp_id, a in zip(("2.1", "2.10", "2.11"), (-60, 0, 60), strict=True)}
    with pytest.raises(FeaturePointError, match="one line"):
        complete_feature_points({**line, "2.12": on_cylinder(30, 0)}, line, FACE_FRAME)
    with pytest.raises(FeaturePointError, match=r"given FPs 9\.3 are not on the generic face"):
        complete_feature_points(fps, {**fps, "9.3": np.zeros(3)})


def test_swapped_fps_fold_the_projection():
    fps = head_fps()
    left, right = SKIN[2], SKIN[3]  # neighbours round the head at 30 degrees either side of the front
    swapped = {**fps, left: fps[right], right: fps[left]}
    with pytest.raises(FoldError, match=rf"{left}.*mirrored|{right}.*mirrored"):
        complete_feature_points(fps, {fp_id: p for fp_id, p in swapped.items() if fp_id != SKIN[0]})


def test_generic_fps_given_at_two_places_are_refused():
    fps = head_fps()
    fps["11.5"] = fps[SKIN[8]].copy()  # coincident with a skin FP on the generic face
    given = {**fps, "11.5": fps[SKIN[8]] + 0.01}
    with pytest.raises(CoincidentFeaturePointsError, match=rf"{SKIN[8]} and 11\.5"):
        complete_feature_points(fps, given)


# --- Texture coordinates (§3.2) ---------------------------------------------------------------------


def front_uvs(fps: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """A front picture's UVs of the FPs that face the camera (x -> u, z -> v)."""
    front = {fp_id: p for fp_id, p in fps.items() if fp_id in SKIN and p[1] < 0}
    return {fp_id: np.array([0.5 + 4.0 * p[0], 0.5 + 3.0 * p[2]]) for fp_id, p in front.items()}


def test_every_vertex_gets_uvs_inside_the_image(generic):
    vertices, _ = head_mesh(25, 48)
    uvs = front_uvs(generic["fps"])
    fit = texture_coordinates(vertices, generic["fps"], uvs)
    assert fit.uvs.shape == (len(vertices), 2)
    assert np.all((fit.uvs >= 0.0) & (fit.uvs <= 1.0))
    assert set(fit.fp_ids) == set(uvs) and fit.unused == ()


def test_texture_is_exact_at_the_fps_and_linear_between(generic):
    uvs = front_uvs(generic["fps"])
    points = np.array([generic["fps"][fp_id] for fp_id in uvs])
    vertices, _ = head_mesh()
    fit = texture_coordinates(np.vstack([vertices, points]), generic["fps"], uvs)
    np.testing.assert_allclose(fit.uvs[-len(points) :], np.array(list(uvs.values())), atol=1e-14)


def test_the_expanded_triangulation_covers_the_whole_unrolled_head():
    # FPs on the front only: the plain triangulation leaves the back and top out (Figure 4)
    points = np.array([[-0.3, -0.5], [0.3, -0.5], [0.0, 0.0], [-0.2, 0.4], [0.25, 0.45]])
    band = Band.of(2 * np.pi, points)
    np.testing.assert_allclose((band.bottom, band.top), (-0.5 - 0.095, 0.45 + 0.095))
    expanded = ExpandedTriangulation.build(points, ["a", "b", "c", "d", "e"], band, "test")
    assert len(expanded.triangulation.points) == len(COPIES) * len(points)
    # everything between the mirror lines, all the way round the head
    heights, arcs = np.linspace(band.bottom, band.top, 23), np.linspace(-np.pi, np.pi, 41)
    grid = np.stack(np.meshgrid(arcs, heights), axis=-1).reshape(-1, 2)
    assert np.all(expanded.triangulation.find_simplex(grid) >= 0)


def test_texture_refuses_bad_uvs(generic):
    vertices, _ = head_mesh(7, 12)
    fps = generic["fps"]
    uvs = front_uvs(fps)
    first, second = list(uvs)[:2]
    with pytest.raises(TextureCoordinateError, match=rf"outside the image \[0, 1\]: {first} \(1.2"):
        texture_coordinates(vertices, fps, {**uvs, first: np.array([1.2, 0.5])})
    with pytest.raises(TextureCoordinateError, match=rf"same texture coordinates: {first} and {second}"):
        texture_coordinates(vertices, fps, {**uvs, second: uvs[first]})
    mirrored = {fp_id: np.array([1.0 - u, v]) for fp_id, (u, v) in uvs.items()}
    with pytest.raises(FoldError, match="mirrored relative to the face"):
        texture_coordinates(vertices, fps, mirrored)
    with pytest.raises(FeaturePointError, match=r"does not have: 9\.3"):
        texture_coordinates(vertices, fps, {**uvs, "9.3": np.array([0.5, 0.5])})


# --- Calibration model (§3.3) -----------------------------------------------------------------------


def test_fitting_onto_a_scaled_copy_recovers_it():
    vertices, triangles = head_mesh()
    fps = head_fps()
    centre, scale = np.array([0.01, -0.02, 0.03]), 1.25
    target = centre + scale * (vertices - centre)
    target_fps = {fp_id: centre + scale * (p - centre) for fp_id, p in fps.items()}
    fit = fit_to_calibration_mesh(vertices, fps, target, triangles, target_fps)
    np.testing.assert_allclose(fit.vertices, target, atol=1e-12)
    assert fit.on_ray.all()


def distance_to_mesh(points: np.ndarray, vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest triangle it lies over (its projection inside the triangle)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    area2 = np.einsum("td,td->t", normal, normal)
    offset = points[:, None, :] - a[None]
    height = np.einsum("ptd,td->pt", offset, normal) / np.sqrt(area2)
    wb = np.einsum("ptd,td->pt", np.cross(offset, (c - a)[None]), normal) / area2
    wc = np.einsum("ptd,td->pt", np.cross((b - a)[None], offset), normal) / area2
    over = (wb >= -1e-9) & (wc >= -1e-9) & (wb + wc <= 1 + 1e-9)
    return np.min(np.where(over, np.abs(height), np.inf), axis=1)


def test_fitting_onto_a_stretched_head_lands_on_its_surface():
    vertices, _ = head_mesh(9, 16)
    scan, triangles = head_mesh(15, 24, reach=80.0)  # a scan covering more of the head, meshed its own way
    fps = head_fps()
    stretch = np.array([1.15, 0.9, 1.1])
    fit = fit_to_calibration_mesh(vertices, fps, scan * stretch, triangles, {f: p * stretch for f, p in fps.items()})
    assert fit.on_ray.all()
    assert np.max(distance_to_mesh(fit.vertices, scan * stretch, triangles)) < 1e-12
    # the FPs' map is piecewise linear, so vertices land near (not at) their stretched selves
    assert np.max(np.linalg.norm(fit.vertices - vertices * stretch, axis=1)) < 0.1 * np.max(RADII)


def test_a_ray_meeting_an_ear_and_the_head_takes_the_head_behind_a_head_vertex():
    vertices, triangles = head_mesh()
    fps = head_fps()
    # "ears": plates standing off both sides (keeping the cylinder); the rays that reach the head there
    # cross them first, further from the axis
    ears = np.array(
        [
            surface_point(h, side + o, RADII * 1.4)
            for side in (-90.0, 90.0)
            for h in (-12.0, 12.0)
            for o in (-12.0, 12.0)
        ]
    )
    ear_triangles = len(vertices) + np.array([[0, 1, 3], [0, 3, 2], [4, 5, 7], [4, 7, 6]])
    mesh, mesh_triangles = np.vstack([vertices, ears]), np.vstack([triangles, ear_triangles])
    longitude = np.degrees(np.arctan2(vertices[:, 0] / RADII[0], -vertices[:, 1] / RADII[1]))
    behind = (np.abs(np.abs(longitude) - 90.0) < 12.0) & (np.abs(vertices[:, 2]) < np.sin(np.radians(12.0)) * RADII[2])
    assert behind.sum() == 18  # head vertices whose rays meet an ear first
    fit = fit_to_calibration_mesh(vertices, fps, mesh, mesh_triangles, fps)
    np.testing.assert_allclose(fit.vertices, vertices, atol=1e-12)


def test_a_calibration_mesh_that_covers_part_of_the_head_needs_a_fallback():
    vertices, triangles = head_mesh()
    fps = head_fps()
    upper = triangles[np.all(vertices[triangles][:, :, 2] > -0.05, axis=1)]
    with pytest.raises(CalibrationError, match="fall outside the calibration mesh"):
        fit_to_calibration_mesh(vertices, fps, vertices, upper, fps)
    fallback = vertices + 1.0
    fit = fit_to_calibration_mesh(vertices, fps, vertices, upper, fps, fallback=fallback)
    assert fit.fallback.any() and not fit.fallback[vertices[:, 2] > 0.0].any()
    np.testing.assert_array_equal(fit.vertices[fit.fallback], fallback[fit.fallback])


def test_calibration_refuses_bad_input():
    vertices, triangles = head_mesh(7, 12)
    fps = head_fps()
    with pytest.raises(CalibrationError, match="no feature points"):
        fit_to_calibration_mesh(vertices, fps, vertices, triangles, {})
    with pytest.raises(CalibrationError, match=rf"triangle 5 refers to vertex .*; the mesh has {len(vertices)}"):
        bad = triangles.copy()
        bad[5, 1] = len(vertices)
        fit_to_calibration_mesh(vertices, fps, vertices, bad, fps)
    with pytest.raises(CalibrationError, match="vertex indices"):
        fit_to_calibration_mesh(vertices, fps, vertices, triangles.astype(float), fps)
    swapped = {**fps, SKIN[2]: fps[SKIN[3]], SKIN[3]: fps[SKIN[2]]}
    with pytest.raises(FoldError, match="calibration mesh's FPs fold the face"):
        fit_to_calibration_mesh(vertices, fps, vertices, triangles, swapped)
    few = {fp_id: fps[fp_id] for fp_id in SKIN[:2]}
    with pytest.raises(FeaturePointError, match=rf"2 point\(s\) \({SKIN[0]}, {SKIN[1]}\); at least 3"):
        fit_to_calibration_mesh(vertices, fps, vertices, triangles, few)


def test_the_blender_frame_and_the_face_frame_give_the_same_fit():
    vertices, triangles = head_mesh(7, 12)
    fps = head_fps()
    in_face = {fp_id: BLENDER_FACE_AXES @ p for fp_id, p in fps.items()}
    given = {fp_id: p * 1.1 for fp_id, p in list(fps.items())[::2]}
    given_face = {fp_id: BLENDER_FACE_AXES @ p for fp_id, p in given.items()}
    blender = complete_feature_points(fps, given)
    face = complete_feature_points(in_face, given_face, FACE_FRAME)
    for fp_id in fps:
        np.testing.assert_allclose(BLENDER_FACE_AXES @ blender.positions[fp_id], face.positions[fp_id], atol=1e-15)


def test_a_fit_does_not_change_its_inputs(generic):
    fps = {fp_id: p.copy() for fp_id, p in generic["fps"].items()}
    vertices = generic["vertices"].copy()
    fit_to_feature_points(generic["binding"], fps, {fp_id: p * 1.1 for fp_id, p in fps.items()})
    np.testing.assert_array_equal(generic["vertices"], vertices)
    assert all(np.array_equal(fps[f], generic["fps"][f]) for f in fps)
    assert dataclasses.is_dataclass(generic["binding"])
