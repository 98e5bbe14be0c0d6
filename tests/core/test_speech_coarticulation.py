"""Cohen & Massaro co-articulation: a two-segment case worked by hand, bilabial closure at normal and fast
rates, rounding spreading into consonants, exactness against the plain formula, and the frame sampling."""

import math

import numpy as np
import pytest

from addon.mpeg4.fap_file import read_fap, write_fap
from addon.mpeg4.faps import Viseme
from addon.speech import SpeechError
from addon.speech.coarticulation import (
    CLOSURE_PAIRS,
    coarticulate,
    fap_tracks,
    frame_count,
    viseme_track,
)
from addon.speech.segments import Segment, TimedLabel, segments_from_labels
from addon.speech.tables import DominanceTable, ShapeTable, load_dominance, load_visemes

PROTRUSION = (16, 17)


def shapes(rows: dict) -> ShapeTable:
    targets = np.zeros((15, 68))
    for row, faps in rows.items():
        for number, value in faps.items():
            targets[row, number - 1] = value
    return ShapeTable(tuple(v.name for v in Viseme), targets, np.flatnonzero(targets.any(0)) + 1, ("",) * 15)


def dominance(alpha: dict, theta_before=10.0, theta_after=10.0, c=1.0) -> DominanceTable:
    a = np.ones((15, 68))
    for row, value in alpha.items():
        a[row] = value
    full = np.full((15, 68), 1.0)
    return DominanceTable(a, full * theta_before, full * theta_after, full * c, {}, ("",) * 15)


def gap(values, pair=(4, 5)):
    return values[..., 2] - values[..., pair[0] - 1] - values[..., pair[1] - 1]


def labels(*items):
    return segments_from_labels([TimedLabel(a, b, label) for a, b, label in items])


def test_two_segments_worked_by_hand():
    # AA on [0, 0.2] targets open_jaw 600 with alpha 1, E on [0.2, 0.4] targets 300 with alpha 2, theta 10/s, c 1
    table = shapes({Viseme.AA: {3: 600}, Viseme.E: {3: 300}})
    segments = [Segment(0.0, 0.2, Viseme.AA), Segment(0.2, 0.4, Viseme.E)]
    values = coarticulate(
        segments, np.array([0.2, 0.1, 0.3]), visemes=table, dominance=dominance({Viseme.AA: 1, Viseme.E: 2})
    )
    # t = 0.2: D_AA = e^-1 (0.1 s after its centre), D_E = 2 e^-1 -> (600 + 2 * 300) / 3 = 400
    assert values[0, 2] == pytest.approx(400.0, abs=1e-12)
    # t = 0.1 (AA's centre): D_AA = 1, D_E = 2 e^-2 = 0.2706706 -> (600 + 81.2012) / 1.2706706 = 536.0958
    assert values[1, 2] == pytest.approx((600 + 2 * math.exp(-2) * 300) / (1 + 2 * math.exp(-2)), abs=1e-12)
    assert values[1, 2] == pytest.approx(536.0958, abs=1e-4)
    # t = 0.3 (E's centre): D_AA = e^-2, D_E = 2 -> (600 e^-2 + 600) / (e^-2 + 2)
    assert values[2, 2] == pytest.approx((600 * math.exp(-2) + 600) / (math.exp(-2) + 2), abs=1e-12)
    assert not values[:, [n for n in range(68) if n != 2]].any()  # only the table's FAPs move


def test_anticipation_and_carry_over_rates_and_the_shape_exponent_apply_on_their_sides():
    table = shapes({Viseme.AA: {3: 600}})
    segments = [Segment(0.0, 0.2, Viseme.NONE), Segment(0.2, 0.4, Viseme.AA), Segment(0.4, 0.6, Viseme.NONE)]
    d = dominance({}, theta_before=5.0, theta_after=20.0, c=2.0)
    before, after = coarticulate(segments, np.array([0.25, 0.35]), visemes=table, dominance=d)[:, 2]
    # 0.05 s before AA's centre (0.3): D_AA = exp(-5 * 0.05^2); NONE [0, 0.2] is 0.15 s past its centre:
    # exp(-20 * 0.15^2); NONE [0.4, 0.6] is 0.25 s ahead of its centre: exp(-5 * 0.25^2).
    d_aa, d_1, d_2 = math.exp(-5 * 0.05**2), math.exp(-20 * 0.15**2), math.exp(-5 * 0.25**2)
    assert before == pytest.approx(600 * d_aa / (d_aa + d_1 + d_2), abs=1e-12)
    d_aa, d_1, d_2 = math.exp(-20 * 0.05**2), math.exp(-20 * 0.25**2), math.exp(-5 * 0.15**2)
    assert after == pytest.approx(600 * d_aa / (d_aa + d_1 + d_2), abs=1e-12)


def test_the_real_tables_match_the_plain_formula_away_from_bilabials():
    visemes, d = load_visemes(), load_dominance()
    rng = np.random.default_rng(3)
    kinds = [v for v in Viseme if v != Viseme.PP]
    lengths = rng.uniform(0.03, 0.25, 400)
    pauses = rng.uniform(0, 0.05, 400) * (rng.random(400) < 0.2)  # some gaps between segments
    ends = np.cumsum(lengths + pauses)
    kind = rng.integers(0, len(kinds), 400)
    segments = [Segment(e - w, e, kinds[k]) for e, w, k in zip(ends, lengths, kind, strict=True)]
    times = rng.uniform(0, ends[-1] + 1, 700)  # unsorted on purpose
    fast = coarticulate(segments, times)
    rows = np.array([int(s.viseme) for s in segments])
    tau = np.array([s.centre for s in segments])[:, None, None] - times[None, :, None]
    theta = np.where(tau >= 0, d.theta_before[rows][:, None], d.theta_after[rows][:, None])
    dom = d.alpha[rows][:, None] * np.exp(-theta * np.abs(tau) ** d.exponent[rows][:, None])
    plain = (dom * visemes.targets[rows][:, None]).sum(0) / dom.sum(0)
    np.testing.assert_allclose(fast, plain, rtol=0, atol=1e-9)


def test_a_weighted_average_stays_within_the_targets_and_one_segment_gives_its_target():
    visemes = load_visemes()
    segments = labels((0, 0.1, "s"), (0.1, 0.3, "aI"), (0.3, 0.35, "t"), (0.35, 0.5, "u:"))
    values = coarticulate(segments, np.linspace(-1, 2, 301))
    used = visemes.targets[[int(s.viseme) for s in segments]]
    assert np.all(values >= used.min(0) - 1e-9) and np.all(values <= used.max(0) + 1e-9)
    alone = coarticulate([Segment(1.0, 1.2, Viseme.OH)], np.array([0.0, 1.1, 50.0]))
    np.testing.assert_allclose(alone, np.tile(visemes.targets[Viseme.OH], (3, 1)), atol=1e-12)


def test_a_long_gap_underflows_no_dominance():
    segments = [Segment(0.0, 0.1, Viseme.AA), Segment(200.0, 200.1, Viseme.OU)]
    values = coarticulate(segments, np.array([0.05, 60.0, 100.05, 140.0, 200.05]))
    assert np.all(np.isfinite(values))
    visemes = load_visemes()
    np.testing.assert_allclose(values[0], visemes.targets[Viseme.AA], atol=1e-9)
    np.testing.assert_allclose(values[-1], visemes.targets[Viseme.OU], atol=1e-9)


@pytest.mark.parametrize("scale", [1.0, 0.5, 1 / 3], ids=["normal", "fast", "very fast"])
def test_apa_closes_the_lips_at_the_p_centre(scale):
    a, p = 0.15 * scale, 0.09 * scale  # normal: 150 ms vowels, a 90 ms /p/; very fast: a 30 ms /p/
    segments = labels((0, a, "a"), (a, a + p, "p"), (a + p, 2 * a + p, "a"))
    values = coarticulate(segments, np.array([s.centre for s in segments]))
    pp = load_visemes().targets[Viseme.PP]
    for pair in CLOSURE_PAIRS:
        closed = gap(values[1], pair[:2])
        assert closed <= 0
        assert closed == pytest.approx(pp[2] - pp[pair[0] - 1] - pp[pair[1] - 1], abs=1e-9)  # PP's own press
        assert gap(values[[0, 2]], pair[:2]).min() > 100  # the vowels stay open
    assert values[1, 2] > 100  # the jaw is not forced shut: the lips do the closing


def test_a_p_shorter_than_a_frame_still_shows_closed_on_a_frame():
    segments = labels((0, 0.05, "a"), (0.05, 0.075, "p"), (0.075, 0.125, "a"))  # /p/ 25 ms, frames 40 ms apart
    tracks = fap_tracks(segments, 25.0)
    assert gap(tracks.values).min() <= 0
    assert np.argmin(gap(tracks.values)) == round(segments[1].centre * 25)  # the frame nearest the centre


def test_closure_keeps_the_tracks_continuous():
    segments = labels((0, 0.1, "A:"), (0.1, 0.16, "m"), (0.16, 0.3, "A:"))
    times = np.arange(0.0, 0.3, 1e-5)
    values = coarticulate(segments, times)
    assert np.abs(np.diff(values, axis=0)).max() < 0.5  # FAPU per 10 us: no step at the closure's edges


def test_protrusion_spreads_into_the_consonants_of_stew_not_stee():
    stew = labels((0, 0.08, "s"), (0.08, 0.14, "t"), (0.14, 0.34, "u:"))
    stee = labels((0, 0.08, "s"), (0.08, 0.14, "t"), (0.14, 0.34, "i:"))
    centres = np.array([0.04, 0.11])
    rounded, spread = coarticulate(stew, centres), coarticulate(stee, centres)
    for number in PROTRUSION:
        assert np.all(rounded[:, number - 1] > spread[:, number - 1])
        assert rounded[1, number - 1] > 100  # the /t/ of "stew" is rounded (its own target is 0)
        assert spread[1, number - 1] < 0  # the /t/ of "stee" is spread
    assert rounded[1, 5] < 0 < spread[1, 5]  # and narrow versus wide (stretch_l_cornerlip)


def test_fap_tracks_sample_every_frame_and_write_a_stream(tmp_path):
    segments = labels((0, 0.12, "_"), (0.12, 0.2, "h"), (0.2, 0.3, "@"), (0.3, 0.41, "l"), (0.41, 0.6, "oU"))
    tracks = fap_tracks(segments, 25)
    assert tracks.n_frames == 15  # ceil(0.6 * 25)
    np.testing.assert_allclose(tracks.times[[0, -1]], [0.0, 14 / 25])
    np.testing.assert_allclose(tracks.values, coarticulate(segments, tracks.times, closure_fps=25), atol=0)
    fields = viseme_track(segments, tracks.times)
    assert fields[0].tolist() == [0, 0, 63, 0] and fields[-1].tolist() == [Viseme.OU, Viseme.OU, 63, 0]
    path = tmp_path / "speech.fap"
    write_fap(tracks.to_stream("hello", fields), path)
    back = read_fap(path)
    assert back.fps == 25 and back.n_frames == 15
    np.testing.assert_array_equal(np.flatnonzero(back.mask[0]) + 1, [1, *tracks.faps])
    np.testing.assert_allclose(back.values, np.where(back.mask, tracks.values, 0), rtol=1e-15)
    np.testing.assert_array_equal(back.viseme, fields)


def test_an_expression_layers_on_the_tracks():
    from addon.speech.high_level import expression_values

    tracks = fap_tracks(labels((0, 0.2, "a"), (0.2, 0.4, "p")), 25)
    joy = expression_values("joy", 0.5)
    layered = tracks.with_offsets(joy)
    np.testing.assert_allclose(layered.values, tracks.values + joy, atol=0)
    assert set(layered.faps) == set(tracks.faps) | set(np.flatnonzero(joy) + 1)
    assert 41 in layered.faps and layered.to_stream().mask[:, 40].all()  # lift_l_cheek is driven now


def test_the_frame_cap_is_checked_before_anything_is_allocated():
    assert frame_count(0.0, 25) == 1 and frame_count(1.0, 25) == 25 and frame_count(1.001, 25) == 26
    with pytest.raises(SpeechError, match=r"lasts 3600000.000 s, 90000000 frames at 25 fps, more than the 90000"):
        fap_tracks([Segment(3_599_999.9, 3_600_000.0, Viseme.AA)], 25)
    with pytest.raises(SpeechError, match="more than the 10 frames allowed"):
        fap_tracks(labels((0, 0.5, "a")), 25, max_frames=10)
    with pytest.raises(SpeechError, match="frame rate 0 is not a positive number"):
        fap_tracks(labels((0, 0.5, "a")), 0)


def test_bad_segments_are_refused_before_computing():
    with pytest.raises(SpeechError, match="no segments"):
        coarticulate([], np.zeros(3))
    with pytest.raises(SpeechError, match="'b' at 0.100 s: it overlaps 'a' at 0.000 s, which ends at 0.200 s"):
        coarticulate([Segment(0, 0.2, Viseme.AA, "a"), Segment(0.1, 0.3, Viseme.PP, "b")], np.zeros(1))
    with pytest.raises(SpeechError, match="finite seconds"):
        coarticulate(labels((0, 0.1, "a")), np.array([np.nan]))
