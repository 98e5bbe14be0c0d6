"""Fit the generic face to a person's feature points: the FDP path of Escher et al. §3.1 in one call.

given FPs -> `complete_feature_points` (§3.1.1) -> `deform_dffd` with the generic face's cached Sibson
coordinates (§3.1) -> the fitted rest mesh. Everything is checked before anything is computed, and
nothing is changed in place.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from .dffd import DffdBinding, deform_dffd
from .missing_points import CompletedFeaturePoints, complete_feature_points


@dataclass(frozen=True)
class FeaturePointFit:
    vertices: np.ndarray  # (N, 3) the fitted face
    completion: CompletedFeaturePoints  # the full FP set it was fitted to, and how each FP was obtained


def fit_to_feature_points(
    binding: DffdBinding,
    generic_fps: Mapping[str, object],
    given_fps: Mapping[str, object],
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> FeaturePointFit:
    """The generic face (bound by `bind_dffd` with `generic_fps`) fitted to `given_fps` (some or all FPs)."""
    completion = complete_feature_points(generic_fps, given_fps, axes)
    return FeaturePointFit(deform_dffd(binding, completion.positions), completion)
