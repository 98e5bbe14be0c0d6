"""Elastic Bones on the lip units (issue 27): the mouth units that move the lips but not the jaw (every
`mouth-*` development unit but mouth-open) turn few faces over at their FP motion and at 1.5 times it, as
`scripts.bench.evaluate --method elastic_bones` drives the engine (shipped weights and trained parameters), the
skinning alone (Unfold Skin, which the add-on runs after it, opens them: `test_elastic_jaw_folds.py`).
Before step 5 of `elastic.skinning` (the lips' last smoothing) they turned 12 and 82 faces over (10 and 60 after;
6 and 58 with the jaw's share in step 5 and LINING_REACH 0.75)."""

import numpy as np
import pytest

from addon.deform.folds import count_inverted
from scripts.bench import evaluate
from scripts.bench.elastic_bones import ElasticBonesMethod

from .helpers import makehuman_units

bpy = pytest.importorskip("bpy")


def test_the_lip_units_turn_few_faces_over():
    folder = makehuman_units()
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    method = ElasticBonesMethod(face, unfold_skin=False)  # the weights' own folds (the add-on then opens them)
    folds = {1.0: 0, 1.5: 0}
    names = {evaluate.target_name(p): p for p in evaluate.target_files(folder)}
    units = [p for name, p in names.items() if name.startswith("mouth-") and name != "mouth-open"]
    for path in units:
        _offsets, fp_offsets = evaluate.target_motion(path, face)
        for scale in folds:
            deformed = method.evaluate(face.control_rest + scale * fp_offsets)
            folds[scale] += count_inverted(face.rest, deformed, *face.fans)
    assert len(units) == 12
    assert folds[1.0] <= 6  # 12 before step 5, 10 with the lips alone in it
    assert folds[1.5] <= 58  # 82 before step 5, 60 with the lips alone in it
    assert np.isfinite(method.weights).all()
