"""convert.py and say.py on bad input (issue 30): a reason on the FAILED line or the error line, never a Python
exception's name, and say.py writes nothing before the face file has been opened and the face found."""

import subprocess
import sys

import pytest

from .helpers import DEMO_FAP, FACE, ROOT, run_convert

bpy = pytest.importorskip("bpy")


def run_say(*args) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "scripts.say", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT)


def test_convert_reports_a_stream_without_frames_as_a_reason(tmp_path):
    stream = tmp_path / "h.fap"
    stream.write_text("2.1 x 25 0\n")
    result = run_convert(stream, "-o", tmp_path / "out", "--face", FACE, "--no-video", "--sheet", "0")
    assert result.returncode == 1
    assert f"[1/1] {stream}: FAILED: the stream has no frames" in result.stdout, result.stdout + result.stderr


def test_convert_refuses_an_object_without_feature_points(tmp_path):
    result = run_convert(DEMO_FAP, "-o", tmp_path / "out", "--face", FACE, "--object", "Eye L", "--no-video")
    assert result.returncode == 2
    assert "convert.py: error: the mesh 'Eye L' has no feature points" in result.stderr, result.stderr
    assert "Error:" not in result.stdout.replace("convert.py: error:", "")


@pytest.mark.parametrize(
    ("face", "extra", "message"),
    [
        ("notes.txt", [], "cannot open the face file"),
        ("truncated.blend", [], "cannot open the face file"),
        (FACE, ["--object", "Eye L"], "the mesh 'Eye L' has no feature points"),
    ],
)
def test_say_checks_the_face_file_before_writing_anything(tmp_path, face, extra, message):
    (tmp_path / "notes.txt").write_text("not a face\n")
    (tmp_path / "truncated.blend").write_bytes(FACE.read_bytes()[:3000])
    out = tmp_path / "out"
    result = run_say("Hello world", "--face", tmp_path / face, "-o", out, *extra)
    assert result.returncode == 2, result.stdout + result.stderr
    assert f"say.py: error: {message}" in result.stderr, result.stderr
    assert not out.exists() or not any(out.iterdir())
