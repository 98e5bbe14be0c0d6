"""The control-mesh template: real skin FPs, no duplicates, manifold, valid masks; and the checker itself."""

import numpy as np
import pytest

from addon.mpeg4.control_mesh import (
    BROWS,
    CONTROL_TRIANGLES,
    EYES,
    MASK_NAMES,
    MOUTH_AND_JAW,
    OTHER_UPPER,
    TRIANGLE_MASKS,
    ControlMeshError,
    check_control_mesh,
    control_fp_ids,
    template_indices,
    triangle_parts,
)
from addon.mpeg4.feature_points import FEATURE_POINTS, FP_IDS, feature_point

HAIRLINE = ("11.1", "11.2", "11.3")  # the forehead's upper edge
EAR_CONTACTS = ("10.1", "10.2", "10.3", "10.4", "10.7", "10.8")  # where the ears meet the head
EDGE_OF_FACE = HAIRLINE + EAR_CONTACTS
SKIN_IDS = tuple(fp.id for fp in FEATURE_POINTS if fp.surface == "skin" or fp.id in EDGE_OF_FACE)
UPPER_LIP = {"8.1", "8.5", "8.6", "8.9", "8.10", "2.2", "2.6", "2.7"}
LOWER_LIP = {"8.2", "8.7", "8.8", "2.3", "2.8", "2.9"}
UPPER_LID = {"3.1", "3.2", "3.13", "3.14"}
LOWER_LID = {"3.3", "3.4", "3.9", "3.10"}


def test_every_id_is_a_skin_fp_and_every_skin_fp_is_used():
    used = {fp_id for triangle in CONTROL_TRIANGLES for fp_id in triangle}
    assert all(feature_point(fp_id).surface == "skin" or fp_id in EDGE_OF_FACE for fp_id in used)
    assert used == set(SKIN_IDS)
    assert control_fp_ids(FP_IDS) == SKIN_IDS


def test_no_duplicate_or_degenerate_triangles():
    keys = [frozenset(triangle) for triangle in CONTROL_TRIANGLES]
    assert all(len(key) == 3 for key in keys)
    assert len(set(keys)) == len(keys)


def test_template_is_a_consistently_oriented_manifold():
    ids = control_fp_ids(FP_IDS)
    triangles = template_indices(ids)
    # Topology only: random points in general position do not change edge sharing or winding.
    points = np.random.default_rng(0).normal(size=(len(ids), 3))
    assert check_control_mesh(points, triangles) == []


def test_template_is_its_own_mirror_image():
    # a triangle split one way on one side only (as the nose bridge once was) moves the two brows differently
    mirror = {fp.id: fp.mirror or fp.id for fp in FEATURE_POINTS}
    masks = {frozenset(t): mask for t, mask in zip(CONTROL_TRIANGLES, TRIANGLE_MASKS, strict=True)}
    for triangle, mask in masks.items():
        image = frozenset(mirror[fp_id] for fp_id in triangle)
        assert image in masks, sorted(triangle)
        assert masks[image] == mask, sorted(triangle)  # mirror partners sit on the same side of an opening


def test_triangle_parts_by_hand_and_mirrored():
    ids = ["2.1", "8.3", "3.7", "4.5", "5.3", "9.1", "11.1", "10.7"]
    triangles = np.array([[0, 4, 5], [1, 2, 3], [2, 3, 4], [4, 5, 6], [3, 6, 4], [0, 4, 7], [0, 2, 7]])
    assert triangle_parts(ids, triangles).tolist() == [MOUTH_AND_JAW, MOUTH_AND_JAW, EYES, OTHER_UPPER, BROWS,
                                                       OTHER_UPPER, EYES]  # fmt: skip
    assert triangle_parts(ids, np.zeros((0, 3), int)).shape == (0,)
    mirror = {fp.id: fp.mirror or fp.id for fp in FEATURE_POINTS}
    ids = control_fp_ids(FP_IDS)
    parts = dict(zip(map(frozenset, CONTROL_TRIANGLES), triangle_parts(ids, template_indices(ids)), strict=True))
    assert all(parts[frozenset(mirror[f] for f in t)] == part for t, part in parts.items())
    assert set(parts.values()) == {MOUTH_AND_JAW, EYES, BROWS, OTHER_UPPER}
    # the jaw's triangles to the ear lobes are the side of the head, not the jaw
    assert parts[frozenset(("5.1", "2.13", "10.7"))] == OTHER_UPPER


def test_masks_are_valid_and_match_the_lip_and_eyelid_fps():
    assert len(TRIANGLE_MASKS) == len(CONTROL_TRIANGLES)
    for triangle, mask in zip(CONTROL_TRIANGLES, TRIANGLE_MASKS, strict=True):
        fps = set(triangle)
        assert mask is None or mask in MASK_NAMES
        groups = {"upper_lip": UPPER_LIP, "lower_lip": LOWER_LIP, "upper_eyelid": UPPER_LID, "lower_eyelid": LOWER_LID}
        expected = [name for name, group in groups.items() if fps & group]
        assert expected == ([mask] if mask else []), triangle


def test_no_triangle_bridges_the_mouth_or_an_eye():
    for triangle in CONTROL_TRIANGLES:
        fps = set(triangle)
        assert not (fps & UPPER_LIP and fps & LOWER_LIP), triangle
        assert not (fps & UPPER_LID and fps & LOWER_LID), triangle


def test_openings_are_holes_bounded_by_the_inner_contours():
    edges: dict[frozenset, int] = {}
    for triangle in CONTROL_TRIANGLES:
        for k in range(3):
            edge = frozenset((triangle[k], triangle[(k + 1) % 3]))
            edges[edge] = edges.get(edge, 0) + 1
    mouth = ["2.2", "2.6", "2.4", "2.8", "2.3", "2.9", "2.5", "2.7"]
    left_eye = ["3.11", "3.1", "3.7", "3.3"]
    for ring in (mouth, left_eye):
        for a, b in zip(ring, ring[1:] + ring[:1], strict=True):
            if {a, b} == {"2.2", "2.3"}:
                continue
            assert edges.get(frozenset((a, b))) == 1, (a, b)  # a boundary edge of the hole
    assert frozenset(("2.2", "2.3")) not in edges


def _square():
    points = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    return points, np.array([[0, 1, 2], [0, 2, 3]])


def test_checker_accepts_a_hand_made_square():
    assert check_control_mesh(*_square()) == []


def test_checker_reports_flipped_triangle():
    points, triangles = _square()
    problems = check_control_mesh(points, np.array([triangles[0], triangles[1][::-1]]))
    assert any("inconsistent orientation" in p for p in problems)


def test_checker_reports_edge_in_three_triangles_and_duplicates():
    points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]])
    triangles = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert any("non-manifold" in p for p in check_control_mesh(points, triangles))
    duplicated = np.array([[0, 1, 2], [2, 1, 0], [0, 3, 1], [0, 1, 4]])
    assert any("same corners" in p for p in check_control_mesh(points, duplicated))


def test_checker_reports_bow_tie_vertex_and_unused_point():
    points = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0], [5, 5, 5]])
    problems = check_control_mesh(points, np.array([[0, 1, 2], [0, 3, 4]]))
    assert any("more than one fan" in p for p in problems)
    assert any("used by no triangle: [5]" in p for p in problems)


def test_checker_reports_degenerate_triangle():
    points = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    assert any("degenerate" in p for p in check_control_mesh(points, np.array([[0, 1, 2]])))


@pytest.mark.parametrize(
    ("points", "triangles"),
    [
        (np.zeros((3, 2)), np.array([[0, 1, 2]])),
        (np.zeros((3, 3)), np.array([[0, 1, 3]])),
        (np.zeros((3, 3)), np.array([[0.0, 1, 2]])),
        (np.full((3, 3), np.nan), np.array([[0, 1, 2]])),
    ],
)
def test_checker_rejects_malformed_input(points, triangles):
    with pytest.raises(ControlMeshError):
        check_control_mesh(points, triangles)


def test_template_indices_names_missing_fps():
    with pytest.raises(ControlMeshError, match="2.1"):
        template_indices(tuple(i for i in SKIN_IDS if i != "2.1"))
