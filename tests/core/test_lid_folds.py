"""Lid weights made so that no face turns over (`eyelids.fold_free_weights`): a synthetic lid on a sphere patch
around an eye, with a hand-made-like weight step that folds faces when the lid turns."""

import numpy as np
import pytest

from addon.deform import eyelids, fused
from addon.deform.folds import inverted_faces

CENTRE = np.array([0.0, 0.0, 0.0])
RADIUS = 0.013  # the lid's skin, just over a 12 mm eyeball


def patch(columns: int = 25, rows: int = 31) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points on a sphere about the eye (face frame: x lateral, y up, z forward), their grid triangles, and the
    upper lid's weights: 1 up to elevation 0.35, 0 from one row above, times a sine arch along the eye."""
    lam, phi = np.meshgrid(np.linspace(-0.8, 0.8, columns), np.linspace(-0.5, 1.0, rows), indexing="ij")
    points = RADIUS * np.stack([np.sin(lam), np.cos(lam) * np.sin(phi), np.cos(lam) * np.cos(phi)], axis=-1)
    points = points.reshape(-1, 3) + CENTRE
    step = phi[0, 1] - phi[0, 0]
    weight = np.clip((0.35 + step - phi) / step, 0.0, 1.0) * np.where(phi > 0.1, 1.0, 0.0)
    weight = (weight * np.cos(lam * np.pi / 1.8) ** 2).reshape(-1)
    triangles = []
    for i in range(columns - 1):
        for j in range(rows - 1):
            a, b, c, d = rows * i + j, rows * (i + 1) + j, rows * (i + 1) + j + 1, rows * i + j + 1
            triangles += [[a, b, c], [a, c, d]]
    return points, np.array(triangles), weight


def turned(points: np.ndarray, weight: np.ndarray, theta: float) -> np.ndarray:
    """The points turned about the eye's x axis by theta times their weight (+ up), as apply_eyelids turns them."""
    angle = theta * weight
    d = points - CENTRE
    y = np.cos(angle) * d[:, 1] + np.sin(angle) * d[:, 2]
    z = np.cos(angle) * d[:, 2] - np.sin(angle) * d[:, 1]
    return np.stack([d[:, 0], y, z], axis=1) + CENTRE


RANGE = np.array([[[-0.8, 0.3], [-0.3, 0.8]]] * 2)  # [eye][upper, lower][least, most]


def made_fold_free(points, triangles, weight):
    vertices = np.arange(len(points))
    weights = np.stack([weight, np.zeros_like(weight)], axis=1)
    centres = np.array([CENTRE, CENTRE + [1.0, 0.0, 0.0]])
    eye = np.zeros(len(points), np.intp)
    fixed = np.stack([weight >= 0.99, np.zeros(len(points), bool)], axis=1)  # the lid: its weight stays
    return eyelids.fold_free_weights(points, vertices, eye, weights, fixed, centres, triangles, RANGE)


def test_the_steep_lid_folds_and_the_weights_made_fold_free_do_not(monkeypatch):
    monkeypatch.setattr(eyelids, "SWEEPS", 2000)  # until every face meets its limits (the bound checked below)
    monkeypatch.setattr(eyelids, "NUMPY_SWEEPS", 2000)
    points, triangles, weight = patch()
    assert inverted_faces(points, turned(points, weight, 0.3), triangles).any()  # the hand-made-like step folds
    closing, opening = (w[:, 0] for w in made_fold_free(points, triangles, weight))
    for theta in np.linspace(RANGE[0, 0, 0], RANGE[0, 0, 1], 23):
        made = opening if theta > 0 else closing
        assert not inverted_faces(points, turned(points, made, theta), triangles).any(), theta
    # every face keeps at least 1 - FOLD_SHARE of its normal (up to the tolerance) at both ends of the range
    d = points - CENTRE
    chart = np.stack([d[:, 0], np.hypot(d[:, 1], d[:, 2]), np.arctan2(d[:, 1], d[:, 2])], axis=1)
    for theta, made in zip(RANGE[0, 0], (closing, opening), strict=True):
        rate = (eyelids.lid_fold_rates(chart, triangles) * made[triangles]).sum(axis=1)
        assert (1.0 + theta * rate).min() >= 1.0 - eyelids.FOLD_SHARE - 1e-3 * abs(theta)
    # what must turn with a rising lid (the skin above it) need not follow it down in a blink
    above = chart[:, 2] > 0.45
    assert opening[above].max() > 0.3 and closing[above].max() == 0.0


def test_the_core_stays_and_nothing_leaves_zero_to_one():
    points, triangles, weight = patch()
    core = weight >= 0.99
    assert core.sum() >= 5
    for made in made_fold_free(points, triangles, weight):
        np.testing.assert_array_equal(made[core, 0], weight[core])
        np.testing.assert_array_equal(made[:, 1], 0.0)  # no lower lid here: nothing to move
        assert made.min() >= 0.0 and made.max() <= 1.0
    assert np.abs(made[:, 0] - weight).max() > 0.3  # the step was moved (for the rising lid)


def test_the_fold_rate_is_exact_for_a_turn():
    """1 + θ g · w is the share of each face's normal (chart metric) it keeps: checked against the turned face."""
    points, triangles, weight = patch(9, 11)
    d = points - CENTRE
    chart = np.stack([d[:, 0], np.hypot(d[:, 1], d[:, 2]), np.arctan2(d[:, 1], d[:, 2])], axis=1)
    rate = (eyelids.lid_fold_rates(chart, triangles) * weight[triangles]).sum(axis=1)
    for theta in (-0.7, 0.25):
        moved = chart.copy()
        moved[:, 2] += theta * weight
        q0, q1 = chart[triangles], moved[triangles]
        n0 = np.cross(q0[:, 1] - q0[:, 0], q0[:, 2] - q0[:, 0])
        n1 = np.cross(q1[:, 1] - q1[:, 0], q1[:, 2] - q1[:, 0])
        metric = np.stack([q0[:, :, 1].mean(1) ** 2] * 2 + [np.ones(len(triangles))], axis=1)
        share = (metric * n0 * n1).sum(1) / (metric * n0 * n0).sum(1)
        np.testing.assert_allclose(share, 1.0 + theta * rate, rtol=0.0, atol=1e-12)


@pytest.mark.skipif(not fused.available(), reason="no compiled kernel (python -m scripts.build_kernel)")
def test_the_kernel_sweeps_equal_the_numpy_sweeps(monkeypatch):
    """Bit for bit, for as many sweeps (the kernel passes over faces already within their limits; numpy does not)."""
    monkeypatch.setattr(eyelids, "NUMPY_SWEEPS", eyelids.SWEEPS)
    points, triangles, weight = patch()
    fast = made_fold_free(points, triangles, weight)
    monkeypatch.setenv(fused.DISABLE, "1")
    for a, b in zip(fast, made_fold_free(points, triangles, weight), strict=True):
        np.testing.assert_array_equal(a, b)


def test_faces_of_a_class_share_no_corner():
    points, triangles, _weight = patch()
    classes = eyelids.color_classes(triangles, len(points))
    assert sorted(np.concatenate(classes).tolist()) == list(range(len(triangles)))
    for members in classes:
        corners = triangles[members].ravel()
        assert len(np.unique(corners)) == len(corners)


def test_turns_stay_within_the_range_the_weights_are_made_for():
    rig = eyelids.EyelidRig(
        vertices=np.zeros(0, np.intp),
        eye=np.zeros(0, np.intp),
        upper=np.zeros(0),
        lower=np.zeros(0),
        local=np.zeros((0, 3)),
        centres=np.array([[0.032, 0.0, 0.0], [-0.032, 0.0, 0.0]]),
        rest_angles=np.array([[0.4, -0.35, 0.0]] * 2),
        axes=np.eye(3),
        turn_range=RANGE,
    )
    fps = np.full((84, 3), np.nan)
    for e, (upper, lower, _inner, _outer, pupil) in enumerate(eyelids.EYE_FPS):
        centre = rig.centres[e]
        for fp_id, angle in ((upper, 0.4 + 0.6), (lower, -0.35), (pupil, 0.0)):  # the upper lid raised 0.6
            fps[eyelids.fp_index(fp_id)] = centre + 0.012 * np.array([0.0, np.sin(angle), np.cos(angle)])
    turns = eyelids.lid_turns(rig, fps)
    np.testing.assert_allclose(turns[:, 0], 0.3)  # clipped at the range's top
