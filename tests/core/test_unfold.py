"""Unfold Skin (`unfold`): a flat grid with one vertex pushed past its neighbours, so that faces turn over."""

import numpy as np
import pytest

from addon.deform import fused, unfold
from addon.deform.folds import inverted_faces
from addon.deform.inputs import DeformError

SIZE = 21  # vertices a side; spacing 1 mm


def grid(size: int = SIZE) -> tuple[np.ndarray, np.ndarray]:
    """A flat square grid in the z = 0 plane (metres) and its triangles, wound to face +z; the cells' diagonals
    turn the other way in the right half, so that the mesh is its own mirror image in x."""
    x, y = np.meshgrid(np.arange(size) * 1e-3, np.arange(size) * 1e-3, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), np.zeros(size * size)], axis=1)
    triangles = []
    for i in range(size - 1):
        for j in range(size - 1):
            a, b, c, d = size * i + j, size * (i + 1) + j, size * (i + 1) + j + 1, size * i + j + 1
            triangles += [[a, b, c], [a, c, d]] if 2 * i < size - 1 else [[a, b, d], [b, c, d]]
    return points, np.array(triangles)


def centre(size: int = SIZE) -> int:
    return (size // 2) * size + size // 2


def pushed(points: np.ndarray, shift: tuple[float, float, float], where: int | None = None) -> np.ndarray:
    """`points` with one vertex (the centre by default) moved by `shift` (metres)."""
    out = points.copy()
    out[centre() if where is None else where] += shift
    return out


def test_a_pushed_vertex_folds_faces_and_unfold_opens_all_of_them():
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0))  # 2.5 spacings: past its right-hand neighbour
    assert inverted_faces(rest, folded, triangles).sum() >= 2
    positions = folded.copy()
    done = unfold.unfold(mesh, positions)
    assert done.left == 0 and done.steps > 0
    assert not inverted_faces(rest, positions, triangles).any()
    # only vertices near the fold moved, and every one that did is listed
    changed = np.flatnonzero(np.any(positions != folded, axis=1))
    assert set(changed) <= set(done.moved)
    distance = np.linalg.norm(rest[done.moved] - rest[centre()], axis=1)
    assert distance.max() <= 6e-3
    still = np.setdiff1d(np.arange(len(rest)), done.moved)
    assert np.array_equal(positions[still], folded[still])


def test_a_frame_without_folds_is_left_exactly_as_it_was():
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    for posed in (rest, rest @ rotation.T + (0.01, -0.02, 0.005), pushed(rest, (0.4e-3, 0.0, 3e-3))):
        positions = posed.astype(np.float32)
        before = positions.copy()
        done = unfold.open_folds(mesh, positions)
        assert done.steps == 0 and done.left == 0 and len(done.moved) == 0
        assert np.array_equal(positions, before)


def test_motion_along_the_normal_never_counts_as_a_fold():
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    positions = pushed(rest, (0.0, 0.0, 20e-3))  # a 20 mm spike: steep, but no face shows its back
    assert unfold.unfold(mesh, positions).steps == 0


def test_the_mirrored_fold_opens_to_the_mirrored_result():
    rest, triangles = grid()
    mirror = np.array([-1.0, 1.0, 1.0])
    # the grid mirrored in x is the grid again, with vertex (i, j) at (SIZE - 1 - i, j)
    i, j = np.divmod(np.arange(len(rest)), SIZE)
    image = (SIZE - 1 - i) * SIZE + j
    mirrored_rest = rest * mirror + ((SIZE - 1) * 1e-3, 0, 0)
    assert np.allclose(mirrored_rest[image], rest)
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0))
    left = folded.copy()
    unfold.unfold(mesh, left)
    right = (folded * mirror + ((SIZE - 1) * 1e-3, 0, 0))[image]  # the fold mirrored, in the grid's vertex order
    unfold.unfold(mesh, right)
    back = (right * mirror + ((SIZE - 1) * 1e-3, 0, 0))[image]
    assert np.abs(back - left).max() < 1e-12


def test_a_fold_wider_than_a_ring_widens_the_region():
    rest, triangles = grid(31)
    mesh = unfold.prepare(rest, triangles)
    folded = rest.copy()
    column = 15 * 31 + np.arange(31)  # a whole column pushed 3.5 spacings sideways: a crease across the grid
    folded[column, 0] += 3.5e-3
    assert inverted_faces(rest, folded, triangles).sum() >= 60
    positions = folded.copy()
    done = unfold.unfold(mesh, positions)
    assert done.left == 0
    assert not inverted_faces(rest, positions, triangles).any()


def test_max_steps_bounds_the_work_and_reports_what_is_left():
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    positions = rest.copy()
    positions[(SIZE // 2) * SIZE + np.arange(SIZE), 0] += 8.5e-3  # a deep crease across the grid
    done = unfold.unfold(mesh, positions, max_steps=1)
    assert done.steps == 1 and done.left > 0
    assert done.left == inverted_faces(rest, positions, triangles).sum()


def _kernel_unfold(mesh, positions, start=None, max_steps=unfold.MAX_STEPS, momentum=unfold.MOMENTUM):
    return fused.unfold(
        mesh, positions, start, max_steps, unfold.STEP, unfold.CHECK_EVERY, unfold.STALL_CHECKS, unfold.BISECTIONS,
        unfold.MARGIN, momentum,
    )  # fmt: skip


@pytest.mark.skipif(not fused.available(), reason="compiled kernel not installed")
@pytest.mark.parametrize("shift", [(2.5e-3, 0.4e-3, 0.0), (6e-3, -1e-3, 1e-3), (-3e-3, 3e-3, 0.0)])
@pytest.mark.parametrize("from_fold", [False, True])
def test_the_kernel_gives_the_numpy_result_bit_for_bit(shift, from_fold):
    """Looking at every triangle first, or starting from the pushed vertex (all its folds are at it)."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, shift).astype(np.float32)
    start = np.array([centre()]) if from_fold else None
    reference, compiled = folded.copy(), folded.copy()
    expected = unfold.unfold(mesh, reference, start=start)
    got = _kernel_unfold(mesh, compiled, start)
    assert got is not None
    assert np.array_equal(got[0], expected.moved) and got[1:] == (expected.steps, expected.left, expected.share)
    assert np.array_equal(compiled, reference)
    whole = folded.copy()
    assert unfold.unfold(mesh, whole).steps == expected.steps and np.array_equal(whole, reference)


@pytest.mark.parametrize("kernel", [False, True])
def test_an_unfold_looks_only_where_it_starts_and_where_it_moved(kernel, monkeypatch):
    """With `start`, a fold with no corner among the start vertices is not looked at (the caller vouched there is
    none): a crease across the grid opened from one of its vertices is opened as from a look at every triangle
    (the region grows from the folds it finds to the rest of the crease), and a fold far from the start stays."""
    if kernel and not fused.available():
        pytest.skip("compiled kernel not installed")
    if not kernel:
        monkeypatch.setattr(fused, "unfold", lambda *arguments: None)
    rest, triangles = grid(31)
    mesh = unfold.prepare(rest, triangles)
    folded = rest.copy()
    column = 15 * 31 + np.arange(31)
    folded[column, 0] += 3.5e-3
    folded = folded.astype(np.float32)
    whole, started = folded.copy(), folded.copy()
    expected = unfold.open_folds(mesh, whole)
    done = unfold.open_folds(mesh, started, start=column)
    assert done.left == expected.left == 0 and done.steps == expected.steps
    assert np.array_equal(done.moved, expected.moved) and np.array_equal(started, whole)
    far = folded.copy()
    done = unfold.open_folds(mesh, far, start=np.array([0, 1, 31]))  # a corner of the grid, 15 mm from the crease
    assert done.steps == 0 and len(done.moved) == 0 and np.array_equal(far, folded)


@pytest.mark.skipif(not fused.available(), reason="compiled kernel not installed")
def test_the_kernels_work_space_serves_call_after_call():
    """The work space the kernel keeps on a mesh (stamps, not cleared between calls) gives each of 40 calls, on
    folds at random places with and without start vertices, the numpy's result bit for bit."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    rng = np.random.default_rng(25)
    for _ in range(40):
        where = int(rng.integers(SIZE + 1, SIZE * (SIZE - 1) - 1))
        shift = (*rng.uniform(-4e-3, 4e-3, 2), 0.0)
        folded = pushed(rest, shift, where).astype(np.float32)
        start = np.array([where]) if rng.integers(2) else None
        budget = int(rng.integers(1, 300))
        reference, compiled = folded.copy(), folded.copy()
        expected = unfold.unfold(mesh, reference, max_steps=budget, start=start)
        got = _kernel_unfold(mesh, compiled, start, max_steps=budget)
        assert np.array_equal(got[0], expected.moved) and got[1:] == (expected.steps, expected.left, expected.share)
        assert np.array_equal(compiled, reference)


def test_bad_input_is_a_deform_error():
    rest, triangles = grid(3)
    with pytest.raises(DeformError):
        unfold.prepare(rest, triangles + 100)
    mesh = unfold.prepare(rest, triangles)
    with pytest.raises(DeformError):
        unfold.unfold(mesh, np.zeros((4, 3)))


@pytest.mark.parametrize("kernel", [False, True])
def test_a_look_at_the_flagged_groups_finds_what_a_whole_look_finds(kernel, monkeypatch):
    if kernel and not fused.available():
        pytest.skip("compiled kernel not installed")
    if not kernel:
        monkeypatch.setattr(fused, "turned_at", lambda look, positions: None)
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    column = np.arange(len(rest)) // SIZE
    look = unfold.group_look(mesh, column, SIZE)  # a group per column of the grid
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0)).astype(np.float32)  # folds faces at the centre's column and the next
    look.off_rest[:] = 0
    assert len(look.turned_corners(folded)) == 0  # the folds are where nothing was written
    look.off_rest[SIZE // 2 + 1] = 1
    corners = look.turned_corners(folded)
    expected = np.sort(triangles[unfold.turned_over(mesh, folded.astype(np.float64))], axis=1)
    expected = expected[np.isin(expected // SIZE, [SIZE // 2 + 1]).any(axis=1)]  # at the flagged column
    assert len(expected) and sorted(map(tuple, np.sort(corners.reshape(-1, 3), axis=1))) == sorted(map(tuple, expected))
    positions = folded.copy()
    done = unfold.open_folds(mesh, positions, look)
    reference = folded.copy()
    expected = unfold.unfold(mesh, reference)
    assert np.array_equal(done.moved, expected.moved) and np.array_equal(positions, reference)
    look.off_rest[:] = 0
    positions = folded.copy()
    assert unfold.open_folds(mesh, positions, look).steps == 0 and np.array_equal(positions, folded)


def test_the_look_sorts_every_triangle_once_into_the_class_of_its_corners_groups():
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    vertex_group = np.random.default_rng(3).integers(0, 7, len(rest))
    look = unfold.group_look(mesh, vertex_group, 7)
    rows = {tuple(t): k for k, t in enumerate(map(tuple, triangles))}
    seen = []
    for c in range(len(look.class_groups)):
        for t in look.corners[look.class_start[c] : look.class_start[c + 1]]:
            k = rows[tuple(t)]
            seen.append(k)
            assert set(look.class_groups[c]) == set(vertex_group[t])
            assert np.array_equal(look.rest_normals[len(seen) - 1], mesh.rest_normals[k])
    assert sorted(seen) == list(range(len(triangles)))


def test_polygons_of_any_size_and_a_loose_vertex_are_taken():
    """A fan of a pentagon and a quad, a vertex in no face (it never moves), a fold in the pentagon opened."""
    from addon.deform.folds import fan_triangles

    rest = np.array([[0, 0, 0], [2, 0, 0], [3, 1.5, 0], [1, 3, 0], [-1, 1.5, 0], [4, -1, 0], [5, 1, 0], [9, 9, 0]])
    rest = rest * 1e-3
    triangles, _owner = fan_triangles(np.array([5, 4]), np.array([0, 1, 2, 3, 4, 1, 5, 6, 2]))
    mesh = unfold.prepare(rest, triangles)
    assert np.diff(mesh.neighbour_start)[7] == 0  # the loose vertex has no neighbours
    folded = rest.copy()
    folded[3] = (1e-3, -1e-3, 0.0)  # the pentagon's top corner pulled below its base
    folded[7] += (5e-3, 0.0, 0.0)  # the loose vertex moved: not a fold, and left as it is
    assert unfold.turned_over(mesh, folded).any()
    positions = folded.copy()
    done = unfold.unfold(mesh, positions)
    assert done.left == 0 and not unfold.turned_over(mesh, positions).any()
    assert 7 not in done.moved and np.array_equal(positions[7], folded[7])


def test_the_repair_grows_from_nothing_as_the_fold_does():
    """Step 4: a vertex pushed ever further past its neighbour gets a repair that starts at ~0 where the first face
    turns over and grows with the push (the membrane's whole change would jump to millimetres at once)."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    changes, shares = [], []
    for push in np.linspace(0.3e-3, 1.2e-3, 19):
        folded = pushed(rest, (push, 0.4e-3, 0.0))
        positions = folded.copy()
        done = unfold.unfold(mesh, positions)
        assert done.left == 0 and not unfold.turned_over(mesh, positions).any()
        changes.append(np.abs(positions - folded).max())
        shares.append(done.share)
    first = next(i for i, change in enumerate(changes) if change > 0)
    assert first > 0 and changes[first] < 0.1e-3  # the first fold is opened by under a tenth of a spacing
    assert all(b >= a - 1e-9 for a, b in zip(changes[first:], changes[first + 1 :], strict=False))
    assert 0 < shares[first] < 0.2


def test_a_guard_and_the_membrane_take_turns_until_both_are_content():
    """`open_folds_guarded`: no guard where the membrane moved nothing; where it did, the guard runs, the membrane
    opens what the guard folded again, and so on until the guard moves nothing or GUARD_ROUNDS have passed."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0)).astype(np.float32)

    def run(refolds: int) -> tuple[np.ndarray, np.ndarray, int]:
        """The guard folds the centre back `refolds` times (saying it moved skin), then moves nothing."""
        positions, calls = folded.copy(), []

        def guard() -> bool:
            calls.append(1)
            if len(calls) > refolds:
                return False
            positions[centre()] = folded[centre()]
            return True

        moved = unfold.open_folds_guarded(mesh, positions, guard)
        return positions, moved, len(calls)

    still = rest.astype(np.float32)
    assert len(unfold.open_folds_guarded(mesh, still, lambda: pytest.fail("no fold: no guard"))) == 0
    for refolds, calls in ((0, 1), (2, 3), (50, unfold.GUARD_ROUNDS)):
        positions, moved, made = run(refolds)
        assert made == calls and centre() in moved
        assert not inverted_faces(rest, positions.astype(np.float64), triangles).any()  # the membrane ends it


def test_a_guard_that_folds_the_skin_back_as_far_every_round_ends_the_rounds():
    """A round whose membrane keeps no smaller share of its change than the round before opened no smaller fold: the
    guard and the membrane undo each other, and more rounds spend the frame's budget to end where they began. The
    rounds stop there, with the positions the sixth round would leave. Before, all GUARD_ROUNDS ran (the Lee
    Perry-Smith scan's sealed lip line, demo frames 22-27: 4-5 rounds of 275-290 steps over 544-631 vertices, each
    keeping 0.79-0.81 of its change, the last out of budget with a face left turned over)."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0)).astype(np.float32)
    positions, calls = folded.copy(), []

    def guard() -> bool:
        calls.append(1)
        positions[:] = folded  # the same fold again, every round
        return True

    unfold.open_folds_guarded(mesh, positions, guard, max_steps=unfold.MAX_STEPS)
    assert len(calls) == 2
    once = folded.copy()
    assert unfold.open_folds(mesh, once).left == 0
    np.testing.assert_array_equal(positions, once)
    assert not inverted_faces(rest, positions.astype(np.float64), triangles).any()


def test_the_guards_rounds_share_the_frames_budget():
    """The rounds of `open_folds_guarded` take their steps from one `max_steps`: a budget the first opening uses up
    leaves no round for the guard (each round had a budget of its own: 7 at the 2 mm remesh's slowest frames)."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0)).astype(np.float32)
    needed = unfold.open_folds(mesh, folded.copy()).steps
    assert needed > 0
    for budget, rounds in ((needed, 0), (50 * needed, unfold.GUARD_ROUNDS)):
        positions, calls = folded.copy(), []

        def guard(positions=positions, calls=calls) -> bool:
            calls.append(1)
            positions[centre()] = folded[centre()]  # folds the centre back every time
            return True

        unfold.open_folds_guarded(mesh, positions, guard, max_steps=budget)
        assert len(calls) == rounds


def test_the_guards_rounds_start_from_the_vertices_it_can_move():
    """With `guarded`, a round after the guard looks only at the triangles at those vertices: named right (the
    centre the guard folds back), the rounds end as a look at every triangle ends, bit for bit; named wrong (a
    corner of the grid), the guard's fold is not looked at and stays (so the rounds do start there)."""
    rest, triangles = grid()
    mesh = unfold.prepare(rest, triangles)
    folded = pushed(rest, (2.5e-3, 0.4e-3, 0.0)).astype(np.float32)

    def run(guarded):
        positions, calls = folded.copy(), []

        def guard() -> bool:
            calls.append(1)
            if len(calls) > 2:
                return False
            positions[centre()] = folded[centre()]
            return True

        moved = unfold.open_folds_guarded(mesh, positions, guard, guarded=guarded)
        return positions, moved, len(calls)

    whole, moved, calls = run(None)
    named, named_moved, named_calls = run(np.array([centre()]))
    assert calls == named_calls == 3 and np.array_equal(moved, named_moved) and np.array_equal(named, whole)
    assert not unfold.turned_over(mesh, named.astype(np.float64)).any()
    wrong, _moved, wrong_calls = run(np.array([0]))
    assert wrong_calls == 1 and np.array_equal(wrong[centre()], folded[centre()])
    assert unfold.turned_over(mesh, wrong.astype(np.float64)).any()


def jittered(jitter: float = 0.3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """`grid` with each vertex moved in its plane by up to `jitter` spacings: an irregular mesh (a remesh, a
    subdivision with its new vertices moved)."""
    rest, triangles = grid()
    move = np.random.default_rng(seed).uniform(-1.0, 1.0, (len(rest), 2)) * jitter * 1e-3
    return rest + np.c_[move, np.zeros(len(rest))], triangles


def test_the_membrane_weights_keep_a_displacement_linear_in_the_rest_positions():
    """Mean value weights: positive, 1 per vertex, and on a flat irregular mesh every inside vertex is their mean of
    its neighbours' rest positions (the plain mean misses by up to a tenth of a spacing here)."""
    rest, triangles = jittered()
    mesh = unfold.prepare(rest, triangles)
    row = np.repeat(np.arange(len(rest)), np.diff(mesh.neighbour_start))
    assert (mesh.weights > 0).all() and np.allclose(np.bincount(row, mesh.weights), 1.0)
    mean = np.stack([np.bincount(row, mesh.weights * rest[mesh.neighbours, k]) for k in range(3)], axis=1)
    inside = [i * SIZE + j for i in range(1, SIZE - 1) for j in range(1, SIZE - 1)]
    assert np.abs(mean[inside] - rest[inside]).max() < 1e-15


@pytest.mark.parametrize("seed", range(4))
def test_on_an_irregular_mesh_a_fold_in_compressed_skin_opens_where_it_is(seed):
    """An irregular grid squeezed to 0.3 of its width (no face turned), one vertex pushed past its neighbour: the
    fold opens as on the regular grid, in 5 steps over its 14-18 nearest vertices. With the plain mean of the
    neighbours the membrane moved the squeezed skin itself: 330-855 steps over the whole grid (the subdivided
    variant's lips at demo frame 120: 565 steps over 3,645 vertices, past a frame's budget, 65 faces left turned)."""
    rest, triangles = jittered(seed=seed)
    mesh = unfold.prepare(rest, triangles)
    squeezed = rest * (0.3, 1.0, 1.0)
    assert not unfold.turned_over(mesh, squeezed).any()
    folded = squeezed.copy()
    folded[centre()] += (0.75e-3, 0.4e-3, 0.0)
    assert unfold.turned_over(mesh, folded).any()
    positions = folded.copy()
    done = unfold.unfold(mesh, positions)
    assert done.left == 0 and done.steps == 5 and len(done.moved) <= 18
    assert not unfold.turned_over(mesh, positions).any()


@pytest.mark.parametrize("seed", range(4))
def test_a_budget_that_ends_with_no_fewer_folds_leaves_the_frame_as_it_came(seed):
    """The plain mean's membrane on a squeezed irregular grid (the weights before mean value weights) turns 2-3
    faces into 54-83 in its first 50 steps: cut off there by the budget, the unfold moves nothing and says what is
    left (before, it wrote the 54-83). The kernel does the same, bit for bit."""
    import dataclasses

    rest, triangles = jittered(seed=seed)
    mesh = unfold.prepare(rest, triangles)
    degree = np.diff(mesh.neighbour_start)
    plain = dataclasses.replace(mesh, weights=np.repeat(1.0 / degree, degree))
    folded = rest * (0.3, 1.0, 1.0)
    folded[centre()] += (0.75e-3, 0.4e-3, 0.0)
    found = int(unfold.turned_over(mesh, folded).sum())
    positions = folded.copy()
    done = unfold.unfold(plain, positions, max_steps=50)
    assert done.steps == 50 and done.left == found and len(done.moved) == 0
    assert np.array_equal(positions, folded)
    compiled = folded.astype(np.float32)
    got = _kernel_unfold(plain, compiled, None, 50)
    if got is not None:
        assert len(got[0]) == 0 and got[1:3] == (50, found) and np.array_equal(compiled, folded.astype(np.float32))


def test_a_frames_budget_is_work_so_a_small_fold_on_a_large_mesh_opens():
    """`frame_steps` costs a step at the whole mesh, so on a larger mesh a small fold got too few steps and stayed
    turned over (the Lee Perry-Smith scan's lip line in the demo: 3 faces for 18 frames); with the frame's work
    (`FRAME_WORK` vertex-steps) the steps go on at what the vertices they moved cost, and the fold opens. A call
    that opened nothing (no vertices to cost the steps at) ends there, as before."""
    rest, triangles = grid(31)
    mesh = unfold.prepare(rest, triangles)
    folded = rest.astype(np.float32)
    block = (15 + np.arange(-4, 5))[:, None] * 31 + 15 + np.arange(-4, 5)[None]
    folded[block.ravel(), 0] += 10e-3  # a 9 x 9 block pushed 10 spacings sideways, over its neighbours
    full = unfold.open_folds(mesh, folded.copy())
    assert full.left == 0 and full.steps > 10
    few = full.steps - unfold.CHECK_EVERY  # one batch short: what a mesh of many more vertices would give the frame
    positions = folded.copy()
    short = unfold.open_folds(mesh, positions, max_steps=few)
    assert short.left > 0 and len(short.moved)  # the step count alone leaves some of it
    positions = folded.copy()
    done = unfold.open_folds_within(mesh, positions, None, unfold.FrameBudget(len(rest), few, unfold.FRAME_WORK))
    assert done.left == 0 and not inverted_faces(rest, positions, triangles).any()
    assert done.steps <= full.steps + few and done.steps * len(done.moved) <= unfold.FRAME_WORK
    # the same through the guarded rounds, and a work budget too small for one more batch keeps the old bound
    positions = folded.copy()
    unfold.open_folds_guarded(mesh, positions, lambda: False, max_steps=few, work=unfold.FRAME_WORK)
    assert not inverted_faces(rest, positions, triangles).any()
    positions = folded.copy()
    small = unfold.open_folds_within(
        mesh, positions, None, unfold.FrameBudget(len(rest), few, (few + 4) * len(short.moved))
    )
    assert small.steps == few and small.left == short.left


@pytest.mark.parametrize("kernel", [False, True])
def test_momentum_opens_a_fold_that_needs_the_region_grown_in_fewer_steps_to_the_same_bounds(kernel):
    """A 5 x 5 block pushed 15 spacings sideways over its neighbours: the membrane opens it only once its region
    has grown by rings (the Lee Perry-Smith scan's sealed lip line in the demo: 655 steps over 3,215 vertices at
    frame 24). Each step taken from Nesterov's look-ahead point, restarted where the region grows, opens it in 25
    steps over 103 vertices where the plain Jacobi steps took 45 over 106, and to the same bounds: no triangle
    turned over, the change kept near the fold and as large. The kernel equals the numpy bit for bit, with the
    momentum and without."""
    size = 51
    rest, triangles = grid(size)
    mesh = unfold.prepare(rest, triangles)
    middle = (size // 2) * size + size // 2
    block = middle + (np.arange(-2, 3)[:, None] * size + np.arange(-2, 3)[None]).ravel()
    folded = rest.astype(np.float32)
    folded[block, 0] += 15e-3
    assert unfold.turned_over(mesh, folded.astype(np.float64)).sum() >= 10
    results = {}
    for momentum in (False, True):
        positions = folded.copy()
        done = unfold.unfold(mesh, positions, momentum=momentum)
        assert done.left == 0 and not inverted_faces(rest, positions, triangles).any()
        assert np.linalg.norm(rest[done.moved] - rest[middle], axis=1).max() < 9e-3
        if kernel:
            if not fused.available():
                pytest.skip("compiled kernel not installed")
            compiled = folded.copy()
            got = _kernel_unfold(mesh, compiled, momentum=momentum)
            assert np.array_equal(got[0], done.moved) and got[1:] == (done.steps, done.left, done.share)
            assert np.array_equal(compiled, positions)
        results[momentum] = done, np.abs(positions - folded).max()
    (plain, plain_change), (fast, fast_change) = results[False], results[True]
    assert (plain.steps, fast.steps) == (45, 25)
    assert fast.steps * len(fast.moved) < 0.6 * plain.steps * len(plain.moved)
    assert abs(fast_change - plain_change) < 0.1 * plain_change
    assert unfold.MOMENTUM and unfold.open_folds(mesh, folded.copy()).steps == fast.steps
