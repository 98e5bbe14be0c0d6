"""The global part of the feature points' motion: the affine map most of them follow, found robustly.

What moves the DFFD's auxiliary sites (`dffd`) and the missing FPs no cylinder sees (`missing_points`). A
least-squares fit lets a local motion leak everywhere: a chin pushed forward 12 mm by its 4 FPs tilts the
least-squares map of all 84 FPs, which drags the auxiliary sites (and with them the neck, scalp and back of
the head) by up to 3.9 mm (chin-prominent-incr in `scripts/bench/evaluate_fitting.py`). Tukey's biweight, by
iteratively reweighted least squares from the least-squares fit, gives FPs that the map does not explain no
weight: a local motion leaves the identity (the chin's sites stay exactly in place), a whole-face change
(scale, shear) its affine map. An exactly affine motion is fitted exactly (the least-squares fit, where every
residual vanishes), so DFFD keeps reproducing it. Weights that leave fewer than 4 FPs in general position
end the iteration where it stands.
"""

import numpy as np

TUKEY_C = 4.685  # the biweight's cut-off in robust standard deviations (95 % efficiency on Gaussian noise)
MAD_SCALE = 1.4826  # median absolute residual -> robust standard deviation (the 1-D factor, on residual lengths)
EXACT_FRACTION = 1e-12  # residuals below this fraction of the FPs' extent count as zero
MAX_ITERATIONS = 50


def robust_affine_fit(rest: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """(4, 3) A: [x, 1] @ A is the displacement at x of the robust affine fit of (n, 3) FPs' `motion` from `rest`.

    No motion gives exactly zero.
    """
    homogeneous = np.column_stack([rest, np.ones(len(rest))])
    fit, *_ = np.linalg.lstsq(homogeneous, motion, rcond=None)
    tolerance = EXACT_FRACTION * float(np.linalg.norm(np.ptp(rest, axis=0)))
    for _ in range(MAX_ITERATIONS):
        residual = np.linalg.norm(homogeneous @ fit - motion, axis=1)
        scale = MAD_SCALE * float(np.median(residual))
        if scale <= tolerance:  # at least half the FPs follow the fit exactly: the rest are outliers
            break
        u = residual / (TUKEY_C * scale)
        root = np.where(u < 1.0, 1.0 - u**2, 0.0)[:, None]  # square root of the biweight (1 - u^2)^2
        refit, _, rank, _ = np.linalg.lstsq(homogeneous * root, motion * root, rcond=None)
        if rank < 4:  # the FPs left with weight cannot fix an affine map
            break
        change = float(np.max(np.abs(homogeneous @ (refit - fit))))
        fit = refit
        if change <= tolerance:
            break
    return fit
