"""The compiled fast path (`addon.deform.fused`) equals the numpy reference; without it evaluate still works.

Tests that need the kernel skip where none could be built (`python -m scripts.build_kernel --install`).
The sample faces' own bindings are compared in tests/blender/test_fused_blender.py.
"""

import ctypes.util
import dataclasses

import numpy as np
import pytest

from addon.deform import fused, planar_bones
from addon.deform.face_binding import bind_face
from addon.deform.planar_bones import Binding, DeformError, bind, evaluate
from addon.deform.regions import APEX, deformation_basis
from scripts import build_kernel

from .test_planar_bones import icosahedron, random_rigid, sphere_points

MODES = ("planar_bones", "soffd")
TOLERANCE = 1e-8  # m: 1e-5 mm
PAIR_ARRAYS = tuple(f.name for f in dataclasses.fields(Binding) if f.name.startswith("pair_"))
needs_kernel = pytest.mark.skipif(not fused.available(), reason="no compiled kernel (python -m scripts.build_kernel)")


def reference(binding, control: np.ndarray, mode: str, dtype=np.float64) -> np.ndarray:
    """The numpy path, whatever the kernel."""
    out = np.empty((binding.n_vertices, 3), dtype)
    return planar_bones._evaluate_numpy(binding, deformation_basis(control[binding.triangles]), mode, out)


def assert_matches(fast: np.ndarray, exact: np.ndarray, rest_offset: np.ndarray | float = 0.0) -> float:
    """float64: equal to rounding; float32: the float64 reference rounded to float32, up to 1e-8 m.

    ``rest_offset``: how far the reference at rest is from the rest shape (a binding whose local coordinates
    were rounded to float32, as a saved one is): the fast path starts from the rest shape itself."""
    if fast.dtype == np.float64:
        limit = 1e-12 + rest_offset
    else:
        limit = np.spacing(np.abs(exact).astype(np.float32)) / 2 + TOLERANCE + rest_offset
    error = np.abs(fast - exact)
    assert (error <= limit).all(), f"worst excess {np.max(error - limit):.3g} m"
    return float(error.max())


def ellipsoid(n: int) -> np.ndarray:
    """n points spread over a head-sized ellipsoid (a Fibonacci lattice), facing +y."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    azimuth = np.pi * (1.0 + 5.0**0.5) * i
    ring = np.sqrt(1.0 - z * z)
    return np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1) * [0.075, 0.095, 0.11]


def front_grid(columns: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """A triangulated grid of control points on the ellipsoid's front, like FPs on a face."""
    u, v = np.meshgrid(np.linspace(-0.8, 0.8, columns), np.linspace(-0.7, 0.6, rows), indexing="ij")
    x, z = 0.075 * u * 0.8, 0.11 * v
    y = 0.095 * np.sqrt(np.maximum(1.0 - (x / 0.075) ** 2 - (z / 0.11) ** 2, 0.0))
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    triangles = []
    for i in range(columns - 1):
        for j in range(rows - 1):
            a, b, c, d = rows * i + j, rows * (i + 1) + j, rows * (i + 1) + j + 1, rows * i + j + 1
            triangles += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return points, np.array(triangles)


@pytest.fixture(scope="module")
def head():
    """A head-sized mesh bound as the add-on binds a face: cover, fade, a mask on some triangles."""
    rest = ellipsoid(6000)
    control, triangles = front_grid(7, 6)
    mask = np.clip(1.5 - 30.0 * np.abs(rest[:, 2]), 0.0, 1.0)  # fades out near the horizontal midline
    masks = ["upper_lip" if i % 5 == 0 else None for i in range(len(triangles))]
    binding = bind_face(rest, control, triangles, es0=0.06, vertex_masks={"upper_lip": mask}, triangle_masks=masks)
    assert binding.n_static > 0 and 0.2 < np.mean(binding.pair_region >= APEX) < 0.6
    return binding


@pytest.fixture(scope="module")
def apex_heavy():
    """Two small control triangles and points all around them, as far off as a face's affection radius
    (2.4 cm on the sample head): most pairs are apex pairs (eq. 13-14)."""
    control, _ = icosahedron(0.012)
    binding = bind(sphere_points(3000, radius=0.03, seed=4), control[:6], np.array([[0, 1, 2], [0, 2, 3]]))
    assert np.mean(binding.pair_region >= APEX) > 0.5
    return binding


def motions(binding) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    control = binding.control_rest
    rotation, _ = random_rigid(3)
    centre = control.mean(axis=0)
    collapsed = control.copy()
    collapsed[binding.triangles[0, 1]] = collapsed[binding.triangles[0, 0]]  # a triangle collapses: d' = 0
    return {
        "rest": control,
        "fap-like": control + rng.normal(0.0, 0.003, control.shape),
        "large": control + rng.normal(0.0, 0.02, control.shape),
        "rigid": (control - centre) @ rotation.T + centre + [0.03, -0.05, 0.02],
        "rigid-far": control @ rotation.T + [0.4, -1.2, 0.7],
        "collapsed": collapsed,
        "one point": _one_moved(binding),
    }


def _busiest(binding) -> int:
    """The control point in the most triangles."""
    return int(np.bincount(binding.triangles.ravel()).argmax())


def _one_moved(binding) -> np.ndarray:
    """Only the busiest control point moves: the triangles without it stay exactly at rest."""
    moved = binding.control_rest.copy()
    moved[_busiest(binding)] += [0.004, -0.003, 0.002]
    return moved


@needs_kernel
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("case", ["head", "apex_heavy"])
def test_fast_path_equals_the_numpy_reference(case, mode, dtype, request):
    binding = request.getfixturevalue(case)
    for control in motions(binding).values():
        exact = reference(binding, control, mode)
        fast = evaluate(binding, control, mode, out=np.empty(exact.shape, dtype))
        assert_matches(fast, exact)
    assert ("fused", mode, np.dtype(dtype).name) in binding._evaluation  # the kernel did run


@needs_kernel
def test_float32_fast_path_is_closer_to_the_reference_than_the_numpy_float32_path(head):
    control = motions(head)["fap-like"]
    exact = reference(head, control, "planar_bones")
    single = np.empty(exact.shape, np.float32)
    fast = np.abs(evaluate(head, control, out=single) - exact).max()
    assert fast <= np.abs(reference(head, control, "planar_bones", np.float32) - exact).max()


@needs_kernel
@pytest.mark.parametrize("mode", MODES)
def test_vertices_no_triangle_affects_stay_bit_identical(head, mode):
    static = np.setdiff1d(np.arange(head.n_vertices), head.pair_vertex)
    assert len(static)
    moved = evaluate(head, motions(head)["large"], mode)
    np.testing.assert_array_equal(moved[static], head.rest_vertices[static])


@needs_kernel
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_vertices_whose_triangles_are_all_still_take_their_rest_position(head, mode, dtype):
    control = _one_moved(head)
    moved_triangle = (head.triangles == _busiest(head)).any(axis=1)
    touched = np.zeros(head.n_vertices, bool)
    touched[head.pair_vertex[moved_triangle[head.pair_triangle]]] = True
    still = np.setdiff1d(head.pair_vertex, np.flatnonzero(touched))
    assert len(still) > 100 and touched.sum() > 100  # both paths are taken
    fast = evaluate(head, control, mode, out=np.empty((head.n_vertices, 3), dtype))
    np.testing.assert_array_equal(fast[still], head.rest_vertices[still].astype(dtype))
    assert_matches(fast, reference(head, control, mode))


@pytest.mark.parametrize("mode", MODES)
def test_the_reference_at_rest_is_the_rest_shape(head, mode):
    """Eq. 1-14 are the identity at rest: what lets the kernel start from the rest shape."""
    np.testing.assert_allclose(reference(head, head.control_rest, mode), head.rest_vertices, rtol=0.0, atol=1e-15)


@needs_kernel
def test_more_triangles_than_mask_bits_still_match_the_reference():
    rest = ellipsoid(4000)
    control, triangles = front_grid(12, 8)
    assert len(triangles) > 128  # triangles t and t + 128 share a bit of the vertex masks
    binding = bind_face(rest, control, triangles, es0=0.06)
    for moved in (_one_moved(binding), motions(binding)["fap-like"]):
        assert_matches(
            evaluate(binding, moved, out=np.empty((binding.n_vertices, 3), np.float32)),
            reference(binding, moved, "planar_bones"),
        )


@needs_kernel
@pytest.mark.parametrize("threads", [1, 2, 3, 16])
def test_thread_count_does_not_change_the_result(head, threads):
    control = motions(head)["fap-like"]
    layout = planar_bones._fused_layout(head, "planar_bones", np.float64)
    one, many = np.empty((2, head.n_vertices, 3))
    assert fused.evaluate_into(layout, control, one, threads=1)
    assert fused.evaluate_into(layout, control, many, threads=threads)
    np.testing.assert_allclose(many, one, rtol=0.0, atol=1e-15)


def test_a_second_thread_only_for_large_bindings(head, monkeypatch):
    monkeypatch.delenv(fused.THREADS_VARIABLE, raising=False)
    layout = fused.build_layout(
        mode="soffd",
        dtype=np.float32,
        control_rest=head.control_rest,
        triangles=head.triangles,
        base=head.rest_vertices,
        **{name: getattr(head, name) for name in PAIR_ARRAYS},
    )
    assert layout.n_pairs == head.n_pairs
    monkeypatch.setattr(fused, "PARALLEL_PAIRS", head.n_pairs + 1)
    assert fused.thread_count(layout) == 1
    monkeypatch.setattr(fused, "PARALLEL_PAIRS", head.n_pairs)
    assert fused.thread_count(layout) == fused.THREADS
    monkeypatch.setenv(fused.THREADS_VARIABLE, "3")
    assert fused.thread_count(layout) == 3


@needs_kernel
def test_binding_with_no_pairs_gives_the_rest_pose():
    rest = np.array([[5.0, 5.0, 5.0], [6.0, 5.0, 5.0]])
    control, triangles = icosahedron()
    binding = bind(rest, control, triangles, cover=np.zeros(2, dtype=bool))
    assert binding.n_pairs == 0
    np.testing.assert_array_equal(evaluate(binding, control * 1.1), rest)


def test_forced_numpy_path_gives_the_reference(head, monkeypatch):
    monkeypatch.setenv(fused.DISABLE, "1")
    assert not fused.available()
    control = motions(head)["fap-like"]
    for dtype in (np.float64, np.float32):
        out = np.empty((head.n_vertices, 3), dtype)
        np.testing.assert_array_equal(evaluate(head, control, out=out), reference(head, control, "planar_bones", dtype))


def test_without_the_library_evaluate_uses_the_numpy_path(sphere_binding, monkeypatch):
    monkeypatch.setattr(fused, "_kernel", lambda: None)
    assert not fused.available()
    control = sphere_binding.control_rest * 1.05
    np.testing.assert_array_equal(evaluate(sphere_binding, control), reference(sphere_binding, control, "planar_bones"))
    assert not any(isinstance(key, tuple) for key in sphere_binding._evaluation)  # no layout was built


@needs_kernel
def test_an_output_the_kernel_cannot_write_goes_the_numpy_way(head):
    control = motions(head)["fap-like"]
    strided = np.empty((head.n_vertices, 3), order="F")
    np.testing.assert_array_equal(evaluate(head, control, out=strided), reference(head, control, "planar_bones"))


@pytest.fixture
def sphere_binding():
    control, triangles = icosahedron()
    return bind(sphere_points(500), control, triangles)


def test_a_corrupt_or_missing_library_is_refused(tmp_path):
    corrupt = tmp_path / "planar_bones_kernel.so"
    corrupt.write_bytes(b"\x7fELF not really a shared library")
    assert fused.open_library(corrupt) is None
    assert fused.open_library(tmp_path / "missing.so") is None
    assert fused.open_library(None) is None


def test_a_library_without_the_kernel_is_refused():
    libc = ctypes.util.find_library("c")
    if libc is None:
        pytest.skip("no C library to load")
    assert fused.open_library(libc) is None  # loads, but has no pbk_abi_version


@needs_kernel
def test_a_library_of_another_abi_version_is_refused(monkeypatch):
    path = fused.library_path()
    assert fused.open_library(path) is not None
    monkeypatch.setattr(fused, "ABI_VERSION", fused.ABI_VERSION + 1)
    assert fused.open_library(path) is None


def test_no_installed_package_means_no_library(monkeypatch):
    monkeypatch.setattr(fused, "PACKAGE", "mpeg4_face_kernel_that_is_not_there")
    assert fused.library_path() is None


def test_the_abi_version_is_the_one_the_source_declares():
    assert build_kernel.abi_version() == fused.ABI_VERSION


@pytest.mark.parametrize(
    "field, value",
    [("pair_vertex", 10**6), ("pair_triangle", 10**4), ("pair_region", 9), ("pair_vertex", -1)],
)
def test_a_layout_of_a_corrupt_binding_is_a_deform_error(sphere_binding, field, value):
    arrays = {name: getattr(sphere_binding, name).copy() for name in PAIR_ARRAYS}
    arrays[field][len(arrays[field]) // 2] = value
    with pytest.raises(DeformError):
        fused.build_layout(
            mode="planar_bones",
            dtype=np.float32,
            control_rest=sphere_binding.control_rest,
            triangles=sphere_binding.triangles,
            base=sphere_binding.rest_vertices,
            **arrays,
        )


def test_the_environment_switch_turns_the_kernel_off(monkeypatch):
    loaded = fused._kernel() is not None
    for value, on in (("1", False), ("0", loaded), ("", loaded)):
        monkeypatch.setenv(fused.DISABLE, value)
        assert fused.available() is on


def _frames(binding) -> list[np.ndarray]:
    """A played sequence: rest, one point, still frames, motion, back to rest, one point again."""
    moves = motions(binding)
    one = moves["one point"]
    return [moves["rest"], one, one, moves["fap-like"], moves["fap-like"], moves["large"], one, moves["rest"], one]


@needs_kernel
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("case", ["head", "apex_heavy"])
def test_playback_equals_evaluate_frame_after_frame(case, mode, dtype, threads, request):
    binding = request.getfixturevalue(case)
    out = np.full((binding.n_vertices, 3), np.nan, dtype)  # nothing of the start survives the first frame
    playback = planar_bones.playback(binding, mode, out)
    for control in _frames(binding):
        assert playback.evaluate(control, threads=threads)
        expected = evaluate(binding, control, mode, out=np.empty_like(out))
        np.testing.assert_array_equal(out, expected)  # the same kernel sums: bit-identical


@needs_kernel
def test_playback_writes_again_what_others_changed(head):
    out = np.empty((head.n_vertices, 3), np.float32)
    playback = planar_bones.playback(head, "planar_bones", out)
    one = _one_moved(head)
    expected = evaluate(head, one, out=np.empty_like(out))
    assert playback.evaluate(one)
    still = np.flatnonzero((out == expected).all(axis=1) & (expected == head.rest_vertices.astype(np.float32)).all(1))
    out[still[:50]] += 1.0  # someone else writes these (the eyelids, the lip guard) and says so
    playback.changed(playback.groups_of(still[:50]))
    assert playback.evaluate(one)
    np.testing.assert_array_equal(out, expected)
    out[:] = 0.0  # and all of them
    playback.changed()
    assert playback.evaluate(one)
    np.testing.assert_array_equal(out, expected)


@needs_kernel
def test_playback_skips_the_still_vertices_it_wrote_at_rest(head):
    """What it does not write is what makes it fast: a vertex of a still group, already at rest, is left
    alone (here: a mark put there unannounced stays)."""
    out = np.empty((head.n_vertices, 3), np.float64)
    playback = planar_bones.playback(head, "planar_bones", out)
    one = _one_moved(head)
    assert playback.evaluate(one)
    moved_triangle = (head.triangles == _busiest(head)).any(axis=1)
    touched = np.unique(head.pair_vertex[moved_triangle[head.pair_triangle]])
    untouched = np.setdiff1d(np.arange(head.n_vertices), touched)
    out[untouched[0]] = 7.0
    out[touched[0]] = 7.0
    assert playback.evaluate(one)
    assert (out[untouched[0]] == 7.0).all() and not (out[touched[0]] == 7.0).any()


def test_playback_groups_hold_every_vertex_once(head):
    layout = planar_bones._fused_layout(head, "planar_bones", np.float64)
    np.testing.assert_array_equal(np.sort(layout.group_vertex), np.arange(head.n_vertices))
    groups = np.repeat(np.arange(len(layout.group_mask)), np.diff(layout.group_start))
    np.testing.assert_array_equal(layout.vertex_group[layout.group_vertex], groups)
    np.testing.assert_array_equal(layout.group_mask[layout.vertex_group], layout.vertex_mask)


def test_no_playback_without_the_kernel(head, monkeypatch):
    monkeypatch.setenv(fused.DISABLE, "1")
    assert planar_bones.playback(head, "planar_bones", np.empty((head.n_vertices, 3))) is None
