"""The FP-motion bound (`scripts/bench/fp_motion_bound.py`) on made-up units with known answers."""

import numpy as np
import pytest

pytest.importorskip("bpy")  # the bench module reads the sample head through scripts.bench.evaluate

from scripts.bench.fp_motion_bound import mirror_twin, predictions, scores


def _units(rng, units=12, vertices=40, controls=5):
    weights = rng.uniform(-1, 1, (vertices, controls))
    fp = rng.normal(0, 1e-3, (units, controls, 3))
    return weights, fp, np.einsum("vf,ufc->uvc", weights, fp)


def test_vertex_offsets_that_are_fp_blends_are_recovered_in_and_out_of_sample():
    rng = np.random.default_rng(1)
    weights, fp, vertex = _units(rng)
    for left_out in ([[] for _ in range(12)], [[u] for u in range(12)]):
        predicted = predictions(vertex, fp, left_out, ridge=1e-14)
        np.testing.assert_allclose(predicted, vertex, atol=1e-9)


def test_a_unit_nothing_else_explains_is_not_predicted_out_of_sample():
    rng = np.random.default_rng(2)
    _weights, fp, vertex = _units(rng)
    fp[:, 4] = 0.0
    fp[0, 4] = [1e-3, 0, 0]  # only unit 0 moves FP 4
    vertex[0] += 2e-3  # and with it everything, which no other unit shows
    out = predictions(vertex, fp, [[u] for u in range(12)], ridge=1e-14)
    inside = predictions(vertex, fp, [[] for _ in range(12)], ridge=1e-14)
    region = np.zeros(vertex.shape[1], int)
    assert scores(vertex, out, region)["per_unit"][0] > 0.5
    assert scores(vertex, inside, region)["per_unit"][0] < scores(vertex, out, region)["per_unit"][0]


def test_still_fps_leave_every_vertex_at_rest():
    rng = np.random.default_rng(3)
    _weights, fp, vertex = _units(rng)
    fp[5] = 0.0
    predicted = predictions(vertex, fp, [[] for _ in range(12)], ridge=1e-9)
    assert not np.any(predicted[5])
    assert scores(vertex, predicted, np.zeros(vertex.shape[1], int))["per_unit"][5] == 1.0


def test_scores_pool_sums_and_split_regions():
    vertex = np.zeros((1, 3, 3))
    vertex[0, :, 0] = [1.0, 2.0, 3.0]
    predicted = np.zeros_like(vertex)
    predicted[0, :, 0] = [1.0, 1.0, 0.0]  # errors 0, 1, 3
    result = scores(vertex, predicted, np.array([0, 0, 1]))
    assert result["pooled"] == 4.0 / 6.0
    assert result["regions"]["brows"] == 1.0 / 3.0
    assert result["regions"]["eyes"] == 1.0


def test_mirror_twins():
    names = ["eye-left-closure", "eye-right-closure", "mouth-open", "nose-left-elevation"]
    assert mirror_twin("eye-left-closure", names) == 1
    assert mirror_twin("eye-right-closure", names) == 0
    assert mirror_twin("mouth-open", names) is None
    assert mirror_twin("nose-left-elevation", names) is None
