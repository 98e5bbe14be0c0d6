"""The mouth lining's jaw share (`elastic.skinning.lining_jaw_share`), hand-worked."""

import numpy as np

from addon.elastic.skinning import LINING_SHARPNESS, falloff, lining_jaw_share


def test_the_lining_follows_the_nearer_lip_and_fades_from_the_lower_one():
    lining = np.array([1.0, 1.0, 1.0, 0.5, 0.0, 1.0, 1.0])
    upper = np.array([0.01, 0.03, 0.01, 0.01, 0.01, np.inf, np.inf])
    lower = np.array([0.01, 0.01, 0.03, 0.01, 0.01, 0.02, np.inf])
    share = lining_jaw_share(lining, upper, lower, jaw_radius=0.04)
    p = LINING_SHARPNESS
    near = (1.0 - (lower / 0.04) ** 2) ** 2
    expected = [
        0.5 * near[0],  # as near the upper lip as the lower: half
        3.0**p / (3.0**p + 1.0) * near[1],  # three times nearer the lower lip: 81/82 of it at p = 4
        1.0 / (1.0 + 3.0**p) * near[2],
        0.25 * near[3],  # where the lips meet, half a lining
        0.0,  # the outer skin keeps its leftover on the head
        near[5],  # only the lower lip reaches it (the upper lining cut away)
        0.0,  # neither: the head's
    ]
    np.testing.assert_allclose(share, expected, atol=1e-15)
    np.testing.assert_allclose(share[1], 81.0 / 82.0 * (1.0 - 1.0 / 16.0) ** 2)


def test_falloff():
    np.testing.assert_allclose(falloff(np.array([0.0, 0.5, 1.0, 2.0, np.inf]), 1.0), [1.0, 0.5625, 0.0, 0.0, 0.0])
