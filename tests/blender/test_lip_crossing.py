"""The lips never pass through each other on the sample head, bound as the add-on binds it, over the
project's mouth shapes and expressions and a fixed seeded set of random lip-FAP frames within range
(`scripts/bench/lip_crossing.py` plays more)."""

import bpy
import numpy as np
import pytest

from addon.blender.face_data import mesh_fans
from addon.deform.lips import bind_lip_guard, guard_lips, lip_penetration, mouth_sides
from addon.deform.planar_bones import evaluate
from addon.mpeg4.decode import fap_to_fp
from addon.mpeg4.feature_points import fp_index
from scripts.bench.lip_crossing import random_frames, viseme_expression_frames

from .helpers import bound_sample, positions

CROSSING = 1e-5  # 0.01 mm


@pytest.fixture(scope="module")
def sample():
    bound = bound_sample()
    head, rest, neutral, fapu, ids, rows, masks = (
        bound.head, bound.rest, bound.neutral, bound.fapu, bound.ids, bound.rows, bound.masks
    )  # fmt: skip
    binding = bound.binding
    triangles = mesh_fans(head.data)[0]
    upper, lower = mouth_sides(rest, masks["upper_lip"], masks["lower_lip"], neutral, triangles=triangles)
    guard = bind_lip_guard(rest, neutral[rows], ids, triangles, upper, lower)
    return rest, neutral, fapu, rows, binding, triangles, upper, lower, guard


def worst_depth(sample, frames: np.ndarray, guarded: bool) -> float:
    rest, neutral, fapu, rows, binding, triangles, upper, lower, guard = sample
    worst = -np.inf
    for points in fap_to_fp(neutral, frames, fapu)[:, rows]:
        deformed = evaluate(binding, points)
        if guarded:
            guard_lips(guard, deformed, points)
        into_lower, into_upper = lip_penetration(deformed, triangles, upper, lower)
        worst = max(worst, np.nanmax(into_lower), np.nanmax(into_upper))
    return worst


def test_the_guard_leaves_the_neutral_face_alone(sample):
    rest, neutral, _, rows, _, _, upper, lower, guard = sample
    out = rest.copy()
    guard_lips(guard, out, neutral[rows])
    np.testing.assert_array_equal(out, rest)
    assert upper.sum() > 100 and lower.sum() > 60  # the mouth box holds both lips


def test_visemes_with_expressions_never_cross_the_lips(sample):
    frames = viseme_expression_frames()
    # measured: 0.25 mm without the guard (OU with anger, pressed lips pushed forward)
    assert worst_depth(sample, frames, guarded=False) > 0.1e-3
    assert worst_depth(sample, frames, guarded=True) < CROSSING


def test_random_lip_faps_within_range_never_cross_the_lips(sample):
    frames = random_frames(200, seed=0)
    # measured: 2.7 mm without the guard (decode keeps the lips' FPs in order; their skin still crosses)
    assert worst_depth(sample, frames, guarded=False) > 1e-3
    assert worst_depth(sample, frames, guarded=True) < CROSSING


def test_the_live_face_keeps_its_lips_apart_and_the_setting_turns_it_off(sample):
    from addon.blender import face_data

    from .helpers import set_up_sample

    _, neutral, fapu, rows, _, triangles, upper, lower, _ = sample
    frames = random_frames(200, seed=0)
    worst = int(np.argmax([worst_depth(sample, frames[k : k + 1], guarded=False) for k in range(len(frames))]))
    head = set_up_sample()
    head.mpeg4_face.enabled = True
    points = fap_to_fp(neutral, frames[worst : worst + 1], fapu)[0]
    for fp_id, ob in face_data.fp_empties(head).items():
        ob.location = points[fp_index(fp_id)]
    bpy.context.view_layer.update()

    def depth() -> float:
        into_lower, into_upper = lip_penetration(positions(head.data), triangles, upper, lower)
        return max(np.nanmax(into_lower), np.nanmax(into_upper))

    assert depth() < CROSSING
    head.mpeg4_face.keep_lips_apart = False
    assert depth() > 1e-3
    head.mpeg4_face.keep_lips_apart = True
    assert depth() < CROSSING
