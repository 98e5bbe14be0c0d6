"""The ASCII .fap reader and writer: hand-made variants, real files, malformed input and round trips."""

import math
import os
import re
import socket
import threading
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from addon import user_files
from addon.mpeg4 import fap_file
from addon.mpeg4.fap_file import (
    MAX_FRAME_NUMBER,
    N_FAPS,
    FapFileError,
    FapStream,
    _scan_numbers,
    format_fap,
    parse_fap,
    read_fap,
    write_fap,
)

INTEROP = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap"


def mask_line(*faps: int, length: int = N_FAPS, sep: str = " ") -> str:
    """A mask line with the given (1-based) FAPs set."""
    return sep.join("1" if k in faps else "0" for k in range(1, length + 1))


def low_level(frame_values: list[dict[int, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Expected (mask, values) arrays from {fap: value} per frame."""
    mask = np.zeros((len(frame_values), N_FAPS), bool)
    values = np.zeros((len(frame_values), N_FAPS))
    for i, frame in enumerate(frame_values):
        for fap, value in frame.items():
            mask[i, fap - 1] = True
            values[i, fap - 1] = value
    return mask, values


def assert_streams_equal(a: FapStream, b: FapStream) -> None:
    assert a.fps == b.fps
    np.testing.assert_array_equal(a.frame_numbers, b.frame_numbers)
    np.testing.assert_array_equal(a.mask, b.mask)
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.viseme, b.viseme)
    np.testing.assert_array_equal(a.expression, b.expression)


# --- hand-made variants -------------------------------------------------------------------------------


def test_reference_example_of_the_research_notes():
    text = f"2.1 example 25 2\n{mask_line(3, 31)}\n0 200 100\n{mask_line(3, 31)}\n1 400 150\n"
    stream = parse_fap(text)
    mask, values = low_level([{3: 200, 31: 100}, {3: 400, 31: 150}])
    assert (stream.version, stream.name, stream.fps) == ("2.1", "example", 25.0)
    np.testing.assert_array_equal(stream.frame_numbers, [0, 1])
    assert stream.frame_numbers.dtype == np.int64
    np.testing.assert_array_equal(stream.mask, mask)
    np.testing.assert_array_equal(stream.values, values)
    np.testing.assert_array_equal(stream.viseme, np.zeros((2, 4)))
    np.testing.assert_array_equal(stream.expression, np.zeros((2, 6)))
    np.testing.assert_array_equal(stream.times, [0.0, 0.04])


def test_crlf_tabs_and_trailing_blanks():
    text = (
        f"2.0 jag 5 2 \r\n{mask_line(3, 4, 68, sep=chr(9))}\t\r\n0\t57\t-114\t7\r\n"
        f"{mask_line(3, 4, 68)}  \r\n  1 58  -116 \t 8 \r\n"
    )
    stream = parse_fap(text.encode("ascii"))
    mask, values = low_level([{3: 57, 4: -114, 68: 7}, {3: 58, 4: -116, 68: 8}])
    assert (stream.version, stream.name, stream.fps) == ("2.0", "jag", 5.0)
    np.testing.assert_array_equal(stream.mask, mask)
    np.testing.assert_array_equal(stream.values, values)


def test_cr_only_line_endings():
    stream = parse_fap(f"2.1 mac 25 1\r{mask_line(5)}\r0 -3\r")
    np.testing.assert_array_equal(stream.values, low_level([{5: -3}])[1])


def test_comment_and_blank_lines_anywhere():
    text = (
        f"# made by hand\n\n2.1 Xface::FapFile 25 2\n# anger\n{mask_line(4)}\n\n0 -154.8\n"
        f"   # disgust\n{mask_line(4)}\n# between mask and values\n1 -40\n\n"
    )
    stream = parse_fap(text)
    assert stream.name == "Xface::FapFile"
    np.testing.assert_array_equal(stream.values, low_level([{4: -154.8}, {4: -40}])[1])


def test_69_flag_mask_drops_the_69th():
    text = (
        f"2.1 AU Interpolation_1214.fap 25 2\n{mask_line(19, 20, 21, 22, length=69)} \n0 940 940 200 200 \n"
        f"{mask_line(19, 69, length=69)}\n1 5 123\n"
    )
    stream = parse_fap(text)
    mask, values = low_level([{19: 940, 20: 940, 21: 200, 22: 200}, {19: 5}])
    assert stream.name == "AU Interpolation_1214.fap"
    np.testing.assert_array_equal(stream.mask, mask)
    np.testing.assert_array_equal(stream.values, values)


def test_viseme_and_expression_reference_form():
    text = (
        f"2.2 high 25 3\n{mask_line(1, 3)}\n0 1 10 40 0 300\n"
        f"{mask_line(2)}\n1 3 63 6 20 1 0\n"
        f"{mask_line(1, 2, 4)}\n2 7 8 63 1 1 2 3 4 0 1 -9\n"
    )
    stream = parse_fap(text)
    np.testing.assert_array_equal(stream.viseme, [[1, 10, 40, 0], [0, 0, 0, 0], [7, 8, 63, 1]])
    np.testing.assert_array_equal(stream.expression, [[0] * 6, [3, 63, 6, 20, 1, 0], [1, 2, 3, 4, 0, 1]])
    np.testing.assert_array_equal(stream.values, low_level([{3: 300}, {}, {4: -9}])[1])
    np.testing.assert_array_equal(stream.mask[:, :2], [[True, False], [False, True], [True, True]])


def test_greta_single_integer_forms():
    text = (
        f"2.1 1-Welcome_1.fap 25 4\n{mask_line(1, length=69)} \n0 7 \n"
        f"{mask_line(2, 3, length=69)}\n1 4 250\n"
        f"{mask_line(1, 2, length=69)}\n2 9 5\n"
        f"{mask_line(1, 2, length=69)}\n3 1 2 3 4 6\n"  # viseme in 4 fields, expression in 1
    )
    stream = parse_fap(text)
    np.testing.assert_array_equal(stream.viseme, [[7, 0, 0, 0], [0, 0, 0, 0], [9, 0, 0, 0], [1, 2, 3, 4]])
    np.testing.assert_array_equal(stream.expression[:, 0], [0, 4, 5, 6])
    np.testing.assert_array_equal(stream.expression[:, 1:], np.zeros((4, 5)))
    np.testing.assert_array_equal(stream.values, low_level([{}, {3: 250}, {}, {}])[1])


def test_float_values_are_exact():
    tokens = ["-154.8", "0.322581", "1e-3", "+5", ".5", "5.", "1E2", "-0", "12345678901234567890", "2.5e+1"]
    faps = list(range(3, 3 + len(tokens)))
    stream = parse_fap(f"2.1 floats 25 1\n{mask_line(*faps)}\n0 {' '.join(tokens)}\n")
    np.testing.assert_array_equal(stream.values[0, 2 : 2 + len(tokens)], [float(t) for t in tokens])


def test_frame_numbers_from_1_with_gaps():
    text = f"2.0 eyes.fap 2 3\n{mask_line(19)}\n1 10\n{mask_line(19)}\n5 20\n{mask_line(19)}\n6 30\n"
    stream = parse_fap(text)
    np.testing.assert_array_equal(stream.frame_numbers, [1, 5, 6])
    np.testing.assert_array_equal(stream.times, [0.5, 2.5, 3.0])


def test_all_zero_mask_frame_holds_only_the_frame_number():
    text = f"2.1 Xface::FapFile 25 2\n{mask_line()} \n0 \n{mask_line(4, 5)} \n1 0.322581 -4.61945 \n"
    stream = parse_fap(text)
    mask, values = low_level([{}, {4: 0.322581, 5: -4.61945}])
    np.testing.assert_array_equal(stream.mask, mask)
    np.testing.assert_array_equal(stream.values, values)


def test_presence_comes_from_the_mask_not_the_value():
    stream = parse_fap(f"2.1 zeros 25 1\n{mask_line(19, 20)}\n0 0 0\n")
    assert stream.mask[0, 18] and stream.mask[0, 19] and stream.mask.sum() == 2
    np.testing.assert_array_equal(stream.values, np.zeros((1, N_FAPS)))


def test_header_frame_count_is_informational():
    frames = f"{mask_line(3)}\n0 1\n{mask_line(3)}\n1 2\n"
    for claimed in ("0", "5", "1000000000", "9" * 40):
        stream = parse_fap(f"2.1 claims 25 {claimed}\n{frames}")
        np.testing.assert_array_equal(stream.frame_numbers, [0, 1])


def test_header_claiming_a_billion_frames_allocates_nothing_large():
    text = f"2.1 huge 25 1000000000\n{mask_line(3)}\n0 1\n{mask_line(3)}\n1 2\n"
    tracemalloc.start()
    try:
        stream = parse_fap(text)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert stream.n_frames == 2
    assert peak < 2_000_000


def test_header_only_is_an_empty_stream():
    stream = parse_fap("2.1 nothing 25 0\n")
    assert stream.n_frames == 0
    assert stream.mask.shape == (0, N_FAPS) and stream.values.shape == (0, N_FAPS)
    assert stream.viseme.shape == (0, 4) and stream.expression.shape == (0, 6)


def test_path_bytes_and_text_read_the_same(tmp_path):
    text = f"2.1 same 10 1\n{mask_line(48)}\n0 -7716\n"
    path = tmp_path / "same.fap"
    path.write_text(text)
    for source in (path, str(path), text, text.encode()):
        stream = read_fap(source)
        np.testing.assert_array_equal(stream.values, low_level([{48: -7716}])[1])
        assert stream.fps == 10.0


# --- the real files -------------------------------------------------------------------------------------

needs_interop = pytest.mark.skipif(not INTEROP.is_dir(), reason="interop .fap files not present")
INTEROP_FILES = sorted(INTEROP.glob("*/*.fap")) if INTEROP.is_dir() else []


@needs_interop
def test_all_sixteen_interop_files_are_there():
    assert len(INTEROP_FILES) == 16


@needs_interop
@pytest.mark.parametrize("path", INTEROP_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_interop_file_reads_and_round_trips(path):
    stream = read_fap(path)
    assert stream.n_frames >= 1
    assert np.all(np.diff(stream.frame_numbers) > 0)
    assert not np.any(stream.values[~stream.mask])
    assert_streams_equal(parse_fap(format_fap(stream)), stream)


# (file, frame index, header, frame number, {FAP: value}, FAPs absent in that frame)
SPOT_CHECKS = [
    ("copperdong_Xface/anger.fap", 1, ("2.1", 25.0, 108), 1, {3: 0, 4: 8, 5: 10, 6: 1, 19: -2}, [1, 2, 21]),
    ("copperdong_Xface/anger.fap", 50, ("2.1", 25.0, 108), 50, {3: 82, 4: -83, 48: 1237, 51: -41}, []),
    ("bestdpf_xface-new/hate.fap", 1, ("2.1", 25.0, 107), 1, {4: 10, 23: -3, 31: -70}, [19]),
    ("isir_greta/AU Interpolation_1214.fap", 0, ("2.1", 25.0, 1), 0, {19: 940, 20: 940, 21: 200, 22: 200}, [1, 23]),
    ("isir_greta/AU Interpolation_1202.fap", 0, ("2.1", 25.0, 1), 0, {19: 0, 20: 0, 21: 0, 22: 0}, [18]),
    ("philippedax_vreng/eyes.fap", 11, ("2.0", 2.0, 52), 12, {19: 1080, 20: 1080, 21: 600, 23: 0}, [27]),
    ("philippedax_vreng/eyes.fap", 51, ("2.0", 2.0, 52), 52, {19: -500, 22: 100, 23: 0, 26: -100}, [18]),
    ("philippedax_vreng/jag.fap", 0, ("2.0", 5.0, 169), 0, {3: 57, 5: -114, 48: -7716, 49: 2665, 50: -1389}, [1, 2]),
    ("philippedax_vreng/jag.fap", 1, ("2.0", 5.0, 169), 1, {3: 58, 48: -7519, 50: -1363}, []),
    ("philippedax_vreng/anger.fap", 1, ("2.1", 10.0, 23), 1, {31: 0, 32: -18}, [30, 39]),
    ("philippedax_vreng/surp.fap", 1, ("2.1", 10.0, 15), 1, {58: 18, 59: 0}, [61]),
    (
        "thuhcsi_Crystal.TTVS/7_basic_emotion.fap",
        0,
        ("2.1", 25.0, 7),
        0,
        {4: -154.8, 5: -44.8, 8: -114.8, 31: -180, 51: -114.8},
        [3],
    ),
    ("thuhcsi_Crystal.TTVS/7_basic_emotion.fap", 1, ("2.1", 25.0, 7), 1, {4: -40, 8: -184.8}, [31]),
    ("thuhcsi_Crystal.TTVS/interpolation_emot.fap", 0, ("2.1", 25.0, 224), 0, {}, list(range(1, 69))),
    (
        "thuhcsi_Crystal.TTVS/interpolation_emot.fap",
        1,
        ("2.1", 25.0, 224),
        1,
        {4: 0.322581, 5: -4.61945, 19: -6.92916, 20: -17.1011},
        [23],
    ),
    ("thuhcsi_Crystal.TTVS/interpolation_emot.fap", 191, ("2.1", 25.0, 224), 191, {23: 600000}, []),
]


@needs_interop
@pytest.mark.parametrize(("name", "index", "header", "frame", "expected", "absent"), SPOT_CHECKS)
def test_interop_spot_values(name, index, header, frame, expected, absent):
    stream = read_fap(INTEROP / name)
    assert (stream.version, stream.fps, stream.n_frames) == header
    assert stream.frame_numbers[index] == frame
    for fap, value in expected.items():
        assert stream.mask[index, fap - 1], fap
        assert stream.values[index, fap - 1] == value, fap
    assert not stream.mask[index, [fap - 1 for fap in absent]].any()


@needs_interop
def test_interop_headers_names():
    assert read_fap(INTEROP / "isir_greta/AU Interpolation_1214.fap").name == "AU Interpolation_1214.fap"
    assert read_fap(INTEROP / "philippedax_vreng/surp.fap").name == "surprise.fap"
    assert read_fap(INTEROP / "copperdong_Xface/joy.fap").name == r"C:\Users\balci\Work\FACE\exml2fap\files\TempFile"


@needs_interop
def test_interop_greta_single_integer_viseme():
    stream = read_fap(INTEROP / "isir_greta/1-Welcome_1.fap")
    np.testing.assert_array_equal(stream.mask[0].nonzero()[0], [0])
    np.testing.assert_array_equal(stream.viseme, [[0, 0, 0, 0]])
    np.testing.assert_array_equal(stream.frame_numbers, [0])


@needs_interop
def test_interop_eyes_numbered_from_one():
    np.testing.assert_array_equal(read_fap(INTEROP / "philippedax_vreng/eyes.fap").frame_numbers, np.arange(1, 53))


# --- malformed input ------------------------------------------------------------------------------------

GOOD_HEADER = "2.1 bad 25 2\n"
FRAME_0 = f"{mask_line(3, 4)}\n0 10 20\n"

MALFORMED = [
    # (id, content, line, words in the message)
    ("flag-count", f"{GOOD_HEADER}{FRAME_0}{mask_line(3)[:-2]}\n1 5\n", 4, "found 67"),
    ("flag-not-0-1", f"{GOOD_HEADER}{FRAME_0}{mask_line(3).replace('0', '2', 1)}\n1 5\n", 4, "flag 1 is '2'"),
    ("mask-length-changes", f"{GOOD_HEADER}{FRAME_0}{mask_line(3, length=69)}\n1 5\n", 4, "first mask (line 2)"),
    ("non-numeric", f"{GOOD_HEADER}{FRAME_0}{mask_line(3, 4)}\n1 5 abc\n", 5, "value 2 ('abc') is not a number"),
    ("comma-decimal", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1,5 2\n", 3, "'1,5'"),
    ("two-points", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1.5.2 2\n", 3, "'1.5.2'"),
    ("sign-inside", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1-2 2\n", 3, "'1-2'"),
    ("nan", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 nan 2\n", 3, "not a finite number"),
    ("inf", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1 -inf\n", 3, "not a finite number"),
    ("overflow", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1 1e999\n", 3, "not a finite number"),
    ("truncated-frame", f"{GOOD_HEADER}{FRAME_0}{mask_line(3)}\n", 4, "truncated frame"),
    ("truncated-values", f"{GOOD_HEADER}{FRAME_0}{mask_line(3, 4)}\n1 5", 5, "needs 2 values"),
    ("too-many-values", f"{GOOD_HEADER}{mask_line(3, 4)}\n0 1 2 3\n{FRAME_0}", 3, "found 3"),
    ("viseme-count", f"{GOOD_HEADER}{mask_line(1, 3)}\n0 1 2 3\n", 3, "needs 5 or 2 values"),
    ("unknown-version", f"3.0 bad 25 1\n{FRAME_0}", 1, "unknown version '3.0'"),
    ("empty", "", 1, "empty file"),
    ("only-comments", "# nothing\n\n# here\n", 1, "empty file"),
    ("header-too-short", f"2.1 25 1\n{FRAME_0}", 1, "version name fps frames"),
    ("fps-zero", f"2.1 bad 0 1\n{FRAME_0}", 1, "fps"),
    ("fps-negative", f"2.1 bad -25 1\n{FRAME_0}", 1, "fps"),
    ("fps-nan", f"2.1 bad nan 1\n{FRAME_0}", 1, "fps"),
    ("frame-count-not-integer", f"2.1 bad 25 two\n{FRAME_0}", 1, "frame count"),
    ("frame-number-float", f"{GOOD_HEADER}{mask_line(3, 4)}\n0.5 1 2\n", 3, "frame number '0.5'"),
    ("frame-number-negative", f"{GOOD_HEADER}{mask_line(3, 4)}\n-1 1 2\n", 3, "frame number '-1'"),
    ("frame-number-repeated", f"{GOOD_HEADER}{FRAME_0}{FRAME_0}", 5, "must increase"),
    ("frame-number-decreasing", f"{GOOD_HEADER}{mask_line()}\n7\n{mask_line()}\n3\n", 5, "must increase"),
    ("frame-number-huge", f"{GOOD_HEADER}{mask_line()}\n{'9' * 30}\n", 3, "too large"),
    ("line-numbers-count-comments", f"# c\n\n{GOOD_HEADER}# c\n{FRAME_0}\n# c\r\n{mask_line(3)}\n1 x\n", 10, "'x'"),
    ("crlf-line-numbers", f"{GOOD_HEADER}{FRAME_0}{mask_line(3)}\n1 x\n".replace("\n", "\r\n"), 5, "'x'"),
    ("junk-in-mask", f"{GOOD_HEADER}{mask_line(3)} \x0c\n0 1\n", 2, "flag 69"),
]


@pytest.mark.parametrize(
    ("content", "line", "words"), [case[1:] for case in MALFORMED], ids=[case[0] for case in MALFORMED]
)
def test_malformed_file_names_file_and_line(tmp_path, content, line, words):
    path = tmp_path / "broken_input.fap"
    path.write_bytes(content.encode("utf-8"))
    with pytest.raises(FapFileError) as info:
        read_fap(path)
    message = str(info.value)
    assert message.startswith(f"{path}: line {line}: "), message
    assert words in message, message


@pytest.mark.parametrize(
    ("data", "line"),
    [
        (f"{GOOD_HEADER}{mask_line(3)}\n0 \x00\x01\x02\n".encode(), 3),
        (GOOD_HEADER.encode() + mask_line(3).encode() + b"\n0 \xff\xfe\n", 3),
        (b"\x00" * 100, 1),
        (bytes(range(256)) * 4, 1),
    ],
    ids=["nul", "not-utf8", "all-nul", "binary"],
)
def test_binary_junk(data, line):
    with pytest.raises(FapFileError, match=rf"^junk\.fap: line {line}: "):
        parse_fap(data, "junk.fap")


def test_nul_in_text():
    with pytest.raises(FapFileError, match=r"^<string>: line 2: binary data"):
        parse_fap(f"{GOOD_HEADER}\x00")


def test_missing_file_and_directory(tmp_path):
    missing = tmp_path / "no_such_file.fap"
    with pytest.raises(FapFileError, match="no_such_file.fap: cannot read the file"):
        read_fap(missing)
    with pytest.raises(FapFileError, match=rf"^{re.escape(str(tmp_path))}: not a regular file but a directory$"):
        read_fap(tmp_path)
    with pytest.raises(FapFileError, match="nul_in_name: cannot read the file"):
        read_fap("nul_in_name\x00.fap", source_name="nul_in_name")


# --- what read_fap refuses to read, and how much it reads ---------------------------------------------


def read_fap_within(path, seconds: float = 10.0):
    """read_fap(path) in a thread, failing the test (not hanging it) if it has not ended in `seconds`."""
    outcome = {}

    def run():
        try:
            outcome["stream"] = read_fap(path)
        except Exception as exc:  # handed to the test below
            outcome["error"] = exc

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))  # a writer comes and goes: the blocked open ends
        pytest.fail(f"read_fap({path}) blocked")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["stream"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_fifo_is_refused_without_being_opened(tmp_path):
    fifo = tmp_path / "stream.fap"
    os.mkfifo(fifo)
    with pytest.raises(FapFileError) as info:
        read_fap_within(fifo)  # opening it would wait for a writer forever
    assert str(info.value) == f"{fifo}: not a regular file but a named pipe (FIFO)"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_fifo_that_takes_the_files_place_after_the_check_is_refused_without_waiting(tmp_path, monkeypatch):
    fifo = tmp_path / "swapped.fap"
    os.mkfifo(fifo)
    checks = []
    real_is_regular = user_files.stat.S_ISREG

    def regular_at_first(mode):  # the path was a regular file when it was first looked at
        checks.append(mode)
        return len(checks) == 1 or real_is_regular(mode)

    monkeypatch.setattr(user_files.stat, "S_ISREG", regular_at_first)
    with pytest.raises(FapFileError) as info:
        read_fap_within(fifo)
    assert str(info.value) == f"{fifo}: not a regular file but a named pipe (FIFO)"
    assert len(checks) == 2


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero here")
def test_dev_zero_is_refused_without_being_read():
    with pytest.raises(FapFileError) as info:
        read_fap_within("/dev/zero")  # it never ends
    assert str(info.value) == "/dev/zero: not a regular file but a character device"


@pytest.mark.skipif(not hasattr(socket, "AF_UNIX"), reason="no Unix sockets here")
def test_a_socket_is_refused(tmp_path):
    path = tmp_path / "s.fap"
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(path))
        with pytest.raises(FapFileError) as info:
            read_fap_within(path)
    assert str(info.value) == f"{path}: not a regular file but a socket"


def test_the_size_cap_reads_a_file_of_the_cap_and_refuses_one_byte_more(tmp_path, monkeypatch):
    content = f"2.1 capped 25 1\n{mask_line(3)}\n0 7\n".encode()
    path = tmp_path / "capped.fap"
    path.write_bytes(content)
    monkeypatch.setattr(fap_file, "MAX_FILE_BYTES", len(content))
    assert read_fap(path).values[0, 2] == 7
    path.write_bytes(content + b"\n")
    with pytest.raises(FapFileError, match=rf"^{re.escape(str(path))}: larger than 0 MiB, which no FAP stream needs$"):
        read_fap(path)


@pytest.mark.skipif(not os.path.isfile("/proc/self/status"), reason="no /proc here")
def test_a_file_that_understates_its_size_is_read_whole_but_only_up_to_the_cap(monkeypatch):
    assert os.stat("/proc/self/status").st_size == 0  # a regular file that claims to be empty, but is not
    with pytest.raises(FapFileError, match=r"^/proc/self/status: line 1: header .*, found 'Name:\\t"):
        read_fap("/proc/self/status")  # read beyond the one byte its size promises
    monkeypatch.setattr(fap_file, "MAX_FILE_BYTES", 100)
    with pytest.raises(FapFileError, match=r"^/proc/self/status: larger than 0 MiB"):
        read_fap("/proc/self/status")


# --- frame numbers and huge lines ------------------------------------------------------------------------


def test_a_309_digit_frame_number_says_how_long_and_what_the_largest_is():
    with pytest.raises(FapFileError) as info:
        parse_fap(f"{GOOD_HEADER}{mask_line()}\n{'9' * 309}\n", "t.fap")
    assert (
        str(info.value)
        == "t.fap: line 3: frame number 999999999999...(309 digits) is too large (at most 9007199254740991)"
    )


def test_frame_numbers_end_at_the_last_exact_double():
    assert MAX_FRAME_NUMBER == 2**53 - 1
    stream = parse_fap(f"{GOOD_HEADER}{mask_line()}\n{2**53 - 1}\n")
    assert stream.frame_numbers[0] == 2**53 - 1
    for number in (2**53, 2**53 + 1, "0" * 5000 + str(2**53)):
        with pytest.raises(FapFileError) as info:
            parse_fap(f"{GOOD_HEADER}{mask_line()}\n{number}\n", "t.fap")
        assert str(info.value).startswith(f"t.fap: line 3: frame number {str(number)[:12]}"), str(info.value)
        assert str(info.value).endswith("is too large (at most 9007199254740991)")


def test_a_zero_padded_frame_number_on_a_bad_line_is_a_fap_error():
    # int() refuses over 4,300 digits: the message must not depend on it
    with pytest.raises(FapFileError, match=r"^t\.fap: line 3: value 1 \('x'\) is not a number$"):
        parse_fap(f"{GOOD_HEADER}{mask_line(3)}\n{'0' * 5000}1 x\n", "t.fap")


def test_the_first_bad_line_is_named_even_when_a_later_one_is_malformed_too():
    text = f"{GOOD_HEADER}{mask_line(3)}\n{2**60} 1\n{mask_line(3)}\n{2**61} x\n"
    with pytest.raises(FapFileError, match=r"^t\.fap: line 3: frame number 1152921504606846976 is too large"):
        parse_fap(text, "t.fap")


def test_the_first_line_over_the_cap_is_named():
    text = f"{GOOD_HEADER}{mask_line(3)}\n0 {'1' * 9000}\n{mask_line(3)}\n1 {'1' * 20000}\n"
    with pytest.raises(FapFileError, match=r"^t\.fap: line 3: 9002 characters long; a \.fap line has at most 8192$"):
        parse_fap(text, "t.fap")


def test_lines_with_too_many_values_are_refused_in_memory_bounded_by_lines_not_values():
    crowded = " ".join(["1"] * 4000)  # under the line cap, but more values than any frame holds
    text = GOOD_HEADER + "".join(f"{mask_line(3)}\n{i} {crowded}\n" for i in range(200))
    tracemalloc.start()
    try:
        with pytest.raises(FapFileError) as info:
            parse_fap(text, "t.fap")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(info.value) == "t.fap: line 3: the mask on line 2 needs 1 values after the frame number, found 4000"
    assert peak < 8 * len(text)  # converting the 800,000 values would take over 60 times the text


def test_a_crowded_line_among_good_ones_names_its_first_bad_value():
    crowded = f"1 {' '.join(['2'] * 100)} x {' '.join(['3'] * 100)}"
    text = f"{GOOD_HEADER}{mask_line(3)}\n0 1\n{mask_line(3)}\n{crowded}\n{mask_line(3)}\n2 1\n"
    with pytest.raises(FapFileError, match=r"^t\.fap: line 5: value 101 \('x'\) is not a number$"):
        parse_fap(text, "t.fap")


LONG = "y" * 8000  # under the line cap
SHORT_MESSAGES = [
    ("version", f"{LONG} n 25 1\n", 1, f"unknown version '{'y' * 40}'... (8000 characters)"),
    ("fps", f"2.1 n {LONG} 1\n", 1, f"fps must be a positive finite number, found '{'y' * 40}'... (8000 characters)"),
    ("count", f"2.1 n 25 {LONG}\n", 1, f"frame count must be a non-negative integer, found '{'y' * 40}'..."),
    ("header", f"2.1 {LONG}\n", 1, f"header must be 'version name fps frames', found '2.1 {'y' * 36}'..."),
    ("flag", f"{GOOD_HEADER}{mask_line(3)} {LONG}\n0 1\n", 2, f"mask flag 69 is '{'y' * 40}'... (8000 characters)"),
    ("value", f"{GOOD_HEADER}{mask_line(3)}\n0 {LONG}\n", 3, f"value 1 ('{'y' * 40}'... (8000 characters)) is not"),
    ("frame", f"{GOOD_HEADER}{mask_line()}\n{LONG}\n", 3, f"frame number '{'y' * 40}'... (8000 characters) is not"),
]


@pytest.mark.parametrize(
    ("text", "line", "words"), [case[1:] for case in SHORT_MESSAGES], ids=[case[0] for case in SHORT_MESSAGES]
)
def test_messages_quote_at_most_40_characters(text, line, words):
    with pytest.raises(FapFileError) as info:
        parse_fap(text, "t.fap")
    message = str(info.value)
    assert message.startswith(f"t.fap: line {line}: ") and words in message, message
    assert len(message) < 160, message


def test_wrong_input_types():
    with pytest.raises(FapFileError):
        read_fap(42)
    with pytest.raises(FapFileError):
        parse_fap(None)


def test_source_name_is_used():
    with pytest.raises(FapFileError, match=r"^speech\.fap: line 1: unknown version"):
        read_fap("1.0 x 25 1\n", source_name="speech.fap")


# --- writing --------------------------------------------------------------------------------------------


def make_stream(frame_numbers, mask, values, viseme=None, expression=None, fps=25.0, name="test"):
    n = len(frame_numbers)
    return FapStream(
        version="2.1",
        name=name,
        fps=fps,
        frame_numbers=np.asarray(frame_numbers, np.int64),
        mask=np.asarray(mask, bool),
        values=np.asarray(values, np.float64),
        viseme=np.zeros((n, 4)) if viseme is None else np.asarray(viseme, np.float64),
        expression=np.zeros((n, 6)) if expression is None else np.asarray(expression, np.float64),
    )


def test_format_reference_layout():
    mask, values = low_level([{3: 200, 31: 100.5}, {3: -1e-5, 68: 1e20}])
    mask[0, :2] = True
    viseme = [[1, 10, 40, 0], [0, 0, 0, 0]]
    expression = [[3, 63, 0, 0, 1, 0], [0, 0, 0, 0, 0, 0]]
    stream = make_stream([0, 3], mask, values, viseme, expression, fps=29.97, name="AU Interpolation 1")
    expected = (
        "2.1 AU_Interpolation_1 29.97 2\n"
        f"{mask_line(1, 2, 3, 31)}\n0 1 10 40 0 3 63 0 0 1 0 200 100.5\n"
        f"{mask_line(3, 68)}\n3 -1e-05 1e+20\n"
    )
    assert format_fap(stream) == expected


def test_integral_fps_is_written_as_integer():
    stream = make_stream([0], np.zeros((1, N_FAPS)), np.zeros((1, N_FAPS)), fps=25.0)
    assert format_fap(stream) == f"2.1 test 25 1\n{mask_line()}\n0\n"


def test_masked_out_entries_are_not_written():
    mask, values = low_level([{5: 1}])
    values[0, 5] = np.nan  # masked out: ignored
    assert format_fap(make_stream([0], mask, values)).endswith("\n0 1\n")


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"values": np.full((1, N_FAPS), np.inf)}, "not finite"),
        ({"frame_numbers": np.array([-1])}, "frame numbers"),
        ({"fps": 0.0}, "fps"),
        ({"version": "3.0"}, "version"),
        ({"mask": np.ones((2, N_FAPS), bool)}, "shape"),
        ({"viseme": np.zeros((1, 3))}, "shape"),
    ],
)
def test_writer_rejects_bad_streams(tmp_path, change, words):
    fields = {**make_stream([0], np.ones((1, N_FAPS)), np.ones((1, N_FAPS))).__dict__, **change}
    stream = FapStream(**fields)
    target = tmp_path / "out.fap"
    target.write_text("old content")
    with pytest.raises(FapFileError, match=words):
        write_fap(stream, target)
    assert target.read_text() == "old content"
    assert [p.name for p in tmp_path.iterdir()] == ["out.fap"]


def test_writer_rejects_decreasing_frame_numbers():
    with pytest.raises(FapFileError, match="increase"):
        format_fap(make_stream([3, 3], np.zeros((2, N_FAPS)), np.zeros((2, N_FAPS))))


def test_write_fap_replaces_and_leaves_no_temporary_file(tmp_path):
    mask, values = low_level([{3: 1}, {3: 2}])
    target = tmp_path / "anim.fap"
    target.write_text("old content")
    write_fap(make_stream([0, 1], mask, values), target)
    assert [p.name for p in tmp_path.iterdir()] == ["anim.fap"]
    assert_streams_equal(read_fap(target), make_stream([0, 1], mask, values))


def test_write_into_missing_directory_is_a_fap_error(tmp_path):
    stream = make_stream([0], np.zeros((1, N_FAPS)), np.zeros((1, N_FAPS)))
    with pytest.raises(FapFileError, match="cannot write the file"):
        write_fap(stream, tmp_path / "missing" / "x.fap")


# --- round trips ----------------------------------------------------------------------------------------

SPECIAL_VALUES = [
    0.0,
    -0.0,
    5e-324,
    1.7976931348623157e308,
    2.0**53,
    2.0**53 + 2,
    1e16,
    0.1,
    1 / 3,
    -1e-300,
    1e22,
    123456789012345678.0,
    0.322581,
    -154.8,
]


def random_numbers(rng: np.random.Generator, kind: str, shape: tuple) -> np.ndarray:
    if kind == "integers":
        return rng.integers(-(10**6), 10**6, shape).astype(np.float64)
    if kind == "decimals":
        return np.round(rng.normal(0.0, 300.0, shape), rng.integers(0, 7))
    if kind == "special":
        return rng.choice(SPECIAL_VALUES, shape)
    bits = rng.integers(np.iinfo(np.int64).min, np.iinfo(np.int64).max, shape, dtype=np.int64, endpoint=True)
    numbers = bits.view(np.float64)  # every finite double is possible, subnormals included
    return np.where(np.isfinite(numbers), numbers, 0.0)


@st.composite
def streams(draw):
    """Random streams; the arrays come from a drawn seed (fast), the structure from hypothesis."""
    n = draw(st.integers(0, 12))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["integers", "decimals", "special", "any"]))
    frame_numbers = np.cumsum(rng.integers(1, 1000, n)) - draw(st.integers(0, 1))
    mask = rng.random((n, N_FAPS)) < draw(st.sampled_from([0.0, 0.05, 0.3, 1.0]))
    values = np.where(mask, random_numbers(rng, kind, (n, N_FAPS)), 0.0)
    values[:, :2] = 0.0
    return FapStream(
        version=draw(st.sampled_from(["2.0", "2.1", "2.2"])),
        name=draw(st.text(alphabet="abcXYZ_-.:#\\/ \t1", min_size=1, max_size=20).filter(str.strip)),
        fps=draw(st.one_of(st.integers(1, 120).map(float), st.floats(1e-3, 1e4))),
        frame_numbers=frame_numbers.astype(np.int64),
        mask=mask,
        values=values,
        viseme=np.where(mask[:, :1], random_numbers(rng, kind, (n, 4)), 0.0),
        expression=np.where(mask[:, 1:2], random_numbers(rng, kind, (n, 6)), 0.0),
    )


@settings(max_examples=300, deadline=None)
@given(streams())
def test_round_trip(stream):
    back = parse_fap(format_fap(stream))
    assert_streams_equal(back, stream)
    assert back.version == stream.version
    assert back.name == "_".join(stream.name.split())


@settings(max_examples=10, deadline=None)
@given(stream=streams())
def test_round_trip_through_a_file(tmp_path_factory, stream):
    path = tmp_path_factory.mktemp("round") / "stream.fap"
    write_fap(stream, path)
    assert_streams_equal(read_fap(path), stream)


def test_round_trip_large_stream_crosses_scan_blocks():
    rng = np.random.default_rng(1)
    n = 20_000
    mask = rng.random((n, N_FAPS)) < 0.3
    mask[:, 0] = rng.random(n) < 0.1
    decimals = 10.0 ** rng.integers(0, 4, (n, N_FAPS))
    values = np.where(mask, np.round(rng.normal(0, 300, (n, N_FAPS)) * decimals) / decimals, 0.0)
    values[:, :2] = 0
    viseme = np.where(mask[:, :1], rng.integers(0, 15, (n, 4)), 0)
    stream = make_stream(np.arange(n) * 2 + 1, mask, values, viseme=viseme)
    assert_streams_equal(parse_fap(format_fap(stream)), stream)


# --- the vectorised number scanner agrees with float() and the grammar ---------------------------------

decimal_token = st.builds(
    lambda sign, whole, point, fraction, exponent: sign + whole + point + fraction + exponent,
    st.sampled_from(["", "-", "+"]),
    st.text("0123456789", max_size=20),
    st.sampled_from(["", "."]),
    st.text("0123456789", max_size=20),
    st.one_of(
        st.just(""),
        st.builds(
            lambda e, s, d: e + s + d,
            st.sampled_from("eE"),
            st.sampled_from(["", "-", "+"]),
            st.text("0123456789", max_size=4),
        ),
    ),
)
junk_token = st.text(alphabet="0123456789+-.eEx,_n", min_size=1, max_size=30)


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(decimal_token.filter(bool), junk_token), min_size=1, max_size=30))
def test_scan_numbers_matches_float(tokens):
    numbers, well_formed, digits_only, line = _scan_numbers(" ".join(tokens))
    assert len(numbers) == len(tokens)
    np.testing.assert_array_equal(line, np.zeros(len(tokens)))
    for token, number, ok, digits in zip(tokens, numbers, well_formed, digits_only, strict=True):
        grammatical = bool(re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", token))
        try:
            expected = float(token)
        except ValueError:
            expected = None
        assert ok == (grammatical and expected is not None and math.isfinite(expected)), token
        assert digits == token.isdigit(), token
        if ok:
            assert number == expected, token


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=" \t1x\u00e9\u0663", max_size=40))
def test_count_tokens_matches_splitting(text):
    assert fap_file._count_tokens(text) == len(re.findall(r"[^ \t]+", text))


def test_written_file_has_the_usual_permissions(tmp_path):
    target = tmp_path / "shared.fap"
    write_fap(make_stream([0], np.zeros((1, N_FAPS)), np.zeros((1, N_FAPS))), target)
    reference = tmp_path / "plain.txt"
    reference.write_text("x")
    assert target.stat().st_mode == reference.stat().st_mode
