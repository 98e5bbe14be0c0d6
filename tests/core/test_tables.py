"""The FP and FAP tables against the standard's counts, groups and symmetry."""

import numpy as np
import pytest

from addon.mpeg4.faps import (
    FAPS,
    INNER_OUTER_LIP_PAIRS,
    LEFT_RIGHT_PAIRS,
    Expression,
    ExpressionValue,
    Viseme,
    VisemeValue,
    expression_weights,
    fap,
    viseme_weights,
)
from addon.mpeg4.feature_points import FEATURE_POINTS, FP_IDS, SURFACES, feature_point, fp_index, mirror_index

GROUP_SIZES = {2: 14, 3: 14, 4: 6, 5: 4, 6: 4, 7: 1, 8: 10, 9: 15, 10: 10, 11: 6}


def test_84_feature_points_in_groups_2_to_11():
    assert len(FEATURE_POINTS) == 84 == len(set(FP_IDS))
    sizes = {g: sum(fp.group == g for fp in FEATURE_POINTS) for g in GROUP_SIZES}
    assert sizes == GROUP_SIZES
    for g, n in GROUP_SIZES.items():
        assert {fp.id for fp in FEATURE_POINTS if fp.group == g} == {f"{g}.{i}" for i in range(1, n + 1)}


def test_mirror_partners_are_symmetric_and_on_opposite_sides():
    mirror = mirror_index()
    for i, fp in enumerate(FEATURE_POINTS):
        assert mirror[mirror[i]] == i
        if fp.mirror is None:
            assert fp.side == "mid"
        else:
            assert {fp.side, feature_point(fp.mirror).side} == {"L", "R"}
    # parity changes between groups: these are right-side points although odd-numbered or paired oddly
    assert [feature_point(i).side for i in ("8.9", "9.4", "9.6", "11.2", "3.8", "3.12")] == ["R"] * 6
    assert feature_point("3.7").mirror == "3.12" and feature_point("3.11").mirror == "3.8"


def test_surfaces():
    assert all(fp.surface in SURFACES for fp in FEATURE_POINTS)
    by_surface = {s: sorted(fp.id for fp in FEATURE_POINTS if fp.surface == s) for s in SURFACES}
    assert by_surface["eye"] == ["3.5", "3.6"]
    assert by_surface["teeth"] == ["9.10", "9.11", "9.8", "9.9"]
    assert by_surface["tongue"] == ["6.1", "6.2", "6.3", "6.4"]
    assert len(by_surface["ear"]) == 10 and len(by_surface["hair"]) == 6
    assert fp_index("2.1") == 0 and fp_index("11.6") == 83
    with pytest.raises(KeyError, match="12.1"):
        fp_index("12.1")


def test_68_faps_with_groups_units_and_points():
    assert [f.number for f in FAPS] == list(range(1, 69))
    group_bounds = {
        1: (1, 2),
        2: (3, 18),
        3: (19, 30),
        4: (31, 38),
        5: (39, 42),
        6: (43, 47),
        7: (48, 50),
        8: (51, 60),
        9: (61, 64),
        10: (65, 68),
    }
    for g, (lo, hi) in group_bounds.items():
        assert {f.number for f in FAPS if f.group == g} == set(range(lo, hi + 1))
    assert fap("open_jaw").fapu == "MNS" and fap(3).fp == "2.1" and fap(3).axis == (0.0, -1.0, 0.0)
    assert fap(19).fapu == "IRISD"  # XFace's MNS here is a known bug
    assert {f.number for f in FAPS if f.fapu == "AU"} == {23, 24, 25, 26, 47, 48, 49, 50}
    assert {f.number for f in FAPS if not f.bidirectional and f.fapu} == {3, 14, 41, 42, 47}
    assert fap(6).axis == (1.0, 0.0, 0.0) and fap(7).axis == (-1.0, 0.0, 0.0)  # mirrored pair
    for f in FAPS[2:]:
        assert f.fp in FP_IDS
    # every left/right pair moves mirror-partner points with mirrored (or equal vertical) directions
    for a, b in LEFT_RIGHT_PAIRS:
        fa, fb = fap(a), fap(b)
        assert feature_point(fa.fp).mirror == fb.fp
        if fa.axis is not None:
            assert fa.axis == (-fb.axis[0], fb.axis[1], fb.axis[2])
    for inner, outer in INNER_OUTER_LIP_PAIRS:
        assert fap(inner).direction == fap(outer).direction and fap(inner).fapu == fap(outer).fapu


def test_viseme_blend_and_expression_intensities():
    v = VisemeValue.from_fields([1, 10, 40, 0])
    assert v.select1 is Viseme.PP and v.select2 is Viseme.AA and v.fields() == (1, 10, 40, 0)
    w = viseme_weights([[1, 10, 40, 0], [3, 3, 63, 1], [0, 14, 0, 0]])
    np.testing.assert_allclose(w[0, [1, 10]], [40 / 63, 23 / 63])
    np.testing.assert_allclose(w[1, 3], 1.0)
    np.testing.assert_allclose(w[2, 14], 1.0)
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    e = ExpressionValue.from_fields([1, 63, 6, 21, 0, 0])
    assert e.select1 is Expression.JOY and e.select2 is Expression.SURPRISE
    ew = expression_weights([e.fields()])
    np.testing.assert_allclose(ew[0], [0, 1, 0, 0, 0, 0, 1 / 3])  # additive, not convex
    with pytest.raises(ValueError, match="0..14"):
        viseme_weights([[15, 0, 0, 0]])
