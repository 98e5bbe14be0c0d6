"""Open Sealed Mouth's cut (addon/deform/mouth_cut.py) on hand-made mouths: a sheet of skin whose lips meet in a
crease that smiles (the grid's rows run straight, the crease curves across them), cut open or refused."""

import numpy as np
import pytest

pytest.importorskip("scipy")

from addon.deform import face_checks
from addon.deform.mouth_cut import LIP_PAIRS, MouthCutError, edge_weights, find_mouth_cut, split_corners

STEP = 0.001  # m, the grid's edge
HALF_WIDTH = 0.025  # m, the mouth's corners at x = +-HALF_WIDTH
DEPTH = 0.004  # m, the crease's depth at the middle
AXES = np.eye(3)  # x left, y up, z forward: the grid looks along -z


def crease_y(x, smile=0.003):
    """The crease's height along the mouth: a smile, `smile` higher at the corners than in the middle."""
    return smile * (np.asarray(x) / HALF_WIDTH) ** 2


def surface_z(x, y, smile):
    """The sheet's depth: a V 2 grid steps wide each side of the crease, DEPTH deep in the middle, none at the
    corners."""
    along = np.clip(1.0 - (np.asarray(x) / HALF_WIDTH) ** 2, 0.0, None)
    across = np.clip(1.0 - np.abs(np.asarray(y) - crease_y(x, smile)) / (2 * STEP), 0.0, None)
    return -DEPTH * along * across


def sealed_mouth(open_slit: bool = False):
    """(vertices, sizes, corners, FPs): a 10 x 4 cm sheet, quads, facing +z, with a V crease 2 grid steps wide
    along `crease_y` between the corners; `open_slit`: a straight crease, the sheet cut along its bottom row (an
    opening between the lips already)."""
    smile = 0.0 if open_slit else 0.003
    xs = np.arange(-0.04, 0.04 + STEP / 2, STEP)
    ys = np.arange(-0.02, 0.02 + STEP / 2, STEP)
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    gz = surface_z(gx, gy, smile)
    vertices = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    nx, ny = len(xs), len(ys)
    index = np.arange(nx * ny).reshape(ny, nx)
    quads = np.stack([index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]], axis=-1).reshape(-1, 4)
    if open_slit:  # the rows below y = 0 get their own copies of the row y = 0 between the corners: a slit
        row = int(np.argmin(np.abs(ys)))
        slit = index[row, np.abs(xs) < HALF_WIDTH - STEP / 2]
        copies = len(vertices) + np.arange(len(slit))
        vertices = np.vstack([vertices, vertices[slit]])
        remap = np.arange(len(vertices))
        remap[slit] = copies
        below = np.arange(len(quads)) < (row * (nx - 1))  # the quads of the rows under y = 0
        quads[below] = remap[quads[below]]
    sizes = np.full(len(quads), 4)
    corner = crease_y(HALF_WIDTH, smile)
    fps = {"2.4": (HALF_WIDTH, corner), "2.5": (-HALF_WIDTH, corner)}
    for x, (upper, lower) in zip((HALF_WIDTH / 2, 0.0, -HALF_WIDTH / 2), LIP_PAIRS, strict=True):
        fps[upper] = (x, crease_y(x, smile) + 0.8 * STEP)
        fps[lower] = (x, crease_y(x, smile) - 0.8 * STEP)
    fps = {k: np.array([x, y, surface_z(x, y, smile)]) for k, (x, y) in fps.items()}
    return vertices, sizes, quads.ravel(), fps


def _graph(vertices, sizes, corners):
    from scipy.sparse import coo_matrix

    edges, _ = edge_weights(vertices, sizes, corners)
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    return coo_matrix((length, (edges[:, 0], edges[:, 1])), shape=(len(vertices),) * 2).tocsr()


def _joined(vertices, sizes, corners, a, b) -> bool:
    from scipy.sparse.csgraph import dijkstra

    graph = _graph(vertices, sizes, corners)
    return face_checks.joined_over_skin(graph, vertices, a, b, 2 * HALF_WIDTH, dijkstra)


def test_a_sealed_crease_is_cut_along_its_bottom_from_corner_to_corner():
    vertices, sizes, corners, fps = sealed_mouth()
    cut = find_mouth_cut(vertices, sizes, corners, fps, AXES)
    ends = vertices[cut.path[[0, -1]]]
    np.testing.assert_allclose(ends[:, :2], [[HALF_WIDTH, crease_y(HALF_WIDTH)], [-HALF_WIDTH, crease_y(HALF_WIDTH)]])
    # every vertex of the cut lies in the crease (below the sheet, within 1.5 grid steps of its bottom: the grid's
    # rows step across the curve, and the V is 2 steps wide each side) although the crease curves across the rows,
    # 3 mm off the straight line between the corners
    off = np.abs(vertices[cut.path, 1] - crease_y(vertices[cut.path, 0]))
    assert off.max() <= 1.5 * STEP, off.max()
    assert (vertices[cut.path[1:-1], 2] < 0.0).all()
    assert (np.diff(vertices[cut.path, 0]) <= 0).all()  # across, left corner to right, never back
    # one cut edge per grid column plus a step up or down where the crease changes row
    assert len(cut.path) - 1 < 2 * int(round(2 * HALF_WIDTH / STEP))


def test_the_cut_parts_the_lips_and_keeps_the_corners_one():
    vertices, sizes, corners, fps = sealed_mouth()
    cut = find_mouth_cut(vertices, sizes, corners, fps, AXES)
    new_corners, sources = split_corners(len(vertices), sizes, corners, cut)
    np.testing.assert_array_equal(sources, cut.path[1:-1])
    after = np.vstack([vertices, vertices[sources]])
    upper, lower = (int(np.argmin(np.linalg.norm(vertices - fps[k], axis=1))) for k in ("2.2", "2.3"))
    assert _joined(vertices, sizes, corners, upper, lower)
    assert not _joined(after, sizes, new_corners, upper, lower)  # now a path between them goes round a corner
    # the upper side keeps the path's vertices, the lower side has the copies; the corners are one vertex each
    polygons = new_corners.reshape(-1, 4)
    assert not np.isin(polygons[cut.upper], len(vertices) + np.arange(len(sources))).any()
    assert np.isin(polygons[cut.lower], cut.path[1:-1]).sum() == 0
    assert np.isin(new_corners, cut.path[[0, -1]]).sum() == np.isin(corners, cut.path[[0, -1]]).sum()
    lower_centres = after[polygons[cut.lower]].mean(axis=1)
    upper_centres = after[polygons[cut.upper]].mean(axis=1)
    assert (lower_centres[:, 1] < crease_y(lower_centres[:, 0]) + STEP).all()
    assert (upper_centres[:, 1] > crease_y(upper_centres[:, 0]) - STEP).all()
    assert len(cut.upper) + len(cut.lower) == np.isin(polygons, cut.path[1:-1]).any(axis=1).sum() + len(cut.lower)
    # nothing moved: the copies sit where their vertices are, until the jaw opens
    np.testing.assert_array_equal(after[len(vertices) :], vertices[cut.path[1:-1]])


def test_a_crease_is_cheaper_to_follow_than_flat_skin():
    vertices, sizes, corners, _fps = sealed_mouth()
    edges, weight = edge_weights(vertices, sizes, corners)
    middle = 0.5 * (vertices[edges[:, 0]] + vertices[edges[:, 1]])
    flat = middle[:, 2] == 0.0
    along_bottom = (np.abs(middle[:, 1] - crease_y(middle[:, 0])) < STEP / 4) & (np.abs(middle[:, 0]) < 0.01)
    along_bottom &= edges[:, 0] + 1 == edges[:, 1]  # along x
    assert np.all(weight[flat & (np.abs(middle[:, 0]) > HALF_WIDTH + STEP)] == 1.0)
    # the V's walls fall 4 mm over 2 mm: a valley folding by 2 atan(2) = 127 degrees at its bottom
    expected = 0.5 * (1.0 + np.cos(2.0 * np.arctan(DEPTH / (2 * STEP))))
    assert weight[along_bottom].max() < 0.4 and weight[along_bottom].min() > 0.0
    assert abs(np.median(weight[along_bottom]) - expected) < 0.15


def test_an_open_mouth_is_not_cut():
    vertices, sizes, corners, fps = sealed_mouth(open_slit=True)
    with pytest.raises(MouthCutError, match="opening between the lips already"):
        find_mouth_cut(vertices, sizes, corners, fps, AXES)


def test_lip_fps_off_the_crease_are_named_and_nothing_is_cut():
    vertices, sizes, corners, fps = sealed_mouth()
    fps["2.2"], fps["2.3"] = fps["2.2"] - [0, 0.006, 0], fps["2.3"] - [0, 0.003, 0]  # both on the lower lip
    with pytest.raises(MouthCutError, match=r"FP 2\.3 lies above FP 2\.2"):
        find_mouth_cut(vertices, sizes, corners, fps, AXES)


def test_missing_fps_are_named():
    vertices, sizes, corners, fps = sealed_mouth()
    del fps["2.7"], fps["2.4"]
    with pytest.raises(MouthCutError, match=r"FP 2\.4, 2\.7"):
        find_mouth_cut(vertices, sizes, corners, fps, AXES)


def test_a_mouth_cut_open_is_open_even_with_its_lip_fps_on_one_point():
    vertices, sizes, corners, fps = sealed_mouth()
    for upper, lower in LIP_PAIRS:  # the standard's neutral face: closed lips, each pair's FPs at one point
        x = fps[upper][0]
        fps[upper] = fps[lower] = np.array([x, crease_y(x), surface_z(x, crease_y(x), 0.003)])
    cut = find_mouth_cut(vertices, sizes, corners, fps, AXES)
    new_corners, sources = split_corners(len(vertices), sizes, corners, cut)
    after = np.vstack([vertices, vertices[sources]])
    # the cut's two vertices at each point are both nearest the FPs there: the one on each side are not joined
    with pytest.raises(MouthCutError, match="opening between the lips already"):
        find_mouth_cut(after, sizes, new_corners, fps, AXES)


def test_lip_fps_all_on_one_lip_find_no_crease_and_nothing_is_cut():
    vertices, sizes, corners, fps = sealed_mouth()
    for fp in ("2.2", "2.3", "2.6", "2.7", "2.8", "2.9"):  # in order, but 5 mm down on the lower lip's skin
        fps[fp] = fps[fp] - [0.0, 0.005, 0.0]
    with pytest.raises(MouthCutError, match="no crease along the inner-lip feature points"):
        find_mouth_cut(vertices, sizes, corners, fps, AXES)


def test_masks_seed_each_lip_on_its_own_side_of_the_cut():
    from addon.deform.auto_masks import _twin_on_side

    vertices, sizes, corners, fps = sealed_mouth()
    cut = find_mouth_cut(vertices, sizes, corners, fps, AXES)
    new_corners, sources = split_corners(len(vertices), sizes, corners, cut)
    after = np.vstack([vertices, vertices[sources]])
    edges, _ = edge_weights(after, sizes, new_corners)
    middle = cut.path[len(cut.path) // 2]  # a vertex of the cut: it and its copy are both nearest an FP there
    twin = len(vertices) + len(cut.path) // 2 - 1
    np.testing.assert_array_equal(after[twin], after[middle])
    # a side's other FPs, off the cut: the outer lips' middles, 8 mm above and below
    above, below = (int(np.argmin(np.linalg.norm(vertices - [0.0, y, 0.0], axis=1))) for y in (0.008, -0.008))
    assert _twin_on_side(after, edges, np.array([middle, above])).tolist() == [middle, above]
    assert _twin_on_side(after, edges, np.array([middle, below])).tolist() == [twin, below]
    assert _twin_on_side(after, edges, np.array([twin, above])).tolist() == [middle, above]
    before = edge_weights(vertices, sizes, corners)[0]
    assert _twin_on_side(vertices, before, np.array([middle, below])).tolist() == [middle, below]  # no twin yet
