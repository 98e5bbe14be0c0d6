"""scripts/convert.py end to end, through the bpy module in a subprocess: every argument is checked before
any work (one line, exit status 2), then one line per stream (exit status 1 if any failed)."""

import errno
import os
import re
import sys

import pytest

from addon.errors import Mpeg4Error
from addon.mpeg4.fap_file import read_fap

from .helpers import FACE, cut_stream, run_convert

pytest.importorskip("bpy")

# Blender's own log lines ("00:00.087  blend | Read blend: ..."; 5.2 adds "color_management | Using OCIO=...")
BLENDER_LOG = re.compile(r"\d\d:\d\d\.\d{3} +[\w.]+ +\| ")
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0  # root reads and writes whatever the permissions say


def _refused(result, message: str) -> None:
    """The run stopped with exactly `convert.py: error: MESSAGE` and opened no face file."""
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.strip() == f"convert.py: error: {message}", result.stderr
    assert "Read blend" not in result.stdout


@pytest.fixture
def short(tmp_path):
    return cut_stream(tmp_path / "short.fap")


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--resolution", "0", "argument --resolution: '0' is not a whole number from 16 to 8192"),
        ("--resolution", "100000", "argument --resolution: '100000' is not a whole number from 16 to 8192"),
        ("--resolution", "64px", "argument --resolution: '64px' is not a whole number from 16 to 8192"),
        ("--frames", "5", "argument --frames: '5' is not FIRST:LAST in whole frame numbers, e.g. 0:100"),
        ("--frames", "a:b", "argument --frames: 'a:b' is not FIRST:LAST in whole frame numbers, e.g. 0:100"),
        ("--frames", "9:3", "argument --frames: '9:3' ends before it starts"),
        ("--sheet", "-1", "argument --sheet: '-1' is not a whole number from 0 to 100"),
        ("--jobs", "0", "argument --jobs: '0' is not a whole number from 1 to 64"),
    ],
)
def test_bad_options_stop_before_any_work(tmp_path, short, option, value, message):
    out = tmp_path / "out"
    result = run_convert("--face", FACE, short, "-o", out, option, value)
    _refused(result, message)
    assert not out.exists()


def test_a_missing_stream_stops_the_run_before_the_good_ones_convert(tmp_path, short):
    missing = tmp_path / "missing.fap"
    out = tmp_path / "out"
    _refused(run_convert("--face", FACE, short, missing, "-o", out), f"stream not found: {missing}")
    assert not out.exists()


def test_a_missing_face_file_stops_the_run(tmp_path, short):
    face = tmp_path / "face.blend"
    _refused(run_convert("--face", face, short, "-o", tmp_path / "out"), f"face file not found: {face}")


def test_a_folder_as_stream_is_refused(tmp_path, short):
    folder = tmp_path / "folder.fap"
    folder.mkdir()
    _refused(
        run_convert("--face", FACE, short, folder, "-o", tmp_path / "out"), f"stream is not a regular file: {folder}"
    )


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_pipe_as_stream_is_refused_without_reading_it(tmp_path, short):
    pipe = tmp_path / "pipe.fap"
    os.mkfifo(pipe)
    result = run_convert("--face", FACE, short, pipe, "-o", tmp_path / "out", timeout=120)
    _refused(result, f"stream is not a regular file: {pipe}")


@pytest.mark.skipif(AS_ROOT or sys.platform == "win32", reason="needs file permissions that apply")
def test_an_unreadable_stream_is_refused(tmp_path, short):
    locked = cut_stream(tmp_path / "locked.fap")
    locked.chmod(0)
    _refused(
        run_convert("--face", FACE, short, locked, "-o", tmp_path / "out"),
        f"cannot read stream {locked}: {os.strerror(errno.EACCES)}",
    )


def test_same_named_streams_from_two_folders_are_refused(tmp_path, short):
    first, second = tmp_path / "a" / "x.fap", tmp_path / "b" / "x.fap"
    for path in (first, second):
        path.parent.mkdir()
        cut_stream(path)
    out = tmp_path / "out"
    _refused(
        run_convert("--face", FACE, first, second, "-o", out), f"{first} and {second} would both write x.*: rename one"
    )
    assert not out.exists()


def test_an_output_folder_under_a_file_is_refused(tmp_path, short):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    out = blocker / "out"
    _refused(
        run_convert("--face", FACE, short, "-o", out),
        f"cannot write to the output folder {out}: {os.strerror(errno.ENOTDIR)}",
    )


@pytest.mark.skipif(AS_ROOT or sys.platform == "win32", reason="needs file permissions that apply")
def test_a_read_only_output_folder_is_refused(tmp_path, short):
    out = tmp_path / "read_only"
    out.mkdir()
    out.chmod(0o555)
    _refused(
        run_convert("--face", FACE, short, "-o", out),
        f"cannot write to the output folder {out}: {os.strerror(errno.EACCES)}",
    )


def test_an_unknown_face_object_is_refused_before_any_stream(tmp_path, short):
    out = tmp_path / "out"
    result = run_convert("--face", FACE, short, "-o", out, "--object", "Nobody")
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.strip() == "convert.py: error: no mesh object named 'Nobody' in the face file"
    assert "[1/1]" not in result.stdout and list(out.iterdir()) == []


def test_each_failing_stream_gives_one_line_and_the_good_one_converts(tmp_path, short):
    broken = tmp_path / "broken.fap"
    broken.write_text("2.1 broken 25 1\n1 0 0\n")
    with pytest.raises(Mpeg4Error) as parse_error:
        read_fap(broken)
    huge = cut_stream(tmp_path / "huge.fap", frames=2, numbers=(0, 1_000_000))  # 1,000,001 frames to bake
    slow = cut_stream(tmp_path / "slow.fap", frames=2, fps="1e-300")
    late = cut_stream(tmp_path / "late.fap", frames=2, numbers=(1_000_001, 1_000_002))
    out = tmp_path / "out"
    streams = (short, broken, huge, slow, late)
    result = run_convert(
        "--face", FACE, *streams, "-o", out, "--frames", ":1000000", "--resolution", "32", "--no-video", "--sheet", "2"
    )
    assert result.returncode == 1, result.stdout + result.stderr
    expected = {
        2: str(parse_error.value),
        3: "frames 0..1000000 would make a 47.8 GiB point cache (at most 4 GiB): choose fewer frames with --frames",
        4: "Blender cannot play a frame rate of 1e-300 fps",
        5: "--frames selects no frame of the stream (its frames are 1000001..1000002)",
    }
    lines = result.stdout.splitlines()
    for i, stream in enumerate(streams, 1):
        mine = [line for line in lines if line.startswith(f"[{i}/5]")]
        assert len(mine) == 1, lines
        if i == 1:
            assert re.fullmatch(
                rf"\[1/5\] {re.escape(str(short))}: ok in [\d.]+ s -> short.pc2, short.abc, "
                r"short_sheet.png",
                mine[0],
            )
        else:
            assert mine[0] == f"[{i}/5] {stream}: FAILED: {expected[i]}"
    assert re.fullmatch(r"1 converted, 4 failed in [\d.]+ s", lines[-1])
    assert "Traceback" not in result.stderr
    # the streams that failed before Blender said anything leave no log either
    assert sorted(p.name for p in out.iterdir()) == ["short.abc", "short.log", "short.pc2", "short_sheet.png"]


def test_convert_writes_alembic_cache_video_and_sheet(tmp_path, short):
    out = tmp_path / "out"
    result = run_convert("--face", FACE, short, "-o", out, "--resolution", "64", "--sheet", "4")
    assert result.returncode == 0, result.stdout + result.stderr
    for name in ("short.abc", "short.mp4", "short_sheet.png", "short.pc2"):
        assert (out / name).stat().st_size > 0
    # Blender's lines per rendered frame go to the stream's log; stdout keeps the result, stderr a few lines of
    # progress (stderr is not a terminal here)
    lines = [line for line in result.stdout.splitlines() if not BLENDER_LOG.match(line)]
    assert len(lines) == 2, result.stdout
    assert re.fullmatch(
        rf"\[1/1\] {re.escape(str(short))}: ok in [\d.]+ s -> short.pc2, short.abc, short.mp4, short_sheet.png",
        lines[0],
    )
    assert re.fullmatch(r"1 converted, 0 failed in [\d.]+ s", lines[1])
    pattern = rf"\[1/1\] {re.escape(str(short))}: \d+ % \(.+\)"
    assert 1 <= len([line for line in result.stderr.splitlines() if re.fullmatch(pattern, line)]) <= 3
    assert "Video append" not in result.stdout + result.stderr and "Saved:" not in result.stdout + result.stderr
    log = (out / "short.log").read_text()
    assert log.count("Video append frame") == 8 and log.count("Saved:") == 4


def test_convert_reads_arguments_after_the_double_dash(monkeypatch):
    from scripts import convert

    argv = ["blender", "--background", "f.blend", "--python", "convert.py", "--", "a.fap", "-o", "out", "b.fap"]
    monkeypatch.setattr(sys, "argv", argv)
    args = convert.parse_args(convert.script_argv())
    assert [p.name for p in args.streams] == ["a.fap", "b.fap"] and args.out.name == "out" and args.face is None


def test_the_contact_sheets_empty_cells_take_the_background(tmp_path, short):
    from tests.web.png import read_png

    out = tmp_path / "out"
    result = run_convert("--face", FACE, short, "-o", out, "--resolution", "32", "--no-video", "--sheet", "7")
    assert result.returncode == 0, result.stdout + result.stderr
    sheet = read_png(out / "short_sheet.png")[..., :3].astype(int)
    tile = sheet.shape[1] // 6  # 7 frames: 6 columns, 2 rows, the last 5 cells of the second row empty
    assert sheet.shape[0] == 2 * tile
    empty = sheet[tile:, tile:]
    assert (empty == sheet[0, 0]).all() and (sheet[:tile, :tile] != sheet[0, 0]).any()  # the face is drawn
