"""Per-group gain and soft limit of FAP values; the real streams stay plausible under the defaults."""

from pathlib import Path

import numpy as np
import pytest

from addon.mpeg4.decode import CLOSING_PAIRS, fap_to_fp, hold_missing
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.fap_groups import FAP_GROUP, GROUP_NAMES, GROUPS, KNEE, LOWER, UPPER, shape_faps, soft_limit
from addon.mpeg4.fapu import Fapu
from addon.mpeg4.feature_points import fp_index
from addon.speech.high_level import apply_high_level

INTEROP = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap"


def test_table_covers_the_six_groups_without_overlap():
    assert GROUP_NAMES == ("jaw", "lips", "eyelids", "eyes", "brows", "head")
    numbers = [n for ranges in GROUPS.values() for key in ranges for n in key]
    assert len(numbers) == len(set(numbers))
    assert np.all(LOWER[FAP_GROUP >= 0] < 0) and np.all(UPPER[FAP_GROUP >= 0] > 0)
    assert FAP_GROUP[2] == GROUP_NAMES.index("jaw") and FAP_GROUP[48] == GROUP_NAMES.index("head")
    assert FAP_GROUP[0] == FAP_GROUP[1] == FAP_GROUP[40] == -1  # viseme, expression, cheek lift: none


def test_soft_limit_by_hand():
    x = np.array([-1e9, -150.0, -80.0, 0.0, 79.0, 80.0, 90.0, 100.0, 1e9])
    y = soft_limit(x, -100.0, 100.0)
    np.testing.assert_allclose(y[2:6], x[2:6])  # inside the knee: unchanged
    assert y[6] == pytest.approx(80 + 20 * np.tanh(0.5))
    assert y[7] == pytest.approx(80 + 20 * np.tanh(1.0))
    assert y[0] == pytest.approx(-100.0) and y[-1] == pytest.approx(100.0)
    assert np.all(np.abs(y) <= 100.0)


def test_soft_limit_is_smooth_and_monotone():
    x = np.linspace(-400, 400, 80001)
    y = soft_limit(x, -150.0, 250.0)
    slope = np.diff(y) / np.diff(x)
    assert np.all(slope > 0)  # monotone: order of values kept
    assert np.abs(np.diff(slope)).max() < 1e-3  # no corner at the knees
    assert y.min() > -150.0 and y.max() < 250.0


def test_infinite_limits_pass_values():
    x = np.array([-1e6, 3.0, 1e6])
    np.testing.assert_array_equal(soft_limit(x, -np.inf, np.inf), x)


def test_gains_scale_their_group_only():
    values = np.full((2, 68), 10.0)
    out = shape_faps(values, {"brows": 2.0, "jaw": 0.0}, limit=False)
    assert np.all(out[:, 30:38] == 20.0)  # FAPs 31-38
    assert np.all(out[:, [2, 13, 14, 17]] == 0.0)  # FAPs 3, 14, 15, 18
    assert out[0, 3] == 10.0 and out[0, 40] == 10.0


def test_bad_gains_are_refused():
    with pytest.raises(KeyError):
        shape_faps(np.zeros((1, 68)), {"nose": 1.0})
    with pytest.raises(ValueError):
        shape_faps(np.zeros((1, 68)), {"lips": -1.0})


def test_ordinary_values_pass_unchanged():
    values = np.zeros((1, 68))
    values[0, [2, 3, 18, 30, 48]] = (512, 200, 1024, 200, 30000)  # jaw, lip, full blink, brow (10 mm), head yaw
    np.testing.assert_array_equal(shape_faps(values), values)


FAPU = Fapu(IRISD0=0.0092, ES0=0.062, ENS0=0.042, MNS0=0.027, MW0=0.052)  # about the sample head's


def _head_neutral():
    """A plausible closed-mouth neutral: only what the checks below look at needs to be right."""
    rng = np.random.default_rng(0)
    neutral = rng.uniform(-0.08, 0.08, size=(84, 3))
    for upper, lower in CLOSING_PAIRS:
        neutral[fp_index(upper)] = neutral[fp_index(lower)] + [0.0, 0.0, 0.0003]
    neutral[fp_index("3.1"), 2] = neutral[fp_index("3.3"), 2] + 0.009
    neutral[fp_index("3.2"), 2] = neutral[fp_index("3.4"), 2] + 0.009
    return neutral


@pytest.mark.skipif(not INTEROP.is_dir(), reason="the shared interop files are not beside this checkout")
@pytest.mark.parametrize("path", sorted(INTEROP.rglob("*.fap")), ids=lambda p: p.name)
def test_real_streams_stay_plausible(path):
    stream = read_fap(path)
    mask, values = apply_high_level(stream.mask, stream.values, stream.viseme, stream.expression)
    values = shape_faps(hold_missing(mask, values))
    assert np.all(values[:, FAP_GROUP >= 0] >= LOWER[FAP_GROUP >= 0])
    assert np.all(values[:, FAP_GROUP >= 0] <= UPPER[FAP_GROUP >= 0])
    values[:, 47:50] = 0.0  # the head turns rigidly: not a spike
    neutral = _head_neutral()
    points = fap_to_fp(neutral, values, FAPU)
    # no spike: no feature point leaves its rest position by more than 3.5 cm (a wide-open mouth's lower lip;
    # unlimited, jag.fap pulls the chin 3.3 cm back and Crystal's interpolation turns the pupils 6 rad)
    assert np.nanmax(np.linalg.norm(points - neutral, axis=2)) < 0.035
    for upper, lower in CLOSING_PAIRS:  # no crossing of lids or lips
        assert np.all(points[:, fp_index(upper), 2] >= points[:, fp_index(lower), 2] - 1e-12)


def test_the_jaw_protrudes_its_measured_range_and_retracts_a_few_millimetres():
    # a mandible protrudes about 8.5 mm at most (Hirsch et al. 2006: 8.2 +- 2.5 mm), thrust_jaw 480 MNS on the
    # sample head (MNS0 18.1 mm), ARKit's jawForward at 1: it passes unchanged (the symmetric 250 eased it to 232);
    # pulled back, the jaw still stops at a few millimetres, and the sideways shift keeps its limit
    values = np.zeros((2, 68))
    values[0, 13] = 480.0
    values[1, [13, 14]] = (-480.0, 480.0)
    out = shape_faps(values)
    assert out[0, 13] == 480.0
    assert -250.0 < out[1, 13] < -200.0 and 200.0 < out[1, 14] < 250.0


def test_knee_leaves_a_full_blink_alone():
    assert 1024 <= KNEE * UPPER[18]
