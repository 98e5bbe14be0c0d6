"""FAPU from a hand-made FP set with known distances."""

import numpy as np
import pytest

from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.fapu import AU, FapuError, compute_fapu


def blender(x, y, z):
    """MPEG-4 face-frame coordinates (x left, y up, z forward) -> Blender (Z up, facing -Y)."""
    return np.array([x, y, z]) @ BLENDER_FACE_AXES


HAND_MADE = {  # metres, face frame
    "3.5": (0.032, 0.040, 0.0),
    "3.6": (-0.032, 0.040, 0.0),  # ES0 = 64 mm
    "3.1": (0.032, 0.046, 0.01),
    "3.3": (0.032, 0.034, 0.01),  # 12 mm
    "3.2": (-0.032, 0.047, 0.01),
    "3.4": (-0.032, 0.033, 0.01),  # 14 mm -> IRISD0 = 13 mm
    "9.15": (0.0, -0.005, 0.02),  # ENS0 = 45 mm
    "2.2": (0.0, -0.035, 0.015),  # MNS0 = 30 mm
    "8.3": (0.026, -0.036, 0.01),
    "8.4": (-0.026, -0.036, 0.01),  # MW0 = 52 mm
}


def test_fapu_from_known_distances_in_blender_frame():
    fapu = compute_fapu({k: blender(*v) for k, v in HAND_MADE.items()})
    assert fapu.as_dict() == pytest.approx(
        {"IRISD0": 0.013, "ES0": 0.064, "ENS0": 0.045, "MNS0": 0.030, "MW0": 0.052}, abs=1e-12
    )
    assert fapu.unit("MNS") == pytest.approx(0.030 / 1024)
    assert fapu.unit("AU") == AU == 1e-5


def test_fapu_uses_one_eye_when_the_other_is_missing():
    pts = {k: blender(*v) for k, v in HAND_MADE.items() if k not in ("3.2", "3.4")}
    assert compute_fapu(pts).IRISD0 == pytest.approx(0.012)
    pts["3.1"] = np.array([np.nan, np.nan, np.nan])
    with pytest.raises(FapuError, match=r"IRISD0 needs .*missing 3\.1, 3\.2, 3\.4"):
        compute_fapu(pts)


def test_missing_fps_are_named():
    pts = {k: blender(*v) for k, v in HAND_MADE.items() if k not in ("9.15", "8.4")}
    with pytest.raises(FapuError) as err:
        compute_fapu(pts)
    msg = str(err.value)
    assert "ENS0" in msg and "MNS0" in msg and "MW0" in msg and "missing 9.15" in msg and "missing 8.4" in msg
    assert "ES0 needs" not in msg


def test_mirrored_face_gives_a_clear_error():
    pts = {k: blender(-v[0], v[1], v[2]) for k, v in HAND_MADE.items()}
    with pytest.raises(FapuError, match="ES0 = -0.064"):
        compute_fapu(pts)
