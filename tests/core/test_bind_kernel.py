"""Binding by the compiled kernel (native/bind_regions.h) equals the numpy reference (`regions.locate`,
`regions.distance_lower_bound`, `planar_bones.bind`'s per-triangle collect), and binding works without it."""

import dataclasses

import numpy as np
import pytest

from addon.deform import fused
from addon.deform.face_binding import bind_face
from addon.deform.planar_bones import Binding, bind, cover_over_control_mesh
from addon.deform.regions import APEX, EDGE, FACE, distance_lower_bound, locate, triangle_frames

from .test_fused import ellipsoid, front_grid, needs_kernel
from .test_planar_bones import icosahedron, sphere_points

TRIANGLES = {
    "acute": [[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.012, 0.025, 0.0]],
    "obtuse": [[0.0, 0.0, 0.0], [0.04, 0.0, 0.0], [0.035, 0.004, 0.002]],
    "right": [[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.0, 0.02, 0.0]],
    "sliver": [[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.015, 0.0005, 0.0]],
    "tilted": [[0.01, -0.02, 0.03], [0.04, 0.01, 0.02], [0.015, 0.03, 0.05]],
}


def frames_of(corners) -> tuple:
    frames = triangle_frames(np.array([corners], dtype=np.float64))
    return frames, fused.bind_frames(frames, frames.corners.mean(axis=1))[0]


@needs_kernel
@pytest.mark.parametrize("shape", TRIANGLES)
def test_locate_by_the_kernel_equals_regions_locate(shape):
    frames, row = frames_of(TRIANGLES[shape])
    points = np.random.default_rng(3).uniform(-0.04, 0.07, (4000, 3))
    exact, fast = locate(frames, 0, points), fused.locate(row, points)
    np.testing.assert_array_equal(fast.region, exact.region)
    assert {FACE, EDGE, APEX} <= set(np.unique(np.minimum(exact.region, APEX)).tolist())  # every kind of region
    for field in ("distance", "face_local", "region_local", "apex_distance"):
        np.testing.assert_allclose(getattr(fast, field), getattr(exact, field), rtol=0.0, atol=1e-12, err_msg=field)
    bound = fused.distance_bound(row, points)
    np.testing.assert_allclose(bound, distance_lower_bound(frames, 0, points), rtol=0.0, atol=1e-15)
    assert np.all(bound <= fast.distance + 1e-15)  # a lower bound


def assert_same_binding(fast: Binding, exact: Binding) -> None:
    for field in dataclasses.fields(Binding):
        a, b = getattr(fast, field.name), getattr(exact, field.name)
        if isinstance(b, np.ndarray) and b.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15, err_msg=field.name)
        elif isinstance(b, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=field.name)
        elif field.name != "_evaluation":
            assert a == b, field.name


def hand_made_head() -> dict:
    """A head-sized mesh bound as the add-on binds a face: cover, fade, a mask on some triangles."""
    rest = ellipsoid(6000)
    control, triangles = front_grid(7, 6)
    mask = np.clip(1.5 - 30.0 * np.abs(rest[:, 2]), 0.0, 1.0)
    masks = ["upper_lip" if i % 5 == 0 else None for i in range(len(triangles))]
    return {
        "rest": rest,
        "control_rest": control,
        "triangles": triangles,
        "es0": 0.06,
        "vertex_masks": {"upper_lip": mask},
        "triangle_masks": masks,
    }


@needs_kernel
def test_a_face_bound_by_the_kernel_equals_the_numpy_binding(monkeypatch):
    case = hand_made_head()
    fast = bind_face(**case)
    assert fast.n_raised > 0  # the raising of radii (§3) is compared too
    monkeypatch.setenv(fused.DISABLE, "1")
    assert_same_binding(fast, bind_face(**case))


@needs_kernel
@pytest.mark.parametrize("float32", [False, True])
def test_a_sphere_bound_by_the_kernel_equals_the_numpy_binding(monkeypatch, float32):
    control, _ = icosahedron(0.012)
    arguments = (sphere_points(3000, radius=0.03, seed=4), control[:6], np.array([[0, 1, 2], [0, 2, 3]]))
    fast = bind(*arguments, radius_fraction=0.5, local_float32=float32)
    assert np.mean(fast.pair_region >= APEX) > 0.3
    monkeypatch.setenv(fused.DISABLE, "1")
    assert_same_binding(fast, bind(*arguments, radius_fraction=0.5, local_float32=float32))


@needs_kernel
def test_the_cover_by_the_kernel_equals_the_numpy_cover(monkeypatch):
    case = hand_made_head()
    arguments = (case["rest"], case["control_rest"], case["triangles"], 0.02)
    fast = cover_over_control_mesh(*arguments)
    assert 0 < fast.sum() < len(fast)
    monkeypatch.setenv(fused.DISABLE, "1")
    np.testing.assert_array_equal(fast, cover_over_control_mesh(*arguments))


def test_binding_works_without_the_kernel(monkeypatch):
    monkeypatch.setenv(fused.DISABLE, "1")
    assert not fused.available()
    binding = bind_face(**hand_made_head())
    assert len(binding.pair_vertex) > 6000 and binding.n_static < 6000
    assert fused.locate(np.zeros(fused.BIND_FRAME), np.zeros((1, 3))) is None
