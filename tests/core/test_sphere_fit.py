"""Least-squares sphere fit (eye pivots)."""

import numpy as np
import pytest

from addon.geometry.sphere_fit import SphereFitError, fit_sphere


def _sphere_points(centre, radius, n=200, seed=0, cap=None):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    if cap is not None:  # only the part of the sphere with z above cap (an eyeball seen from the front)
        d = d[d[:, 2] > cap]
    return np.asarray(centre) + radius * d


def test_exact_sphere_far_from_origin():
    centre = np.array([1000.0, -250.0, 3.5])
    pts = _sphere_points(centre, 0.012)
    c, r = fit_sphere(pts)
    assert np.allclose(c, centre, atol=1e-9)
    assert r == pytest.approx(0.012, rel=1e-9)


def test_cap_of_a_sphere_gives_its_centre_not_the_cap_mean():
    centre = np.array([0.03, -0.11, 0.03])
    pts = _sphere_points(centre, 0.0125, n=2000, cap=0.3)
    c, r = fit_sphere(pts)
    assert np.linalg.norm(c - centre) < 1e-9
    assert np.linalg.norm(pts.mean(axis=0) - centre) > 0.005  # the mean, like an off-centre origin, is wrong


def test_noisy_points_stay_close():
    centre = np.array([0.0, 0.0, 0.0])
    pts = _sphere_points(centre, 1.0, n=500, seed=3)
    pts += np.random.default_rng(4).normal(scale=0.01, size=pts.shape)
    c, r = fit_sphere(pts)
    assert np.linalg.norm(c) < 0.005
    assert abs(r - 1.0) < 0.005


@pytest.mark.parametrize(
    "pts",
    [
        np.zeros((3, 3)),
        np.zeros((10, 3)),
        np.array([[x, y, 0.0] for x in range(4) for y in range(4)], dtype=float),
        np.array([[np.nan, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]),
    ],
)
def test_degenerate_points_are_refused(pts):
    with pytest.raises(SphereFitError):
        fit_sphere(pts)
