"""Phones from a voice recording (no bpy): WAV reading and resampling, every bad recording refused with a clear
message, the phone tables, forced alignment of an espeak-ng sentence against espeak-ng's own phoneme times,
recognition without a transcript, long takes cut at pauses, progress and cancelling."""

import importlib.util
import math
import os
import struct
import wave

import numpy as np
import pytest

from addon.mpeg4.faps import Viseme
from addon.speech import SpeechError, cue_files, espeak, phone_alignment, recording, tables
from addon.speech.recording import RATE, RecordingError
from tests.markers import needs_espeak

needs_pocketsphinx = pytest.mark.skipif(importlib.util.find_spec("pocketsphinx") is None, reason="no pocketsphinx")
SENTENCE = "Please pass me the apple pie."
STOPS = {"p", "b", "t", "d", "k", "g"}


def write_wav(path, frames: np.ndarray, rate: int, width: int) -> None:
    """(N, channels) integer samples as a PCM WAV of `width` bytes a sample (stdlib `wave`)."""
    frames = np.asarray(frames)
    if width == 1:
        data = (frames + 128).astype(np.uint8).tobytes()
    elif width == 3:
        value = frames.astype(np.int32).ravel()
        data = np.stack([value & 255, (value >> 8) & 255, (value >> 16) & 255], axis=1).astype(np.uint8).tobytes()
    else:
        data = frames.astype(f"<i{width}").tobytes()
    with wave.open(str(path), "wb") as out:
        out.setnchannels(frames.shape[1])
        out.setsampwidth(width)
        out.setframerate(rate)
        out.writeframes(data)


def sine(rate: int, seconds: float = 1.0, hz: float = 440.0, amplitude: float = 0.5) -> np.ndarray:
    return amplitude * np.sin(2 * np.pi * hz * np.arange(int(rate * seconds)) / rate)


def spectrum_peak(samples: np.ndarray, rate: int) -> float:
    window = samples * np.hanning(len(samples))
    return np.argmax(np.abs(np.fft.rfft(window))) * rate / len(samples)


# ----------------------------------------------------------------------------- reading WAV


@pytest.mark.parametrize(("width", "rate", "channels"), [(1, 8000, 1), (2, 44100, 2), (3, 48000, 1), (4, 22050, 2)])
def test_pcm_wav_of_any_width_rate_and_channels_reads_as_16_khz_mono(tmp_path, width, rate, channels):
    scale = 2 ** (8 * width - 1) - 1
    tone = sine(rate)
    frames = np.round(np.column_stack([tone] * channels) * scale)
    write_wav(tmp_path / "tone.wav", frames, rate, width)
    take = recording.read_recording(tmp_path / "tone.wav")
    assert take.samples.dtype == np.float32 and abs(take.duration - 1.0) < 1e-3
    middle = take.samples[2000:-2000]
    assert abs(spectrum_peak(middle, RATE) - 440.0) < 2.0
    assert abs(np.sqrt(np.mean(middle**2)) - 0.5 / math.sqrt(2)) < 0.005  # level kept by the filter


def test_float_and_extensible_wav_read_like_pcm(tmp_path):
    tone = sine(32000).astype("<f4")
    fmt = struct.pack("<HHIIHH", 3, 1, 32000, 32000 * 4, 4, 32)
    data = tone.tobytes()
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", len(data)) + data
    (tmp_path / "float.wav").write_bytes(b"RIFF" + struct.pack("<I", len(body)) + body)
    guid = struct.pack("<H", 1) + bytes(14)  # WAVE_FORMAT_EXTENSIBLE, sub-format PCM
    pcm = np.round(sine(16000) * 32767).astype("<i2").tobytes()
    fmt = struct.pack("<HHIIHHHHI", 0xFFFE, 1, 16000, 32000, 2, 16, 22, 16, 4) + guid
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", len(pcm)) + pcm
    (tmp_path / "ext.wav").write_bytes(b"RIFF" + struct.pack("<I", len(body)) + body)
    floats = recording.read_recording(tmp_path / "float.wav").samples
    extensible = recording.read_recording(tmp_path / "ext.wav").samples
    assert abs(spectrum_peak(floats[2000:-2000], RATE) - 440) < 2
    np.testing.assert_allclose(extensible, sine(16000), atol=1e-4)  # 16 kHz passes through unchanged


def test_resampling_keeps_a_tone_and_removes_what_16_khz_cannot_hold():
    rate = 48000
    kept = recording.resample(sine(rate, hz=1000), rate)[1000:-1000]
    removed = recording.resample(sine(rate, hz=11000), rate)[1000:-1000]  # above the new Nyquist, 8 kHz
    assert len(recording.resample(sine(rate), rate)) == RATE
    assert abs(np.sqrt(np.mean(kept**2)) - 0.5 / math.sqrt(2)) < 0.002
    assert np.sqrt(np.mean(removed**2)) < 1e-3  # no alias folded back below 8 kHz


def _recording_file(tmp_path, samples, rate=RATE):
    write_wav(tmp_path / "take.wav", np.asarray(samples).reshape(-1, 1), rate, 2)
    return tmp_path / "take.wav"


BAD_RECORDINGS = {
    "not audio": (lambda d: (d / "a.wav").write_text("hello, world") and d / "a.wav", "not a WAV file"),
    "header only": (lambda d: (d / "a.wav").write_bytes(b"RIFF\x04\x00\x00\x00WAVE") and d / "a.wav", "without"),
    "ADPCM": (lambda d: _adpcm(d), "WAV encoding 2 with 4-bit samples is not read here"),
    "empty": (lambda d: _recording_file(d, []), "holds no samples"),
    "silent": (lambda d: _recording_file(d, np.zeros(16000)), r"is silent \(its loudest sample is -inf dBFS\)"),
    "nearly silent": (lambda d: _recording_file(d, np.round(sine(RATE, amplitude=2e-4) * 32767)), "is silent"),
    "clipped": (lambda d: _recording_file(d, np.clip(sine(RATE, amplitude=3), -1, 1) * 32767), "is clipped"),
    "a folder": (lambda d: d, "not a regular file"),
    "missing": (lambda d: d / "none.wav", "cannot read the file"),
    "other format": (lambda d: _flac(d), "only WAV files are read outside Blender|not a sound"),
}


def _flac(folder):
    (folder / "a.flac").write_bytes(b"fLaC" + bytes(40))  # broken: Blender's decoder (where there is one) fails
    return folder / "a.flac"


def _adpcm(folder):
    fmt = struct.pack("<HHIIHH", 2, 1, 16000, 8000, 256, 4)
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt + b"data" + struct.pack("<I", 256) + bytes(256)
    (folder / "a.wav").write_bytes(b"RIFF" + struct.pack("<I", len(body)) + body)
    return folder / "a.wav"


@pytest.mark.parametrize("case", BAD_RECORDINGS)
def test_a_bad_recording_gets_a_clear_message(tmp_path, case):
    make, message = BAD_RECORDINGS[case]
    with pytest.raises(RecordingError, match=message) as caught:
        recording.read_recording(make(tmp_path))
    assert str(tmp_path) in str(caught.value)  # the message names the file


def test_a_recording_longer_than_the_cap_is_refused_before_it_is_decoded(tmp_path):
    path = _recording_file(tmp_path, np.round(sine(RATE, seconds=3) * 20000))
    with pytest.raises(RecordingError, match=r"lasts 3.0 s, longer than the 2 s allowed"):
        recording.read_recording(path, max_seconds=2)


# ----------------------------------------------------------------------------- tables


def test_every_phone_of_the_dictionary_has_a_viseme_and_shared_names_agree_with_espeak():
    pocketsphinx = pytest.importorskip("pocketsphinx")
    dictionary = os.path.join(pocketsphinx.get_model_path(), "en-us", "cmudict-en-us.dict")
    with open(dictionary, encoding="utf-8") as file:
        phones = {p.lower() for line in file for p in line.split()[1:]}
    cmu = tables.cmu_phones().visemes
    assert phones <= cmu.keys() and {"sil", "+nsn+", "+spn+"} <= cmu.keys()
    text = tables.load_phonemes().visemes
    assert {name: cmu[name] for name in cmu.keys() & text.keys()} == {
        name: text[name] for name in cmu.keys() & text.keys()
    }


def test_every_english_espeak_phoneme_maps_to_dictionary_phones():
    text = tables.load_phonemes().visemes
    mapping = phone_alignment.espeak_to_cmu()
    assert text.keys() <= mapping.keys()
    assert all(p in tables.cmu_phones().visemes for phones in mapping.values() for p in phones)


def test_r_coloured_vowels_of_us_english_bring_their_r_once():
    # espeak-ng's US English writes the r of "star", "where", "warm", "floor", "fire" inside the vowel; the
    # dictionary (what the acoustic model was trained on) writes it as a phone: S T AA R, W EH R, F AY ER
    of = phone_alignment.cmu_of_phonemes
    assert of(["s", "t", "'A@", "_:"]) == [("s",), ("t",), ("aa", "r"), ()]
    assert of(["w", "'e@"]) == [("w",), ("eh", "r")]
    assert of(["w", "'O@", "m"]) == [("w",), ("ao", "r"), ("m",)]
    assert of(["f", "l", "'o@"]) == [("f",), ("l",), ("ao", "r")]
    assert of(["f", "'aI3"]) == [("f",), ("ay", "er")]
    # where espeak-ng writes an r of its own after the vowel, the r is that phoneme's (never r r)
    assert of(["s", "t", "'o@", "r", "i"]) == [("s",), ("t",), ("ao",), ("r",), ("iy",)]
    assert of(["f", "'A@", "r-", "a#"]) == [("f",), ("aa",), ("r",), ("ah",)]
    # a pause between keeps both
    assert of(["w", "'e@", "_", "r"]) == [("w",), ("eh", "r"), (), ("r",)]
    with pytest.raises(KeyError):
        of(["s", "no-such-phoneme"])


def test_vowels_that_are_not_r_coloured_bring_no_r():
    of = phone_alignment.cmu_of_phonemes
    assert of(["s", "t", "'A@"], rhotic=False) == [("s",), ("t",), ("aa",)]
    assert of(["s", "t", "'A@", "r"], rhotic=False) == [("s",), ("t",), ("aa",), ("r",)]  # the Scottish voice's r


@needs_espeak
@needs_pocketsphinx
def test_the_transcript_is_aligned_in_the_accent_given():
    text = "Maybe Bob should show you the whole map."
    take, speech = _take(text, voice="en")
    said = [p.label for p in speech.phonemes if not p.label.startswith("_")]
    assert "@" in said  # British "the": D @ (US English: D @2)
    found = [p.label for p in phone_alignment.phones_from_recording(take, text, accent="en") if p.label != "sil"]
    assert found == said
    default = [p.label for p in phone_alignment.phones_from_recording(take, text) if p.label != "sil"]
    assert default != said and "@2" in default
    with pytest.raises(phone_alignment.AlignmentError, match="accent 'en-xx' is not one of en-us"):
        phone_alignment.phones_from_recording(take, text, accent="en-xx")


@needs_espeak
def test_a_missing_words_r_coloured_vowel_keeps_its_r():
    # the dictionary path labels a missing word's phones with their CMU names: without its r, "blarn" had no RR
    assert phone_alignment._pronunciation("blarnsworth").split()[:5] == ["B", "L", "AA", "R", "N"]
    assert phone_alignment._pronunciation("quorpy").split()[:4] == ["K", "W", "AO", "R"]


def test_cue_files_read_cmu_phones():
    from addon.speech.segments import TimedLabel, segments_from_labels

    labels = [TimedLabel(0.0, 0.1, "sil"), TimedLabel(0.1, 0.2, "dh"), TimedLabel(0.2, 0.3, "ay")]
    assert [s.viseme for s in segments_from_labels(labels)] == [Viseme.NONE, Viseme.TH, Viseme.AA, Viseme.IH]


# ----------------------------------------------------------------------------- alignment


def _take(text=SENTENCE, voice="en-us", lead=0.25):
    """espeak-ng's recording of `text` after `lead` s of silence (as a recording starts), and its phonemes."""
    speech = espeak.synthesize(text, voice)
    samples = np.concatenate([np.zeros(int(lead * speech.sample_rate), np.int16), speech.samples])
    return recording.from_samples(samples, speech.sample_rate), speech


@needs_espeak
@needs_pocketsphinx
def test_alignment_gives_espeaks_phonemes_in_order_within_30_ms():
    take, speech = _take()
    phones = [p for p in phone_alignment.phones_from_recording(take, SENTENCE) if p.label != "sil"]
    truth = [p for p in speech.phonemes if not p.label.startswith("_")]
    assert [p.label for p in phones] == [p.label for p in truth]
    assert all(a.end <= b.start + 1e-9 for a, b in zip(phones, phones[1:], strict=False))
    for phone, phoneme in zip(phones, truth, strict=True):
        error = phone.start - 0.25 - phoneme.start
        # espeak-ng reports a stop at its burst; the lips close at the closure before it, up to 80 ms earlier
        low = -0.08 if phoneme.label.lstrip("',") in STOPS else -0.03
        assert low <= error <= 0.03, (phoneme, error)
        assert phone.where.startswith("word ")


@needs_espeak
@needs_pocketsphinx
def test_the_phone_file_reimports_as_the_same_visemes(tmp_path):
    take, _ = _take()
    phones = phone_alignment.phones_from_recording(take, SENTENCE)
    cue_files.write_timed_labels(tmp_path / "take_phonemes.tsv", phones)
    again = cue_files.read_cue_file(tmp_path / "take_phonemes.tsv")
    assert [(s.start, s.viseme) for s in again] == [(s.start, s.viseme) for s in phone_alignment.phone_segments(phones)]


@needs_espeak
@needs_pocketsphinx
def test_words_missing_from_the_dictionary_are_pronounced_by_espeak():
    text = "Zorblax pumped the qwimble."
    take, speech = _take(text)
    phones = phone_alignment.phones_from_recording(take, text)
    assert {"word 'zorblax'", "word 'qwimble'"} <= {p.where.rsplit(" at ", 1)[0] for p in phones}
    assert sum(p.label in ("p", "b", "m") for p in phones) == sum(p.label in ("p", "b", "m") for p in speech.phonemes)


@needs_espeak
@needs_pocketsphinx
def test_recognition_without_transcript_finds_most_phones_and_the_closures():
    take, speech = _take("Maybe Bob bought a map.")
    phones = phone_alignment.phones_from_recording(take, None)
    assert all(p.where.startswith("recognised ") for p in phones[1:])
    assert phones[0].start == 0 and phones[-1].end <= take.duration
    assert all(a.end <= b.start + 1e-9 for a, b in zip(phones, phones[1:], strict=False))
    spoken = [p for p in phones if tables.cmu_phones().lookup(p.label) not in ((), (Viseme.NONE,))]
    assert len(spoken) >= 0.7 * len([p for p in speech.phonemes if not p.label.startswith("_")])
    bilabials = [p.start + 0.25 for p in speech.phonemes if p.label in ("p", "b", "m")]
    found = [p.start for p in phones if p.label in ("p", "b", "m")]
    hits = sum(any(abs(f - t) < 0.08 for f in found) for t in bilabials)
    assert hits >= len(bilabials) // 2


@needs_espeak
@needs_pocketsphinx
def test_recognised_words_are_aligned_and_the_phone_loops_closures_laid_over_them():
    take, _ = _take("Maybe Bob bought a map.")
    ranges, _ = phone_alignment.pieces(take.samples)
    words = phone_alignment.run(phone_alignment._word_steps(take, ranges, "STANDARD"))
    assert words and all(w == w.lower() and not w.startswith("<") for w in words)
    phones = phone_alignment.phones_from_recording(take, None, words=True)
    loop = phone_alignment.run(phone_alignment.phone_loop_steps(take))
    assert phone_alignment.phones_from_recording(take, None) == loop  # the default: the phone loop alone
    aligned = [p for p in phones if p.where.startswith("recognised word ")]
    assert aligned and any(p.label == "m" for p in aligned)  # "Maybe", "map": heard as words with an /m/
    assert {p.where.split("'")[1] for p in aligned} <= set(words)
    closures = [p for p in loop if p.label in ("p", "b", "m")]
    assert closures and all(c in phones for c in closures)  # every closure of the phone loop kept, as it was


@needs_espeak
@needs_pocketsphinx
def test_without_recognised_words_or_their_alignment_the_phone_loop_is_used(monkeypatch):
    take, _ = _take("Maybe Bob bought a map.")
    loop = phone_alignment.run(phone_alignment.phone_loop_steps(take))

    def no_words(recording, ranges, accuracy):
        return []
        yield

    monkeypatch.setattr(phone_alignment, "_word_steps", no_words)
    assert phone_alignment.phones_from_recording(take, None, words=True) == loop
    monkeypatch.undo()

    def refused(*args, **kwargs):
        raise phone_alignment.AlignmentError("the transcript could not be aligned")
        yield

    monkeypatch.setattr(phone_alignment, "alignment_steps", refused)
    assert phone_alignment.phones_from_recording(take, None, words=True) == loop
    monkeypatch.undo()

    # the extension's zip leaves the word language model out (scripts/slim_wheels.py)
    monkeypatch.setattr(phone_alignment, "WORD_LANGUAGE_MODEL", "not-installed.lm.bin")
    assert phone_alignment.phones_from_recording(take, None, words=True) == loop


def test_closures_laid_over_phones_cut_them_and_keep_the_rest():
    label = phone_alignment.TimedLabel
    phones = [label(0.0, 0.1, "sil"), label(0.1, 0.3, "a"), label(0.3, 0.5, "n"), label(0.5, 0.6, "sil")]
    closures = [label(0.05, 0.15, "m"), label(0.2, 0.25, "b"), label(0.45, 0.7, "p")]
    out = phone_alignment.with_closures(phones, closures)
    assert [(p.start, p.end, p.label) for p in out] == [
        (0.0, 0.05, "sil"),
        (0.05, 0.15, "m"),
        (0.15, 0.2, "a"),
        (0.2, 0.25, "b"),
        (0.25, 0.3, "a"),
        (0.3, 0.45, "n"),
        (0.45, 0.7, "p"),
    ]
    assert phone_alignment.with_closures(phones, []) == phones


def test_frames_become_seconds_at_each_tasks_frame_rate():
    # frame k's window [h k, h k + 410) samples has its centre 12.8125 ms after h k / 16 ms; a boundary before
    # frame k lies half-way between the centres of frames k - 1 and k: 7.8125 ms at 10 ms frames, 10.3125 at 5 ms
    assert phone_alignment._boundary_offset(100) == pytest.approx(0.0078125)
    assert phone_alignment._boundary_offset(200) == pytest.approx(0.0103125)
    (phone,) = phone_alignment._phones_of([("b", 100, 4, None)], 1.0, 200)
    assert (phone.start, phone.end) == pytest.approx((1.0 + 0.5 + 0.0103125 - 0.3, 1.0 + 0.52 + 0.0103125 - 0.3))
    (phone,) = phone_alignment._phones_of([("b", 100, 4, "bob")], 1.0, 100)
    assert (phone.start, phone.end) == pytest.approx((1.0 + 1.0 + 0.0078125 - 0.3, 1.0 + 1.04 + 0.0078125 - 0.3))
    assert phone.where == "word 'bob' at 1.71 s"


@needs_espeak
@needs_pocketsphinx
def test_recognition_resolves_phones_shorter_than_three_10_ms_frames(monkeypatch):
    # at 5 ms frames a three-state phone may last 15 ms: fluent speech has phones that short. Three sentences,
    # not one: espeak-ng's noise differs from one synthesis to the next (its random generator carries on between
    # calls and seeding it does not make the audio repeat), and one sentence's few short phones came and went.
    # The recogniser's own phones: the bilabial cues split murmurs off on a finer grid
    monkeypatch.setattr(phone_alignment, "bilabials_from_acoustics", lambda phones, samples: phones)
    take, _ = _take("Maybe Bob bought a map. Please pass me the apple pie. My mother made a bowl of plum jam.")
    phones = phone_alignment.run(phone_alignment.phone_loop_steps(take))
    inside = [p for p in phones[1:] if p.end < take.duration]  # the last ones are clipped to the take
    durations = np.array([p.end - p.start for p in inside])
    assert durations.min() >= 0.015 - 1e-9
    assert np.any(durations < 0.03 - 1e-9)
    starts = np.array([p.start for p in inside]) / 0.005  # on the 5 ms grid, 10.3125 ms after a frame start
    assert np.allclose(starts % 1, 0.0625, atol=1e-6)


@needs_espeak
@needs_pocketsphinx
def test_a_transcript_that_is_not_what_is_said_is_refused():
    take, _ = _take("Maybe Bob bought a map.")
    with pytest.raises(phone_alignment.AlignmentError, match="could not be aligned"):
        phone_alignment.phones_from_recording(take, "Completely different words spoken here by nobody at all today")
    with pytest.raises(phone_alignment.AlignmentError, match="no words"):
        phone_alignment.phones_from_recording(take, "!!! ...", vad_mode=2)
    with pytest.raises(phone_alignment.AlignmentError, match="more than anyone says"):
        phone_alignment.phones_from_recording(take, "word " * 200)


@needs_espeak
@needs_pocketsphinx
def test_a_long_take_is_cut_at_pauses_and_aligned_in_pieces(monkeypatch):
    monkeypatch.setattr(phone_alignment, "PIECE_SECONDS", 3.0)
    text = "Maybe Bob bought a map. Please pass me the apple pie. My mother made a bowl of plum jam."
    take, speech = _take(text)
    ranges, _ = phone_alignment.pieces(take.samples)
    assert len(ranges) >= 2 and ranges[0][0] == 0 and ranges[-1][1] == len(take.samples)
    phones = [p for p in phone_alignment.phones_from_recording(take, text) if p.label != "sil"]
    assert [p.label for p in phones] == [p.label for p in speech.phonemes if not p.label.startswith("_")]


@needs_espeak
@needs_pocketsphinx
def test_progress_rises_to_one_and_closing_the_steps_stops_the_work():
    take, _ = _take("Maybe Bob bought a map. Please pass me the apple pie.")
    fractions = []
    phone_alignment.phones_from_recording(take, None, progress=fractions.append)
    assert fractions == sorted(fractions) and 0 < fractions[0] and fractions[-1] == pytest.approx(1.0, abs=0.05)
    steps = phone_alignment.alignment_steps(take, "Maybe Bob bought a map. Please pass me the apple pie.")
    next(steps)
    steps.close()  # Esc: the decoder in use is dropped, the next run starts afresh
    assert phone_alignment.phones_from_recording(take, "Maybe Bob bought a map. Please pass me the apple pie.")


def test_missing_pocketsphinx_says_how_to_install_it(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def without_pocketsphinx(name, *args, **kwargs):
        if name == "pocketsphinx":
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", without_pocketsphinx)
    with pytest.raises(phone_alignment.PocketSphinxMissingError, match=r"pip install pocketsphinx==5\.1\.1"):
        phone_alignment.speech_frames(np.zeros(1600, np.float32))
    assert issubclass(phone_alignment.PocketSphinxMissingError, SpeechError)


@needs_espeak
@needs_pocketsphinx
def test_a_take_gives_the_same_phones_whatever_was_decoded_before():
    take, _ = _take("Maybe Bob bought a map.")
    other, _ = _take(SENTENCE, voice="en")
    for transcript in (None, "Maybe Bob bought a map."):
        first = phone_alignment.phones_from_recording(take, transcript)
        phone_alignment.phones_from_recording(other, transcript and SENTENCE)
        assert phone_alignment.phones_from_recording(take, transcript) == first


@needs_espeak
@needs_pocketsphinx
def test_the_cepstral_mean_pass_gives_the_mean_of_a_full_search_and_leaves_the_grammar_options():
    take, _ = _take()
    pcm = phone_alignment._pcm(take.samples)
    with phone_alignment._decoder("align", "STANDARD") as decoder:
        decoder.set_align_text("please pass me the apple pie")
        decoder.start_utt()
        decoder.process_raw(pcm, no_search=True, full_utt=False)
        decoder.end_utt()  # searches every frame under the sentence's grammar
        searched = decoder.get_cmn(True)
        decoder.reinit_feat()
        assert phone_alignment._piece_mean(decoder, pcm) == searched
        assert decoder.config["fsgusefiller"] is True
        assert decoder.current_search() == "_align"
