"""convert.py --jobs N: one process per stream, N at a time, the same lines in stream order and the same outputs as
converting in one process; a process that dies is its stream's FAILED line; Ctrl+C stops them all.

A crash is simulated from outside, as it would happen: the test finds the process converting one stream (a child
of convert.py whose command line names that stream, through /proc) and kills it with SIGKILL."""

import io
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from addon.errors import Mpeg4Error
from addon.mpeg4.fap_file import read_fap

from .helpers import FACE, ROOT, cut_stream, run_convert

pytest.importorskip("bpy")

TINY = ("--resolution", "32", "--no-video", "--sheet", "0")
HAS_PROC = Path("/proc/self/stat").is_file()


def result_lines(stdout: str) -> list[str]:
    """The stream lines with their times taken out, and the summary without its time."""
    lines = [re.sub(r": ok in [\d.]+ s", ": ok in _ s", line) for line in stdout.splitlines() if line.startswith("[")]
    summary = stdout.splitlines()[-1]
    return [*lines, re.sub(r" in [\d.]+ s$", " in _ s", summary)]


def test_jobs_gives_the_lines_and_outputs_of_one_process(tmp_path):
    streams = [cut_stream(tmp_path / "a.fap", frames=4), tmp_path / "bad.fap", cut_stream(tmp_path / "b.fap", frames=3)]
    streams[1].write_text("2.1 broken 25 1\n1 0 0\n")
    with pytest.raises(Mpeg4Error) as parse_error:
        read_fap(streams[1])
    runs = {jobs: run_convert("--face", FACE, *streams, "-o", tmp_path / jobs, "--jobs", jobs, *TINY) for jobs in "12"}
    for result in runs.values():
        assert result.returncode == 1, result.stdout + result.stderr
        assert "Traceback" not in result.stderr
    lines = result_lines(runs["2"].stdout)
    assert lines == result_lines(runs["1"].stdout)
    assert lines == [
        f"[1/3] {streams[0]}: ok in _ s -> a.pc2, a.abc",
        f"[2/3] {streams[1]}: FAILED: {parse_error.value}",
        f"[3/3] {streams[2]}: ok in _ s -> b.pc2, b.abc",
        "2 converted, 1 failed in _ s",
    ]
    one, two = tmp_path / "1", tmp_path / "2"
    names = sorted(p.name for p in one.iterdir())
    assert names == ["a.abc", "a.log", "a.pc2", "b.abc", "b.log", "b.pc2"]
    assert sorted(p.name for p in two.iterdir()) == names
    for name in ("a.pc2", "b.pc2"):
        assert (two / name).read_bytes() == (one / name).read_bytes()
    assert (two / "a.abc").stat().st_size > 0 and (two / "b.abc").stat().st_size > 0


def _children(parent: int) -> dict[int, list[str]]:
    """The processes whose parent is `parent`, with their command lines."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            if ppid == parent:
                found[int(entry.name)] = (entry / "cmdline").read_bytes().decode().split("\0")
        except (OSError, IndexError, ValueError):  # it ended meanwhile
            continue
    return found


def _descendants(pid: int) -> list[int]:
    found = []
    for child in _children(pid):
        found += [child, *_descendants(child)]
    return found


def _wait_for_children(parent: subprocess.Popen, wanted, timeout: float = 120) -> dict[int, list[str]]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and parent.poll() is None:
        children = _children(parent.pid)
        if wanted(children):
            return children
        time.sleep(0.02)
    raise AssertionError(f"convert.py did not start the processes looked for: {parent.communicate()}")


def _as_from_a_terminal() -> None:
    """In the child before it runs: SIGINT as a terminal leaves it. A shell that starts pytest in the background
    (`&` without job control) starts it with SIGINT ignored, which its children inherit and Python then keeps."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_convert(*args) -> subprocess.Popen:
    command = [sys.executable, "-m", "scripts.convert", *map(str, args)]
    return subprocess.Popen(
        command,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_as_from_a_terminal if os.name == "posix" else None,
    )


@pytest.mark.skipif(not HAS_PROC, reason="finds the child processes through /proc")
def test_a_killed_child_is_its_streams_failed_line(tmp_path):
    # the victim is long enough (the whole demo, a few seconds) to be still converting when it is killed
    good, victim = cut_stream(tmp_path / "good.fap", frames=3), cut_stream(tmp_path / "victim.fap", frames=413)
    out = tmp_path / "out"
    parent = _start_convert("--face", FACE, good, victim, "-o", out, "--jobs", "2", *TINY)
    children = _wait_for_children(parent, lambda found: any(str(victim) in argv for argv in found.values()))
    (pid,) = [pid for pid, argv in children.items() if str(victim) in argv]
    for descendant in _descendants(pid):  # whatever it started too, so nothing of it finishes the stream
        os.kill(descendant, signal.SIGKILL)
    os.kill(pid, signal.SIGKILL)
    stdout, stderr = parent.communicate(timeout=600)
    assert parent.returncode == 1, stdout + stderr
    lines = result_lines(stdout)
    assert lines == [
        f"[1/2] {good}: ok in _ s -> good.pc2, good.abc",
        f"[2/2] {victim}: FAILED: the process converting it ended without a result (exit status -9, killed by SIGKILL)",
        "1 converted, 1 failed in _ s",
    ]
    assert not [p.name for p in out.iterdir() if p.name.startswith("victim") and p.suffix != ".log"]


@pytest.mark.skipif(not HAS_PROC or sys.platform == "win32", reason="finds the child processes through /proc")
def test_ctrl_c_stops_every_child_and_leaves_no_outputs(tmp_path):
    streams = [cut_stream(tmp_path / f"{name}.fap", frames=3) for name in ("a", "b")]
    out = tmp_path / "out"
    parent = _start_convert("--face", FACE, *streams, "-o", out, "--jobs", "2", *TINY)
    children = _wait_for_children(parent, lambda found: len(found) == 2)
    parent.send_signal(signal.SIGINT)  # to convert.py alone, as a terminal's Ctrl+C reaches it (and its children)
    stdout, stderr = parent.communicate(timeout=120)
    assert parent.returncode == 130, stdout + stderr
    assert stderr.splitlines()[-1] == "convert.py: interrupted"
    assert not [line for line in stdout.splitlines() if line.startswith("[")]
    assert not [pid for pid in children if Path(f"/proc/{pid}").exists()]
    assert not [p.name for p in out.iterdir() if p.suffix != ".log"]


@pytest.mark.skipif(sys.platform == "win32", reason="sends SIGINT")
def test_ctrl_c_in_one_process_stops_after_the_step_under_way(tmp_path):
    """Pressed while Blender works (here: exporting or rendering the video), Ctrl+C is not lost in an operator or
    a handler: the run stops when that step ends, and the stream's outputs are removed."""
    stream = cut_stream(tmp_path / "long.fap", frames=40)
    out = tmp_path / "out"
    parent = _start_convert("--face", FACE, stream, "-o", out, "--resolution", "32", "--sheet", "0")
    deadline = time.monotonic() + 300
    while not (out / "long.abc").exists() and parent.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    parent.send_signal(signal.SIGINT)
    stdout, stderr = parent.communicate(timeout=300)
    assert parent.returncode == 130, stdout + stderr
    assert stderr.splitlines()[-1] == "convert.py: interrupted" and "[1/1]" not in stdout
    assert [p.name for p in out.iterdir()] == ["long.log"]


def test_a_child_runs_the_command_that_started_the_run(tmp_path, monkeypatch):
    import bpy

    from scripts import convert

    stream = tmp_path / "a.fap"
    args = convert.parse_args([str(stream), "-o", str(tmp_path), "--face", str(FACE), "--frames", ":9", *TINY])
    options = ["--face", str(FACE), str(stream), "-o", str(tmp_path), *convert.stream_options(args)]
    # python -m scripts.convert (the bpy module): the same module, from the checkout
    assert convert.child_command(FACE, stream, args) == ([sys.executable, "-m", "scripts.convert", *options], ROOT)
    # python path/to/convert.py (a copy next to an installed extension): the same file
    monkeypatch.setattr(convert, "__spec__", None)
    script = str(ROOT / "scripts" / "convert.py")
    assert convert.child_command(FACE, stream, args) == ([sys.executable, script, *options], None)
    # blender --background --python convert.py: Blender again, not its bundled Python (sys.executable)
    monkeypatch.setattr(bpy.app, "binary_path", "/opt/blender/blender")
    blender = ["/opt/blender/blender", "--background", "--python-exit-code", "1", "--python", script, "--"]
    assert convert.child_command(FACE, stream, args) == ([*blender, *options], None)
    assert vars(convert.parse_args(options)) == vars(args)  # the child converts as this run would


def test_progress_is_a_bar_on_a_terminal_and_a_few_lines_in_a_log():
    from scripts import convert

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    log = io.StringIO()
    progress = convert.Progress(log)
    progress.start("[1/1] a.fap", 40)
    for done in range(41):
        progress.advance(done, "video")
    assert log.getvalue().splitlines() == [f"[1/1] a.fap: {p} % (video)" for p in (25, 50, 75)]

    terminal = Terminal()
    progress = convert.Progress(terminal)
    progress.start("[1/1] a.fap", 4)
    progress.advance(1, "bake")
    progress.advance(1, "bake")  # nothing new to draw
    progress.advance(3, "video")
    progress.clear()
    assert terminal.getvalue() == (
        "\r[1/1] a.fap [######..................]  25 % bake\033[K"
        "\r[1/1] a.fap [##################......]  75 % video\033[K"
        "\r\033[K"
    )


@pytest.mark.skipif(sys.platform == "win32", reason="sends itself SIGINT")
def test_ctrl_c_while_a_child_starts_is_acted_on_once_it_is_recorded(request):
    """A press inside `CTRL_C.held()` (around starting a child and recording it) does not interrupt it halfway; it
    raises KeyboardInterrupt as soon as the block is over, so the child is stopped with the others."""
    from scripts.convert import CTRL_C

    before = signal.signal(signal.SIGINT, signal.default_int_handler)  # as Python sets it up from a terminal
    request.addfinalizer(lambda: signal.signal(signal.SIGINT, before))
    recorded = []
    with pytest.raises(KeyboardInterrupt):
        with CTRL_C.held():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs here: it only notes the press
            recorded.append("child")
    assert recorded == ["child"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
