"""Training (what paper 004 left for later): least-squares gains and elastic weights w_i.

Given development units (the FP motion of a sculpted expression and the sculpted vertices), find the
parameters whose deformation is nearest the sculpted vertices in the least-squares sense
(Σ over units and vertices of ‖deformed − sculpted‖²), in two linear stages:
1. the gains of the translating bones, with the elastic layer off: every deformed vertex is affine in
   them (`pose.fp_transforms` keeps children linear), so this is one linear least-squares problem;
2. the elastic weights w_i with those gains fixed: eq. 4 is linear in w_i, so again linear.
(Gains and w_i together are not linear: the direction u of eq. 3 depends on the gains.)
Against overfitting the parameters are few and tied across the face's mid-line (a right bone or pair
shares its left partner's value), and bounded (gains in GAIN_BOUNDS, w_i in WEIGHT_BOUNDS, since w_i is
a weight); `scripts/bench/train_elastic.py` also reports leave-one-unit-out errors.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy.optimize import lsq_linear

from .parameters import Parameters, neighbour_pairs
from .pose import apply_elastic
from .skeleton import Skeleton
from .skinning import linear_blend_skinning

GAIN_BOUNDS = (0.0, 3.0)
WEIGHT_BOUNDS = (0.0, 2.0)

Unit = tuple[Any, np.ndarray]  # (what drives the engine: moved FPs or FAP values, (N, 3) sculpted vertices)
FirstPass = Callable[[Any, np.ndarray], np.ndarray]  # (drive, (B,) gains) -> (B, 4, 4) first-pass transforms


def affine_system(model: Callable[[np.ndarray], np.ndarray], n_params: int) -> tuple[np.ndarray, np.ndarray]:
    """(base, columns) with model(θ) = base + columns @ θ for a model affine in θ (read off at θ = 0 and
    at each unit vector, which is exact for an affine model)."""
    base = model(np.zeros(n_params))
    columns = np.stack([model(np.eye(n_params)[k]) - base for k in range(n_params)], axis=1)
    return base, columns


def solve_bounded(
    systems: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]], bounds: tuple[float, float]
) -> np.ndarray:
    """θ minimising Σ ‖base + columns @ θ − target‖² over the (base, columns, target) systems, within bounds."""
    a = np.concatenate([columns for _, columns, _ in systems])
    b = np.concatenate([target - base for base, _, target in systems])
    return lsq_linear(a, b, bounds=bounds).x


def _group(name: str, skeleton: Skeleton) -> str:
    """The left (or mid-line) bone a bone's parameter is tied to."""
    bone = skeleton.bones[skeleton.index(name)]
    return bone.mirror if bone.mirror and name.endswith("_r") else name


def gain_groups(skeleton: Skeleton) -> dict[str, list[str]]:
    """Trained gain -> the bones it scales: the translating bones that follow FPs, left and right tied."""
    groups: dict[str, list[str]] = {}
    for bone in skeleton.bones:
        if bone.kind == "translate" and bone.follow:
            groups.setdefault(_group(bone.name, skeleton), []).append(bone.name)
    return groups


def weight_groups(skeleton: Skeleton) -> dict[tuple[str, str], list[tuple[str, str]]]:
    """Trained w_i -> the (bone, neighbour) pairs it weighs, left and right tied."""
    groups: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for bone, neighbour in neighbour_pairs(skeleton.bones):
        key = (_group(bone, skeleton), _group(neighbour, skeleton))
        groups.setdefault(key, []).append((bone, neighbour))
    return groups


def train(
    skeleton: Skeleton,
    weights: np.ndarray,
    rest_vertices: np.ndarray,
    units: Sequence[Unit],
    first_pass: FirstPass,
    elastic: bool = True,
) -> Parameters:
    """Least-squares gains (stage 1) and, if `elastic`, elastic weights (stage 2) on the given units.

    `first_pass(drive, gains)` is the engine's rule transformation: e.g. FP motion through
    `pose.fp_transforms` or FAP values through `rules.fap_transforms`; it must be affine in the gains of
    the translating bones (both are)."""
    gains = gain_groups(skeleton)
    gain_keys = list(gains)

    def gain_params(theta):
        return Parameters({b: float(t) for key, t in zip(gain_keys, theta, strict=True) for b in gains[key]})

    def deform(transforms):
        return linear_blend_skinning(rest_vertices, weights, transforms).reshape(-1)

    systems = []
    for drive, sculpted in units:
        model = lambda theta, drive=drive: deform(first_pass(drive, gain_params(theta).gain_array(skeleton)))  # noqa: E731
        systems.append((*affine_system(model, len(gain_keys)), np.asarray(sculpted).reshape(-1)))
    trained_gains = gain_params(solve_bounded(systems, GAIN_BOUNDS))
    if not elastic:
        return trained_gains

    pairs = weight_groups(skeleton)
    pair_keys = list(pairs)
    rows, _ = trained_gains.pair_arrays(skeleton)
    names = neighbour_pairs(skeleton.bones)
    column = np.zeros((len(names), len(pair_keys)))
    for k, key in enumerate(pair_keys):
        for pair in pairs[key]:
            column[names.index(pair), k] = 1.0
    gain_array = trained_gains.gain_array(skeleton)
    systems = []
    for drive, sculpted in units:
        first = first_pass(drive, gain_array)
        model = lambda theta, first=first: deform(apply_elastic(skeleton, first, rows, column @ theta))  # noqa: E731
        systems.append((*affine_system(model, len(pair_keys)), np.asarray(sculpted).reshape(-1)))
    w = column @ solve_bounded(systems, WEIGHT_BOUNDS)
    return Parameters(trained_gains.gains, {pair: float(x) for pair, x in zip(names, w, strict=True)})
