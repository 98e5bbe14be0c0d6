"""The lip guard in the compiled kernel (`fused.guard_lips_into`, native/lip_guard.h) against its numpy reference
(`lips.guard_lips`), on the hand-made mouth of test_lips: the same vertices move by the same amounts."""

import pickle

import numpy as np
import pytest

from addon.deform import fused, lips
from addon.deform.inputs import DeformError
from addon.deform.lips import bind_lip_guard, guard_lips

from .test_lips import FACE, FP_IDS, mouth, mouth_with_skin, pressed, tucked_mouth

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
        assert guard_lips(guard, expected, points) == bool(np.any(expected != deformed.astype(dtype)))
        got = deformed.astype(dtype)
        moves = fused.guard_lips_into(native, got, points)
        assert moves is not None and moves == guard_lips(
            guard, deformed.astype(dtype), points
        )  # both say if they moved
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
    assert fused.guard_lips_into(arrays(guard), out, fps) is False  # it ran, and moved nothing
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
    assert fused.guard_lips_into(arrays(guard), rest[: len(rest) // 2].copy(), fps) is None  # too few vertices
    assert fused.guard_lips_into(arrays(guard), np.asfortranarray(rest), fps) is None


def grid_lips():
    """A flat 21 x 21 grid, 1 mm apart, split by its diagonals (every distance along the edges ties with many
    others), with two bands of rows as the upper and lower lip."""
    n = 21
    x, y = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    rest = np.stack([x.ravel() * 1e-3, y.ravel() * 1e-3, np.zeros(x.size)], axis=1)
    corner = (x[:-1, :-1] * n + y[:-1, :-1]).ravel()
    triangles = np.concatenate(
        [np.stack([corner, corner + n, corner + n + 1], 1), np.stack([corner, corner + n + 1, corner + 1], 1)]
    )
    row = y.ravel()
    return rest, triangles, np.flatnonzero((row >= 11) & (row <= 13)), np.flatnonzero((row >= 7) & (row <= 9))


@needs_kernel
@pytest.mark.parametrize("mesh", ["grid", "mouth"])
def test_the_kernel_finds_the_skin_beside_the_lips_as_python_does(mesh, monkeypatch):
    """`lips._carry` with the kernel's Dijkstra and with Python's: the same skin, sources and shares, on a grid whose
    distances tie everywhere and on the mouth whose lip turns up into skin."""
    if mesh == "grid":
        rest, triangles, upper, lower = grid_lips()
    else:
        rest, triangles, up, low, *_ = mouth_with_skin()
        upper, lower = np.flatnonzero(up), np.flatnonzero(low)
    vertices = np.concatenate([upper, lower])
    side = np.r_[np.ones(len(upper)), -np.ones(len(lower))]
    found, kernel = [], fused.nearest_sources
    monkeypatch.setattr(fused, "nearest_sources", lambda *args: found.append(kernel(*args)) or found[-1])
    native = lips._carry(rest, triangles, vertices, side, 1.0)
    assert len(found) == 3 and all(f is not None for f in found)  # the kernel found them, ties and all
    monkeypatch.setattr(fused, "nearest_sources", lambda *args: None)
    python = lips._carry(rest, triangles, vertices, side, 1.0)
    assert len(native["skin"]) > len(vertices)  # the skin beside was reached
    for name in ("skin", "sources", "shares"):
        np.testing.assert_array_equal(native[name], python[name])


@needs_kernel
def test_the_kernel_leaves_more_ties_than_it_has_room_for_to_python():
    """A hub equally far from 20 sources keeps all 20 (ties with the k-th are all kept): more than the kernel has
    room for, so it says so and Python finds them."""
    spokes = 20
    ends = np.r_[np.arange(1, spokes + 1), np.zeros(spokes, int)]  # hub 0 to each spoke, each spoke to the hub
    starts = np.r_[0, spokes, spokes + 1 + np.arange(spokes)]
    length = np.full(len(ends), 1e-3)
    sources = np.arange(1, spokes + 1)
    assert fused.nearest_sources(starts, ends, length, sources, 1, lips.CARRY_RADIUS, lips.TIE) is None
    found = lips._nearest((starts, ends, length), sources, 1, 1.0)
    assert sorted(row for _d, row in found[0]) == list(range(spokes))
    assert all(d == pytest.approx(1e-3) for d, _row in found[0])
    small = fused.nearest_sources(starts, ends, length, sources[:5], 1, lips.CARRY_RADIUS, lips.TIE)
    assert small is not None and sorted(row for _d, row in small[0]) == list(range(5))


def contact_cases(rest, lower, rng):
    """Deformed tucked mouths: the lower lip slid forward on the contact by several amounts (a bump along the mouth),
    then the same with jitter of every vertex and a lift of the lower lip into the upper one."""
    bump = np.cos(np.pi * rest[:, 0] / 0.05) ** 2
    for amount in (0.0, 0.0005, 0.001, 0.002, 0.003):
        slid = rest.copy()
        slid[lower, 2] += amount * bump[lower]
        yield slid
    for _ in range(12):
        slid = rest.copy()
        slid[lower, 2] += rng.uniform(0.0, 0.003) * bump[lower]
        slid[lower, 1] += rng.uniform(0.0, 0.001) * bump[lower]
        yield slid + rng.normal(0.0, 0.0002, rest.shape)


@needs_kernel
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("apart", [0.001, 0.0002, -0.0001])
@pytest.mark.parametrize("turned", [False, True])
def test_the_kernel_presses_the_contact_apart_as_the_numpy_does_bit_for_bit(dtype, apart, turned):
    """`lips.press_apart` by the kernel (native/lip_guard.h) and by numpy, its reference, after the seam's guard, on
    the tucked mouth of test_lips (lips 1 mm apart, touching 0.2 mm apart, overlapping 0.1 mm) slid and jittered: the
    same positions to the last bit, float32 or float64, in the face frame or in a mesh turned away from it (the face
    frame's axes then mix every coordinate). Both say alike whether they moved any."""
    rest, triangles, upper, lower, fps = tucked_mouth(apart=apart)
    axes = FACE
    if turned:  # the mesh in other coordinates: rows of `axes` are the face's x, y, z in them
        q, _ = np.linalg.qr(np.random.default_rng(2).normal(size=(3, 3)))
        axes = q if np.linalg.det(q) > 0 else q * [1.0, 1.0, -1.0]  # a turn, not a mirror image
        rest, fps = rest @ axes, fps @ axes
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=axes)
    assert guard.contact is not None and len(guard.contact.ends) > len(guard.contact.vertices)  # edges' middles too
    rng = np.random.default_rng(11)
    moved = 0
    for case in contact_cases(rest @ axes.T, lower, rng):
        deformed = (case @ axes).astype(dtype)
        guard_lips(guard, deformed, fps)
        expected, got = deformed.copy(), deformed.copy()
        said = lips.press_apart(guard, expected, native=False)
        assert lips.press_apart(guard, got) is said
        np.testing.assert_array_equal(got, expected)
        moved += int(said and np.any(expected != deformed))
    assert moved >= 12  # the contact did push in most cases


def pressed_once():
    """The tucked mouth (lips touching 0.2 mm apart) with its lower lip slid forward 2 mm at the mid line, after the
    seam's guard; pressed apart by the kernel: (rest, lower lip, guard, slid, pressed)."""
    rest, triangles, upper, lower, fps = tucked_mouth(apart=0.0002)
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    slid = rest.copy()
    slid[lower, 2] += 0.002 * np.cos(np.pi * rest[lower, 0] / 0.05) ** 2
    guard_lips(guard, slid, fps)
    first = slid.copy()
    assert lips.press_apart(guard, first)
    return rest, lower, guard, slid, first


@needs_kernel
def test_the_kernel_keeps_the_triangles_order_from_call_to_call_and_answers_alike():
    """The kernel's order of the other lip's triangles (sorted by their boxes, kept between calls) does not change
    what it finds: the same mouth pressed again after many other frames and after the order was shuffled."""
    rest, lower, guard, slid, first = pressed_once()
    arrays = lips._contact_arrays(guard)
    n_first = arrays.n_first
    assert np.array_equal(np.sort(arrays.order[:n_first]), np.arange(n_first))  # a permutation within each facing
    assert np.array_equal(np.sort(arrays.order[n_first:]), np.arange(n_first, len(arrays.order)))
    rng = np.random.default_rng(3)
    for case in contact_cases(rest, lower, rng):  # other frames sort it their way
        lips.press_apart(guard, case)
    arrays.order[:n_first] = rng.permutation(arrays.order[:n_first])
    again = slid.copy()
    assert lips.press_apart(guard, again)
    np.testing.assert_array_equal(again, first)


def test_inconsistent_contact_arrays_are_refused():
    rest, triangles, upper, lower, fps = tucked_mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    c = guard.contact

    def made(**changes):
        fields = dict(vertices=c.vertices, rows=c.rows, ends=c.ends, look=c.look, keep=c.keep, direction=c.direction)
        fields |= dict(triangles=c.triangles, facing=c.facing, reach=c.reach, axes=guard.axes)
        fields |= dict(n_guarded=len(guard.vertices), skin=guard.skin, sources=guard.sources, shares=guard.shares)
        return fused.ContactArrays.of(**(fields | changes))

    assert made().n_first == int(np.sum(c.facing == 1.0)) > 0
    for changes in (
        {"rows": c.rows + len(guard.vertices)},  # a row past the guarded vertices
        {"ends": c.ends + len(c.vertices)},  # a sample's end past the contact's vertices
        {"facing": c.facing[::-1]},  # the upper lip's triangles first
        {"triangles": c.triangles - 1000},
        {"sources": guard.sources + len(guard.vertices)},
        {"look": c.look * 0.5},
    ):
        with pytest.raises(DeformError):
            made(**changes)


@needs_kernel
def test_a_guard_pickled_after_pressing_presses_alike_in_its_new_arrays():
    """The kernel's arguments are addresses of this process's arrays: a guard pickled with its contact's arrays (kept
    with it after the first press) and loaded again takes the addresses of the loaded arrays (before, the old ones:
    the process crashed)."""
    _rest, _lower, guard, slid, first = pressed_once()
    loaded = pickle.loads(pickle.dumps(guard))
    assert "arguments" not in pickle.loads(pickle.dumps(lips._contact_arrays(guard))).__dict__
    again = slid.copy()
    assert lips.press_apart(loaded, again)
    np.testing.assert_array_equal(again, first)


@needs_kernel
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_kernel_guards_a_fold_past_the_corners_with_no_seam_as_the_numpy_does(dtype):
    """The folded corner of test_lips (lip skin past a corner, held to no seam: slack -inf) pressed up and jittered:
    the kernel's seam and contact move the lips and the fold as numpy's do."""
    from addon.deform.lips import mouth_sides

    from .test_lips import folded_corner_mouth

    rest, triangles, masks, fps, neutral, (upper_fold, lower_fold) = folded_corner_mouth()
    upper, lower = mouth_sides(rest, *masks, neutral, axes=FACE, triangles=triangles)
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert np.isneginf(guard.slack).sum() == 12  # the fold (two columns of each layer), held to no seam
    native = arrays(guard)
    rng = np.random.default_rng(7)
    moved = 0
    for deformed, points in cases(rest, upper, fps):
        deformed = deformed.copy()
        deformed[lower_fold, 1] += rng.uniform(0.0, 1e-4)
        expected, got = deformed.astype(dtype), deformed.astype(dtype)
        said = guard_lips(guard, expected, points)
        assert fused.guard_lips_into(native, got, points) == said
        np.testing.assert_allclose(got, expected, rtol=0.0, atol=TOLERANCE if dtype == np.float64 else 1e-7)
        got = expected.copy()
        pressed_apart = lips.press_apart(guard, expected, native=False)
        assert lips.press_apart(guard, got) is pressed_apart
        np.testing.assert_array_equal(got, expected)
        moved += int(pressed_apart)
    assert moved >= 15  # the contact did part the fold in most cases
