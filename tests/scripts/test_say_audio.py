"""scripts/say.py --audio end to end, through the bpy module in a subprocess: a recording and its transcript ->
.fap, the aligned phones (re-importable cues), the visemes and Alembic; bad recordings and arguments stop it
with one line before any file is written."""

import numpy as np
import pytest

from addon.mpeg4.fap_file import read_fap
from addon.speech import cue_files, espeak, wav
from tests.markers import needs_espeak

from .helpers import FACE
from .test_say import FPS, run_say

pytest.importorskip("bpy")
pytest.importorskip("pocketsphinx")

SENTENCE = "Maybe Bob bought a map."


def recording(folder):
    speech = espeak.synthesize(SENTENCE, "en-us")
    return wav.write_wav(folder / "line_01.wav", speech.samples, speech.sample_rate), speech


def closures(segments) -> int:
    """Runs of PP (adjacent bilabials make one closure)."""
    names = [s.viseme.name for s in segments]
    return sum(1 for k, name in enumerate(names) if name == "PP" and (k == 0 or names[k - 1] != "PP"))


@needs_espeak
def test_a_recording_with_its_transcript_gives_the_stream_the_phones_and_the_visemes(tmp_path):
    path, speech = recording(tmp_path)
    (tmp_path / "line.txt").write_text(SENTENCE)
    out = tmp_path / "out"
    result = run_say("--audio", path, "--transcript", tmp_path / "line.txt", "--face", FACE, "-o", out, "--no-video")
    assert result.returncode == 0, result.stdout + result.stderr
    for name in ("line_01.fap", "line_01_phonemes.tsv", "line_01_visemes.tsv", "line_01.abc"):
        assert (out / name).is_file(), name
    assert not (out / "line_01.wav").exists()  # the recording is the sound: nothing is re-encoded
    stream = read_fap(out / "line_01.fap")
    assert stream.fps == FPS and abs(stream.n_frames / FPS - speech.duration) <= 1 / FPS
    phones = cue_files.read_timed_labels(out / "line_01_phonemes.tsv")
    assert [p.label for p in phones if p.label != "sil"] == [p.label for p in speech.phonemes if p.label[0] != "_"]
    visemes = cue_files.read_cue_file(out / "line_01_visemes.tsv")
    assert closures(visemes) == closures(espeak.speech_segments(speech)) == 6  # m b b (b b) m p
    assert cue_files.read_cue_file(out / "line_01_phonemes.tsv")  # Import Lip-Sync Cues reads the phones too


@needs_espeak
@pytest.mark.parametrize(
    ("make", "args", "message"),
    [
        (lambda d: d / "none.wav", [], "audio file not found"),
        (lambda d: (d / "a.wav").write_text("hello") and d / "a.wav", [], "not a WAV file"),
        (lambda d: wav.write_wav(d / "a.wav", np.zeros(8000, np.int16), 16000), [], "is silent"),
        (lambda d: recording(d)[0], ["--text", "  "], "the transcript is empty"),
        (lambda d: recording(d)[0], ["--text", "Nothing like it at all, not one word"], "could not be aligned"),
        (lambda d: recording(d)[0], ["Hello"], "give either the TEXT to speak or --audio"),
    ],
)
def test_a_bad_recording_or_transcript_stops_before_any_file_is_written(tmp_path, make, args, message):
    out = tmp_path / "out"
    result = run_say("--audio", make(tmp_path), *args, "--face", FACE, "-o", out)
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.startswith("say.py: error: ") and message in result.stderr, result.stderr
    assert result.stderr.count("\n") == 1
    assert not out.exists() or not any(out.iterdir())


def test_a_transcript_without_a_recording_is_refused(tmp_path):
    result = run_say("--text", "Hi there", "--face", FACE, "-o", tmp_path)
    assert result.returncode == 2 and "give either the TEXT to speak or --audio" in result.stderr
