"""scripts/say.py end to end, through the bpy module in a subprocess: text -> .fap, .wav and phoneme times ->
Alembic and an MP4 whose video and audio last the sentence; bad arguments stop it with one line."""

import subprocess
import sys
import wave

import pytest

from addon.mpeg4.fap_file import read_fap
from tests.markers import needs_espeak

from .helpers import FACE, ROOT, cut_stream, run_convert

bpy = pytest.importorskip("bpy")

FPS = 25


def run_say(*args, timeout: int = 600) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "scripts.say", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, cwd=ROOT)


@needs_espeak
def test_hello_world_gives_the_files_and_an_mp4_whose_video_and_audio_last_the_sentence(tmp_path):
    from scripts.say import mp4_durations

    video = bpy.app.build_options.codec_ffmpeg
    result = run_say("Hello world", "--face", FACE, "-o", tmp_path, *([] if video else ["--no-video"]))
    assert result.returncode == 0, result.stdout + result.stderr
    for name in ("hello_world.fap", "hello_world.wav", "hello_world_phonemes.tsv", "hello_world.abc"):
        assert (tmp_path / name).is_file(), name
    stream = read_fap(tmp_path / "hello_world.fap")
    assert stream.fps == FPS and stream.mask[:, 2:].any(axis=1).all()
    with wave.open(str(tmp_path / "hello_world.wav"), "rb") as audio:
        rate = audio.getframerate()
        seconds = audio.getnframes() / rate
    assert 0.5 < seconds < 1.5
    assert abs(seconds - stream.n_frames / FPS) < 1 / rate  # padded to whole frames
    phonemes = (tmp_path / "hello_world_phonemes.tsv").read_text().split()
    assert "h" in phonemes and "'oU" in phonemes and "d" in phonemes
    if not video:
        pytest.skip("this bpy build has no FFmpeg output: the MP4 part is not checked")
    tracks = mp4_durations(tmp_path / "hello_world.mp4")
    assert set(tracks) == {"vide", "soun"}, tracks
    assert abs(tracks["vide"] - seconds) <= 1 / FPS and abs(tracks["soun"] - seconds) <= 1 / FPS, (tracks, seconds)
    assert f"video {tracks['vide']:.3f} s, audio {tracks['soun']:.3f} s" in result.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["   "], "the text to speak is empty"),
        (["Hi", "--expression", "glee:0.5"], "unknown expression 'glee' (known: joy, sadness, anger, fear, disgust, "),
        (["Hi", "--expression", "joy:2"], "argument --expression: 'joy:2' is not NAME:WEIGHT with a weight from 0"),
        (["Hi", "--fps", "0"], "argument --fps: '0' is not a frame rate from 1 to 240"),
        (["Hi", "--name", "../x"], "argument --name: '../x' is not a file name stem (letters, digits, _ . -)"),
    ],
)
def test_bad_arguments_stop_with_one_line_before_any_file_is_written(tmp_path, args, message):
    out = tmp_path / "out"
    result = run_say(*args, "--face", FACE, "-o", out)
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.startswith(f"say.py: error: {message}") and result.stderr.count("\n") == 1, result.stderr
    assert not out.exists() or not any(out.iterdir())


def test_a_missing_face_file_stops_the_run(tmp_path):
    result = run_say("Hi", "--face", tmp_path / "none.blend", "-o", tmp_path / "out")
    assert result.returncode == 2
    assert result.stderr == f"say.py: error: face file not found: {tmp_path / 'none.blend'}\n"


@needs_espeak
def test_an_unknown_voice_stops_the_run(tmp_path):
    result = run_say("Hi", "--voice", "xx-no-such-voice", "--face", FACE, "-o", tmp_path)
    assert result.returncode == 2
    assert result.stderr.startswith("say.py: error: espeak-ng has no voice 'xx-no-such-voice'")
    assert not any(tmp_path.iterdir())


def test_convert_takes_audio_for_one_stream_only(tmp_path):
    """say.py hands its WAV to convert.py as --audio; that option is checked with the others, before any work."""
    one, two = cut_stream(tmp_path / "one.fap"), cut_stream(tmp_path / "two.fap")
    audio = tmp_path / "one.wav"
    result = run_convert("--face", FACE, one, "-o", tmp_path / "out", "--audio", audio)
    assert result.returncode == 2 and result.stderr == f"convert.py: error: audio file not found: {audio}\n"
    audio.write_bytes(b"RIFF")
    result = run_convert("--face", FACE, one, two, "-o", tmp_path / "out", "--audio", audio)
    assert result.returncode == 2
    assert result.stderr == "convert.py: error: --audio is the sound of one stream, and 2 streams are given\n"
