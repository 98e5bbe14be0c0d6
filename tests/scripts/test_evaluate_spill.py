"""The spill measure of scripts/bench/evaluate.py, worked by hand."""

import numpy as np
import pytest

pytest.importorskip("bpy")  # scripts.bench.evaluate reads the sample head through bpy

from scripts.bench.evaluate import pooled_spill, score, target_spill


def test_spill_counts_error_and_moved_vertices_on_still_skin():
    rest = np.zeros((4, 3))
    sculpted = np.array([[0, 0, 2e-3], [0, 0, 0.05e-3], [0, 0, 0], [0, 0, 0]])  # vertices 1..3 are still skin
    deformed = np.array([[0, 0, 1e-3], [0, 0, 0.5e-3], [0, 0, 0.2e-3], [0, 0, 0]])
    s = score(deformed, sculpted, rest)
    share, moved = s.spill()
    assert share == pytest.approx((0.45 + 0.2) / (1.0 + 0.45 + 0.2))
    assert moved == 1  # vertex 1 moved 0.5 mm > 0.3 mm; vertex 2 only 0.2 mm
    region = np.array([0, 0, 1, -1])
    per_region = target_spill(s, region)["regions"]
    assert per_region["brows"] == {"share": pytest.approx(0.45 / 1.45), "moved": 1}
    assert per_region["eyes"] == {"share": 1.0, "moved": 0}
    assert per_region["cheeks"] == {"share": 0.0, "moved": 0}  # no vertex, no error
    assert pooled_spill([s, s]) == pytest.approx(share)
    assert pooled_spill([s], region == 0) == pytest.approx(0.45 / 1.45)
