"""`evaluate_placement --template`: the leave-out measurement of docs/auto_placement.md places with another
template file, and the shipped one is what placement loads again afterwards."""

import sys

import numpy as np
import pytest

pytest.importorskip("bpy")

from addon.placement import template
from scripts.bench import evaluate_placement


def test_the_template_option_swaps_the_file_placement_loads(tmp_path, monkeypatch):
    shipped = template.load_template()
    other = tmp_path / "other.npz"
    with np.load(template.TEMPLATE_FILE) as data:
        arrays = dict(data)
    arrays["fp_positions"] = arrays["fp_positions"] + 1.0
    np.savez(other, **arrays)
    heads = tmp_path / "heads"
    heads.mkdir()
    monkeypatch.setattr(template, "TEMPLATE_FILE", template.TEMPLATE_FILE)
    monkeypatch.setattr(sys, "argv", ["evaluate_placement", "--heads", str(heads), "--template", str(other)])
    try:
        assert evaluate_placement.main() == 1  # no heads in the folder: nothing measured
        assert template.TEMPLATE_FILE == other
        assert np.allclose(template.load_template().fp_positions, shipped.fp_positions + 1.0)
    finally:
        template.load_template.cache_clear()


def test_above_p95_names_the_points_the_percentile_is_made_of():
    errors = np.ones((5, 84))  # 420 errors: the 95th percentile lies among the 21 largest
    errors[:, 83] = 9.0  # 11.6 off on every head
    errors[:3, 0] = 7.0  # 2.1 off on three
    errors[0, 1] = 0.5
    over = evaluate_placement.above_p95(errors)
    assert over == {"11.6": 5, "2.1": 3}
    assert list(over) == ["11.6", "2.1"]


def test_the_listing_is_scored_against_the_errors():
    errors = np.ones((2, 84))
    errors[0, 0] = errors[1, 0] = 5.0  # 2.1 off on both heads
    errors[1, 83] = 4.0  # 11.6 off on the second
    listed = [["2.1", "3.5"], ["2.1"]]  # 2.1 listed on both, 3.5 (1 mm off) on the first, 11.6 not
    assert evaluate_placement.listed_against_errors(errors, listed) == {
        "over": 3,
        "over_listed": 2,
        "listed": 3,
        "listed_within": 1,
    }
