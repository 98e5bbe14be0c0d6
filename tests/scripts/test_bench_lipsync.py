"""The lip-sync benchmark's scores (scripts/bench/bench_lipsync.py), worked by hand."""

import numpy as np
import pytest

from addon.mpeg4.faps import Viseme
from addon.speech.segments import Segment
from scripts.bench.bench_lipsync import (
    boundary_frames,
    confusion,
    confusion_table,
    disagreement_line,
    score,
    summary_of,
)


def _segments(*runs):
    return [Segment(a, b, v) for a, b, v in runs]


# truth: 50 ms silence, 100 ms closure, 150 ms open vowel; found: the closure 20 ms late and heard as OU at first
TRUTH = _segments((0.0, 0.05, Viseme.NONE), (0.05, 0.15, Viseme.PP), (0.15, 0.30, Viseme.AA))
FOUND = _segments((0.0, 0.05, Viseme.NONE), (0.05, 0.07, Viseme.OU), (0.07, 0.17, Viseme.PP), (0.17, 0.30, Viseme.AA))


def test_score_counts_frames_closures_onsets_and_confusions():
    s = score(TRUTH, FOUND, 0.30)
    assert s["frames"] == 30
    assert s["agree"] == 5 + 8 + 13  # the OU frames and the late closure's two AA frames disagree
    assert (s["speech_frames"], s["speech_agree"]) == (25, 21)
    assert (s["closures"], s["closures_found"], s["found_closures"], s["found_closures_true"]) == (1, 1, 1, 1)
    assert s["onsets_ms"] == pytest.approx([20.0, 20.0])  # PP and AA both start 20 ms late
    counts = np.array(s["confusion"])
    assert counts.sum() == 30
    assert counts[Viseme.PP, Viseme.PP] == 8 and counts[Viseme.PP, Viseme.OU] == 2
    assert counts[Viseme.AA, Viseme.PP] == 2 and counts[Viseme.AA, Viseme.AA] == 13
    assert np.trace(counts) == s["agree"]


def test_summary_adds_confusions_and_the_table_gives_each_rows_share():
    s = score(TRUTH, FOUND, 0.30)
    pooled = summary_of([s, s])
    assert np.array_equal(pooled["confusion"], 2 * np.array(s["confusion"]))
    assert pooled["agreement"] == pytest.approx(26 / 30)
    lines = confusion_table(pooled["confusion"]).splitlines()
    assert len(lines) == 1 + len(Viseme)
    assert lines[1 + Viseme.PP].split()[-2:] == ["20", "80.0%"]  # 8 of 10 closure frames, twice
    assert lines[1 + Viseme.OU].split()[-1] == "-"  # no truth frames


def test_confusion_of_frame_tracks():
    counts = confusion(np.array([0, 1, 1, 10]), np.array([0, 1, 14, 10]))
    assert counts.shape == (15, 15)
    assert counts[1, 14] == 1 and np.trace(counts) == 3


def test_disagreements_at_a_boundary_are_told_from_wrong_visemes():
    # the late closure: its 2 OU frames and 2 PP frames each have the truth's viseme within 40 ms
    s = score(TRUTH, FOUND, 0.30)
    assert s["boundary_frames"] == 4
    # 20 frames of AA heard as E, then an NN found 50 ms late (the AA held on): of the 25 frames that disagree
    # the last 4 E frames have the found AA within 4 frames, and so have the NN frames 21..24 the found NN
    # (frame 20 is 5 frames from it)
    truth = np.array([Viseme.AA] * 20 + [Viseme.NN] * 10)
    found = np.array([Viseme.E] * 20 + [Viseme.AA] * 5 + [Viseme.NN] * 5)
    assert boundary_frames(truth, found) == 4 + 4
    pooled = summary_of([s, s])
    assert pooled["boundary_frames"] == 8
    assert disagreement_line(pooled) == "8 of 60 frames disagree, 8 of them within 40 ms of a boundary"
