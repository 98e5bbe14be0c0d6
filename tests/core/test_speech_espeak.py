"""espeak-ng through ctypes: phonemes with times and audio from one synthesis, and the refusals. The tests that
synthesise skip, naming the reason, where libespeak-ng is not installed."""

import numpy as np
import pytest

from addon.mpeg4.faps import Viseme
from addon.speech import SpeechError, espeak
from addon.speech.coarticulation import fap_tracks
from addon.speech.espeak import EspeakMissingError, check_text, speech_segments, synthesize
from addon.speech.segments import TimedLabel


@pytest.fixture(scope="module")
def engine():
    try:
        return espeak._get_engine()
    except EspeakMissingError as exc:
        pytest.skip(f"libespeak-ng is not installed here: {exc}")


def bare(label):
    return label.lstrip("',%=!")


def rms(speech, start, end):
    part = speech.samples[int(start * speech.sample_rate) : int(end * speech.sample_rate)].astype(np.float64)
    return float(np.sqrt(np.mean(part**2))) if len(part) else 0.0


def test_hello_world_phonemes_come_in_time_order_and_end_with_the_audio(engine):
    speech = synthesize("hello world", "en")
    starts = np.array([p.start for p in speech.phonemes])
    ends = np.array([p.end for p in speech.phonemes])
    assert np.all(np.diff(starts) >= 0) and np.all(ends >= starts)
    np.testing.assert_array_equal(ends[:-1], starts[1:])  # each phoneme lasts until the next one starts
    assert ends[-1] == pytest.approx(len(speech.samples) / speech.sample_rate, abs=1e-12)
    assert starts[-1] <= speech.duration
    assert 0.4 < speech.duration < 2.0 and speech.sample_rate == engine.sample_rate
    names = [bare(p.label) for p in speech.phonemes]
    assert names[:8] == ["h", "@", "l", "oU", "w", "3:", "l", "d"]
    assert all(name.startswith("_") for name in names[8:])


def test_the_audio_is_loud_in_the_vowels_and_quiet_before_the_first_phoneme(engine):
    speech = synthesize("hello world", "en")
    vowel = next(p for p in speech.phonemes if bare(p.label) == "3:")
    assert rms(speech, vowel.start, vowel.end) > 500
    assert rms(speech, 0.0, speech.phonemes[0].start) < 0.05 * rms(speech, vowel.start, vowel.end)


def test_speech_becomes_segments_and_tracks_that_cover_the_audio(engine):
    speech = synthesize("Bob, map the moon.", "en-us")
    segments = speech_segments(speech)
    assert segments[0].start == 0.0 and segments[0].viseme == Viseme.NONE
    assert segments[-1].end == pytest.approx(speech.duration)
    assert sum(s.viseme == Viseme.PP for s in segments) == 5  # Bob: b b; map: m p; moon: m
    tracks = fap_tracks(segments, 25, duration=speech.duration)
    assert tracks.n_frames == int(np.ceil(speech.duration * 25 - 1e-9))
    gap = tracks.values[:, 2] - tracks.values[:, 3] - tracks.values[:, 4]
    for segment in (s for s in segments if s.viseme == Viseme.PP):
        frame = round(segment.centre * 25)
        assert gap[frame] <= 0, segment.label  # every bilabial closed on its nearest frame


def test_a_faster_rate_gives_shorter_speech(engine):
    slow = synthesize("The rain in Spain stays mainly in the plain.", rate=120)
    fast = synthesize("The rain in Spain stays mainly in the plain.", rate=300)
    assert fast.duration < 0.6 * slow.duration


def test_bad_voice_and_too_long_speech_are_refused(engine):
    with pytest.raises(SpeechError, match="espeak-ng has no voice 'xx-nonexistent'"):
        synthesize("hello", "xx-nonexistent")
    with pytest.raises(SpeechError, match="text too long: its speech runs past 0.5 s"):
        synthesize("This sentence takes clearly more than half a second to say.", max_seconds=0.5)
    assert synthesize("hello").duration > 0  # the engine still works afterwards


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "the text to speak is empty"),
        ("  \n\t ", "the text to speak is empty"),
        ("a\0b", "NUL character at position 2"),
        ("x" * 20_001, "text too long: 20001 characters, more than the 20000 allowed"),
        ("\ud800", "not text at position 1"),
    ],
)
def test_bad_text_is_refused_before_synthesis(text, message):
    with pytest.raises(SpeechError, match=message):
        check_text(text)
    with pytest.raises(SpeechError, match=message):
        synthesize(text)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"rate": 20}, "speaking rate 20"), ({"max_seconds": 0}, "length cap 0"), ({"voice": ""}, "voice ''")],
)
def test_bad_options_are_refused_before_synthesis(kwargs, message):
    with pytest.raises(SpeechError, match=message):
        synthesize("hello", **kwargs)


def test_a_missing_library_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(espeak, "_engine", None)
    monkeypatch.setattr(espeak, "find_library", lambda: ("/nonexistent/libespeak-ng.so.1", None))
    with pytest.raises(EspeakMissingError) as error:
        synthesize("hello")
    assert "pip install espeakng-loader==0.2.4" in str(error.value)
    assert "apt-get install libespeak-ng1" in str(error.value)
    assert isinstance(error.value, SpeechError)


def _take(pieces, rate=1000):
    """(N,) int16 samples: `pieces` of (seconds, amplitude) one after another."""
    return np.concatenate([np.full(int(round(s * rate)), a, dtype=np.int16) for s, a in pieces])


def test_a_stop_starts_where_its_closure_goes_quiet():
    # hand-worked: loud "a" to 0.30 s, 60 ms of silence (the closure), the /p/'s burst reported at 0.36 s
    samples = _take([(0.30, 8000), (0.06, 0), (0.24, 8000)])
    labels = [TimedLabel(0.0, 0.36, "a"), TimedLabel(0.36, 0.50, "p"), TimedLabel(0.50, 0.60, "a")]
    moved = espeak.stops_from_closure(labels, samples, 1000)
    assert [(round(x.start, 6), round(x.end, 6), x.label) for x in moved] == [
        (0.0, 0.30, "a"),
        (0.30, 0.50, "p"),
        (0.50, 0.60, "a"),
    ]


def test_a_closure_is_taken_back_no_further_than_max_closure_nor_into_the_phoneme_ahead():
    samples = _take([(0.10, 8000), (0.26, 0), (0.24, 8000)])  # 260 ms of silence before the burst at 0.36 s
    labels = [TimedLabel(0.0, 0.36, "a"), TimedLabel(0.36, 0.50, "'b"), TimedLabel(0.50, 0.60, "a")]
    moved = espeak.stops_from_closure(labels, samples, 1000)
    assert moved[1].start == pytest.approx(0.36 - espeak.MAX_CLOSURE) and moved[0].end == moved[1].start
    short = [TimedLabel(0.0, 0.05, "_"), TimedLabel(0.05, 0.36, "m"), TimedLabel(0.36, 0.5, "b")]
    kept = espeak.stops_from_closure(short, _take([(0.36, 0), (0.24, 8000)]), 1000)
    assert kept[0] == short[0] and kept[1].label == "m" and kept[1].start == 0.05  # no stop: as reported
    late = [TimedLabel(0.0, 0.30, "a"), TimedLabel(0.30, 0.34, "@"), TimedLabel(0.34, 0.5, "t")]
    taken = espeak.stops_from_closure(late, _take([(0.10, 8000), (0.40, 0)]), 1000)
    assert taken[2].start == pytest.approx(0.305) and taken[1].start == 0.30  # the phoneme ahead keeps 5 ms


def test_speak_text_closes_the_lips_before_the_burst_and_only_in_silence(engine):
    # voiceless stops after a vowel: their closure is silent (a voiced one hums through it and stays as reported)
    speech = synthesize("a map, a pip, a top", "en-us")
    reported = espeak.reported_labels(speech)
    keyed = espeak.phoneme_labels(speech)
    stops = [k for k, label in enumerate(reported) if bare(label.label) in espeak.STOPS and k > 0]
    assert len(stops) == 5
    for k in stops:
        assert keyed[k].start < reported[k].start - 0.01  # the closure's silence comes first
        assert rms(speech, keyed[k].start, reported[k].start) < 0.02 * rms(speech, 0.0, speech.duration) + 1
    assert [x.label for x in keyed] == [x.label for x in reported]
