"""The lip guard in the compiled kernel (`fused.guard_lips_into`, native/lip_guard.h) against its numpy reference
(`lips.guard_lips`), on the hand-made mouth of test_lips: the same vertices move by the same amounts."""

import numpy as np
import pytest

from addon.deform import fused
from addon.deform.inputs import DeformError
from addon.deform.lips import bind_lip_guard, guard_lips

from .test_lips import FACE, FP_IDS, mouth, mouth_with_skin, pressed

needs_kernel = pytest.mark.skipif(not fused.available(), reason="no compiled kernel (python -m scripts.build_kernel)")
TOLERANCE = 1e-9  # m: the kernel sums in double where numpy rounds the projections to the output's float32


def arrays(guard) -> fused.GuardArrays:
    return fused.GuardArrays.of(
        guard.vertices, guard.side, guard.slack, guard.knots, guard.order, guard.starts, guard.spread, guard.axes,
        guard.reach, guard.width, guard.skin, guard.sources, guard.shares,
    )  # fmt: skip


def cases(rest, upper, fps):
    """(deformed, control points) of a mouth: pressed by several amounts, and pressed with random jitter up and
    down, some lip FPs moved too, so that the seam moves between the lips and bends."""
    rng = np.random.default_rng(5)
    for amount in (0.0, 0.3, 0.75, 1.0, 1.5):
        yield pressed(rest, upper, fps, amount)
    for _ in range(20):
        deformed, points = pressed(rest, upper, fps, rng.uniform(0.0, 1.5))
        deformed = deformed + rng.normal(0.0, 0.0006, rest.shape) * [0.2, 1.0, 0.2]
        points = points + rng.normal(0.0, 0.0008, points.shape) * [1.0, 1.0, 0.3]
        yield deformed, points


@needs_kernel
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_kernel_moves_the_lips_and_the_skin_beside_them_as_the_numpy_guard_does(dtype):
    """On the mouth whose upper lip turns up into skin: the skin beside the lips follows alike too."""
    rest, triangles, upper, lower, fps, _edge, _above = mouth_with_skin()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    native = arrays(guard)
    moved = carried = 0
    for deformed, points in cases(rest, upper | ~lower, fps):
        expected = deformed.astype(dtype)
        guard_lips(guard, expected, points)
        got = deformed.astype(dtype)
        assert fused.guard_lips_into(native, got, points)
        np.testing.assert_allclose(got, expected, rtol=0.0, atol=TOLERANCE if dtype == np.float64 else 1e-7)
        moved += int(np.any(expected != deformed.astype(dtype)))
        beside = guard.skin[len(guard.vertices) :]
        carried += int(np.any(expected[beside] != deformed.astype(dtype)[beside]))
    assert moved >= 15  # the guard did act in most cases
    assert carried >= 15  # and the skin beside the lips followed


@needs_kernel
def test_the_kernel_leaves_the_rest_mesh_unchanged():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    out = rest.copy()
    assert fused.guard_lips_into(arrays(guard), out, fps)
    np.testing.assert_array_equal(out, rest)


def test_inconsistent_guard_arrays_are_refused():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    with pytest.raises(DeformError):
        fused.GuardArrays.of(
            guard.vertices, guard.side, guard.slack, guard.knots, guard.order + len(guard.vertices), guard.starts,
            guard.spread, guard.axes, guard.reach, guard.width, guard.skin, guard.sources, guard.shares,
        )  # fmt: skip
    with pytest.raises(DeformError):  # a share from beyond the guarded vertices
        fused.GuardArrays.of(
            guard.vertices, guard.side, guard.slack, guard.knots, guard.order, guard.starts, guard.spread, guard.axes,
            guard.reach, guard.width, guard.skin, guard.sources + len(guard.vertices), guard.shares,
        )  # fmt: skip


@needs_kernel
def test_the_kernel_refuses_an_output_it_cannot_write():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert not fused.guard_lips_into(arrays(guard), rest[: len(rest) // 2].copy(), fps)  # too few vertices
    assert not fused.guard_lips_into(arrays(guard), np.asfortranarray(rest), fps)
