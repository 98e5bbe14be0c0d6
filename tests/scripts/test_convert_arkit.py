"""scripts/convert.py with the ARKit bridge: a capture converts like a .fap (and is written as one), --arkit-csv
writes a stream as ARKit weights with its round trip's error, --arkit-glb the face with 52 morph targets."""

import json
import re
import struct

import pytest

from addon.arkit.captures import read_capture
from addon.arkit.recipes import ARKIT_NAMES
from addon.mpeg4.fap_file import read_fap

from .helpers import FACE, cut_stream, run_convert

pytest.importorskip("bpy")


def _glb_json(path) -> dict:
    data = path.read_bytes()
    (length,) = struct.unpack("<I", data[12:16])
    return json.loads(data[20 : 20 + length])


def test_a_capture_converts_and_a_stream_goes_out_as_arkit_weights(tmp_path):
    capture = tmp_path / "take.csv"
    rows = ["time,jawOpen,eyeBlinkLeft"] + [f"{k / 30:.6f},{k / 7:.4f},{(k % 2) * 0.5}" for k in range(8)]
    capture.write_text("\n".join(rows) + "\n")
    short = cut_stream(tmp_path / "short.fap")
    out = tmp_path / "out"
    args = ("--face", FACE, capture, short, "-o", out, "--arkit-csv", "--arkit-glb", "--no-video", "--sheet", "0")
    result = run_convert(*args)
    assert result.returncode == 0, result.stdout + result.stderr
    stream = read_fap(out / "take.fap")
    assert stream.fps == 30.0 and stream.n_frames == 8
    assert stream.values[7, 2] == 1220  # jawOpen 1 -> open_jaw 1220
    assert (out / "take.abc").exists() and (out / "short.abc").exists()
    back = read_capture(out / "short_arkit.csv", timecode_fps=25)
    assert back.n_frames == read_fap(short).n_frames and back.weights.max() <= 1.0
    error = re.search(r"short.fap: ok .*mean FP error ([0-9.]+) mm", result.stdout)
    assert error is not None and float(error[1]) <= 1.0, result.stdout
    gltf = _glb_json(out / "makehuman_head_arkit.glb")
    targets = {mesh["name"]: mesh.get("extras", {}).get("targetNames", []) for mesh in gltf["meshes"]}
    assert targets["Head"] == list(ARKIT_NAMES)
    assert "jawOpen" in targets["Teeth Lower"] and "eyeLookInLeft" in targets["Eye L"]


def test_a_bad_capture_fails_its_line_and_leaves_no_outputs(tmp_path):
    capture = tmp_path / "bad.json"
    capture.write_text(json.dumps({"fps": 30, "frames": [{"jawOpen": 0.2}, {"jawOpen": float("nan")}]}))
    capture.write_text(capture.read_text().replace("NaN", "2.0"))
    out = tmp_path / "out"
    result = run_convert("--face", FACE, capture, "-o", out, "--no-video", "--sheet", "0")
    assert result.returncode == 1
    assert "bad.json: FAILED: bad.json: frames frame 1: jawOpen = 2 is outside 0..1" in result.stdout
    assert sorted(p.name for p in out.iterdir() if p.suffix != ".log") == []


def test_no_streams_needs_arkit_glb(tmp_path):
    result = run_convert("--face", FACE, "-o", tmp_path / "out")
    assert result.returncode == 2
    assert "give the streams to convert (or --arkit-glb" in result.stderr
