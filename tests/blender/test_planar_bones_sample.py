"""Planar Bones on the sample head, bound as the add-on binds it (`face_binding.bind_face`).

Left-right symmetry: the head's mesh and FPs are mirror images, so a FAP frame and its mirror image (left
and right FAPs swapped) must deform it into mirror images. Inner lips: the skin just inside the mouth
opening follows the inner-lip FPs instead of fading toward rest. Folds: the project's own mouth shapes and
expressions turn no face of the head over."""

from pathlib import Path

import numpy as np
import pytest

from addon.blender.face_data import mesh_fans
from addon.deform.folds import count_inverted
from addon.deform.planar_bones import evaluate
from addon.mpeg4.decode import fap_to_fp, hold_missing
from addon.mpeg4.fap_file import read_fap
from addon.mpeg4.fap_groups import shape_faps
from addon.mpeg4.faps import LEFT_RIGHT_PAIRS, N_FAPS
from addon.mpeg4.feature_points import fp_index, mirror_index
from addon.speech.high_level import apply_high_level
from addon.speech.tables import load_expressions, load_visemes

from .helpers import DEMO_FAP, bound_sample

FLIP = np.array([-1.0, 1.0, 1.0])  # the head's mid-line is x = 0
TOLERANCE = 5e-5  # 0.05 mm
# one-sided motions of every region, some beyond the standard's usual range (in FAP units)
FRAMES = {
    "left smile": {12: 400, 6: 250, 59: 300, 53: 250, 41: 200},
    "left brow": {31: 300, 33: 350, 35: 300, 37: 150},
    "left pout and jaw": {3: 300, 16: 300, 17: 250, 4: -100, 8: 150, 10: -120},
    "left wink": {19: 600, 21: 300},
}


def fap_frame(values: dict[int, float]) -> np.ndarray:
    frame = np.zeros(N_FAPS)
    for number, value in values.items():
        frame[number - 1] = value
    return frame


def mirrored(values: np.ndarray) -> np.ndarray:
    out = values.copy()
    for left, right in LEFT_RIGHT_PAIRS:
        out[left - 1], out[right - 1] = values[right - 1], values[left - 1]
    return out


@pytest.fixture(scope="module")
def sample():
    bound = bound_sample()
    head, rest, neutral, fapu = bound.head, bound.rest, bound.neutral, bound.fapu
    rows, binding = bound.rows, bound.binding
    mirror_vertex = np.array([np.argmin(np.linalg.norm(rest - v * FLIP, axis=1)) for v in rest])
    fans = mesh_fans(head.data)
    return rest, neutral, fapu, rows, binding, mirror_vertex, fans


def test_the_sample_head_is_its_own_mirror_image(sample):
    rest, neutral, _, _, _, mirror_vertex, _ = sample
    np.testing.assert_allclose(rest[mirror_vertex] * FLIP, rest, atol=1e-6)
    np.testing.assert_allclose(neutral[mirror_index()] * FLIP, neutral, atol=1e-6)


@pytest.mark.parametrize("name", FRAMES)
def test_a_mirrored_fap_frame_deforms_the_head_into_the_mirror_image(sample, name):
    rest, neutral, fapu, rows, binding, mirror_vertex, _ = sample
    values = fap_frame(FRAMES[name])
    deformed = {}
    for side, frame in (("as given", values), ("mirrored", mirrored(values))):
        points = fap_to_fp(neutral, frame[None], fapu)[0]
        deformed[side] = evaluate(binding, points[rows])
    moved = np.linalg.norm(deformed["as given"] - rest, axis=1).max()
    assert moved > 2e-3  # the frame moves the face by millimetres
    error = np.linalg.norm(deformed["mirrored"] - deformed["as given"][mirror_vertex] * FLIP, axis=1)
    assert error.max() < TOLERANCE


def test_inner_lips_follow_their_fps_in_a_pout(sample):
    rest, neutral, fapu, rows, binding, _, _ = sample
    points = fap_to_fp(neutral, fap_frame({16: 300, 17: 300})[None], fapu)[0]  # push_b_lip, push_t_lip
    deformed = evaluate(binding, points[rows])
    for fp_id in ("2.2", "2.3"):
        k = fp_index(fp_id)
        motion = points[k] - neutral[k]
        near = np.linalg.norm(rest - neutral[k], axis=1) < 4e-3  # both lips' skin at the inner-lip FP
        share = (deformed[near] - rest[near]) @ motion / (motion @ motion)
        # measured 0.64 / 0.77 on average and at least 0.31; 0.44 / 0.54 and 0.00 while the opening's rim
        # counted as the edge of the face and the skin inside it faded toward rest
        assert share.mean() > 0.6 and share.min() > 0.25, (fp_id, share)


def test_no_viseme_with_any_expression_turns_a_face_over(sample):
    rest, neutral, fapu, rows, binding, _, fans = sample
    visemes, expressions = load_visemes(), load_expressions()
    frames = np.array(
        [v + k * x for v in visemes.targets for x in expressions.targets for k in (0.5, 1.0)]  # expressions add
    )
    frames[:, 47:50] = 0.0  # head rotation turns the whole object
    points = fap_to_fp(neutral, frames, fapu)
    folded = [count_inverted(rest, evaluate(binding, frame[rows]), *fans) for frame in points]
    assert max(folded) == 0


INTEROP = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap"
STREAMS = [DEMO_FAP, *sorted(INTEROP.rglob("*.fap"))] if INTEROP.is_dir() else [DEMO_FAP]


@pytest.mark.parametrize("path", STREAMS, ids=lambda p: p.name)
def test_streams_decoded_as_imported_turn_no_face_over(sample, path):
    """The import's defaults (group gains 1, plausible ranges) keep every real stream fold-free (issue 13)."""
    rest, neutral, fapu, rows, binding, _, fans = sample
    stream = read_fap(path)
    mask, values = apply_high_level(stream.mask, stream.values, stream.viseme, stream.expression)
    values = shape_faps(hold_missing(mask, values))
    values[:, 47:50] = 0.0  # head rotation turns the whole object
    points = fap_to_fp(neutral, values, fapu)
    folded = [count_inverted(rest, evaluate(binding, frame[rows]), *fans) for frame in points]
    assert max(folded) == 0
